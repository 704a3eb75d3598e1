# Cross-architecture determinism (issue 5): the same checksum on x86-64,
# aarch64 and armhf; scripts/cross-test.sh runs it under qemu.
rost_add_test(test_determinism SOURCES test_determinism.cpp)
