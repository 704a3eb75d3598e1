# Cross toolchain for 32-bit ARMv7-A Linux boards with hardware floating point
# (Debian armhf: Raspberry Pi 2/3 in 32-bit mode, BeagleBone, i.MX 6).
#   cmake -G Ninja -S . -B build-armhf \
#         -DCMAKE_TOOLCHAIN_FILE=toolchains/arm-linux-gnueabihf.cmake -DROST_GTEST_FROM_SOURCE=ON
# Needs g++-arm-linux-gnueabihf; qemu-user to run the tests here.
#
# ROST_CROSS_NEON (default ON) compiles for ARMv7-A with NEON, so the kernel's
# NEON path runs. For a board without NEON (some Cortex-A9/A5 parts) configure
# with -DROST_CROSS_NEON=OFF: the kernel then uses its scalar path, which gives
# the same results bit for bit (docs/cross.md). GCC never uses NEON for scalar
# float code unless -funsafe-math-optimizations is given (NEON flushes
# denormals to zero), so scalar code keeps IEEE semantics either way.
set(ROST_CROSS_TRIPLE arm-linux-gnueabihf)
set(ROST_CROSS_PROCESSOR armv7l)
set(ROST_CROSS_QEMU qemu-arm)
if(NOT DEFINED ROST_CROSS_NEON AND DEFINED ENV{ROST_CROSS_NEON})
  set(ROST_CROSS_NEON "$ENV{ROST_CROSS_NEON}")
endif()
if(NOT DEFINED ROST_CROSS_NEON OR ROST_CROSS_NEON)
  set(CMAKE_C_FLAGS_INIT "-march=armv7-a -mfpu=neon -mfloat-abi=hard")
else()
  set(CMAKE_C_FLAGS_INIT "-march=armv7-a -mfpu=vfpv3-d16 -mfloat-abi=hard")
endif()
set(CMAKE_CXX_FLAGS_INIT "${CMAKE_C_FLAGS_INIT}")
include(${CMAKE_CURRENT_LIST_DIR}/linux-cross-common.cmake)
