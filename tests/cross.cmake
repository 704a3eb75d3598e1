# Cross-architecture determinism (issue 5): the same checksum on x86-64,
# aarch64 and armhf; scripts/cross-test.sh runs it under qemu.
rost_add_test(test_determinism SOURCES test_determinism.cpp)
# With the engine in the tree, replay also goes through its synchronous mode.
if(EXISTS ${PROJECT_SOURCE_DIR}/src/core/engine.cpp)
  target_compile_definitions(test_determinism PRIVATE ROST_TEST_ENGINE=1)
endif()
