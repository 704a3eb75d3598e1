# Cross toolchain for 64-bit ARM Linux boards (Jetson, Raspberry Pi 4/5, i.MX 8).
#   cmake -G Ninja -S . -B build-aarch64 \
#         -DCMAKE_TOOLCHAIN_FILE=toolchains/aarch64-linux-gnu.cmake -DROST_GTEST_FROM_SOURCE=ON
# Needs g++-aarch64-linux-gnu; qemu-user to run the tests here. Optional:
# ROST_SYSROOT=<board root fs copy> or ROST_MULTIARCH=ON (see docs/cross.md).
# NEON (Advanced SIMD) is part of the ARMv8-A base ISA: the kernel's NEON path
# is always the one compiled.
set(ROST_CROSS_TRIPLE aarch64-linux-gnu)
set(ROST_CROSS_PROCESSOR aarch64)
set(ROST_CROSS_QEMU qemu-aarch64)
include(${CMAKE_CURRENT_LIST_DIR}/linux-cross-common.cmake)
