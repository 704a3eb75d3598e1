# Shared part of the Linux cross toolchain files (toolchains/<triple>.cmake).
# The including file sets ROST_CROSS_TRIPLE, ROST_CROSS_PROCESSOR and
# ROST_CROSS_QEMU before including this one.
#
# Three ways to find the target's libraries (see docs/cross.md):
#   * default: the Debian cross compiler's own C/C++ runtime in /usr/<triple>;
#     the core needs nothing else (Eigen is header-only and taken from the host).
#   * ROST_SYSROOT=<dir> (environment or -D): a copy of the board's root file
#     system; everything is searched there and qemu loads the board's libraries.
#   * ROST_MULTIARCH=ON (environment or -D): Debian multiarch packages installed
#     on this machine (apt-get install libopencv-dev:arm64 ...), found in
#     /usr/lib/<triple> and /usr/include.
#
# CMake reads a toolchain file again for every try_compile, so everything here
# is idempotent and only caches what a user may override.

set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR ${ROST_CROSS_PROCESSOR})

# Values given in the environment are forwarded to try_compile projects.
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES ROST_SYSROOT ROST_MULTIARCH ROST_CROSS_NEON)
if(NOT DEFINED ROST_SYSROOT AND DEFINED ENV{ROST_SYSROOT})
  set(ROST_SYSROOT "$ENV{ROST_SYSROOT}")
endif()
if(NOT DEFINED ROST_MULTIARCH AND DEFINED ENV{ROST_MULTIARCH})
  set(ROST_MULTIARCH "$ENV{ROST_MULTIARCH}")
endif()

set(CMAKE_C_COMPILER ${ROST_CROSS_TRIPLE}-gcc)
set(CMAKE_CXX_COMPILER ${ROST_CROSS_TRIPLE}-g++)
set(CMAKE_LIBRARY_ARCHITECTURE ${ROST_CROSS_TRIPLE})

if(ROST_SYSROOT)
  if(NOT IS_DIRECTORY "${ROST_SYSROOT}")
    message(FATAL_ERROR "ROST_SYSROOT=${ROST_SYSROOT} is not a directory (a copy of the board's root file system)")
  endif()
  set(CMAKE_SYSROOT "${ROST_SYSROOT}")
  set(CMAKE_FIND_ROOT_PATH "${ROST_SYSROOT}")
  set(_rost_qemu_prefix "${ROST_SYSROOT}")
  # pkg-config (libcamera, OpenCV without CMake files) reads the board's .pc files.
  set(ENV{PKG_CONFIG_SYSROOT_DIR} "${ROST_SYSROOT}")
  set(ENV{PKG_CONFIG_LIBDIR}
      "${ROST_SYSROOT}/usr/lib/${ROST_CROSS_TRIPLE}/pkgconfig:${ROST_SYSROOT}/usr/lib/pkgconfig:${ROST_SYSROOT}/usr/share/pkgconfig")
elseif(ROST_MULTIARCH)
  # The host's root holds the multiarch packages: /usr/lib/<triple> is the
  # target's library directory; /usr/include is shared by all architectures.
  # x86-64 libraries live in /usr/lib/x86_64-linux-gnu, which is never searched
  # because CMAKE_LIBRARY_ARCHITECTURE is the target's.
  set(CMAKE_FIND_ROOT_PATH "/usr/${ROST_CROSS_TRIPLE};/")
  set(_rost_qemu_prefix "/usr/${ROST_CROSS_TRIPLE}")
  set(ENV{PKG_CONFIG_SYSROOT_DIR} "")
  set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/${ROST_CROSS_TRIPLE}/pkgconfig:/usr/share/pkgconfig")
else()
  # Only the cross compiler's runtime (Debian packages libc6-dev-<arch>-cross,
  # libstdc++-12-dev-<arch>-cross): nothing of the host is taken by accident,
  # so optional packages (OpenCV, libcamera, Google Benchmark) are simply not found.
  set(CMAKE_FIND_ROOT_PATH "/usr/${ROST_CROSS_TRIPLE}")
  set(_rost_qemu_prefix "/usr/${ROST_CROSS_TRIPLE}")
  set(ENV{PKG_CONFIG_SYSROOT_DIR} "/usr/${ROST_CROSS_TRIPLE}")
  set(ENV{PKG_CONFIG_LIBDIR} "/usr/${ROST_CROSS_TRIPLE}/lib/pkgconfig")
endif()

# Programs (compilers, code generators) run on the build machine; libraries,
# headers and CMake packages come from the target root only.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

# Eigen is header-only and architecture independent: without a target copy
# (sysroot or multiarch root), use the host's package by pointing Eigen3_DIR at
# it. An explicit <Package>_DIR is used as given, not re-rooted, so this does
# not open the host's root to any other search.
# A sysroot or multiarch root with its own libeigen3-dev is used as it is.
set(_rost_eigen_in_root FALSE)
foreach(_root IN LISTS CMAKE_FIND_ROOT_PATH)
  if(EXISTS "${_root}/usr/share/eigen3/cmake/Eigen3Config.cmake")
    set(_rost_eigen_in_root TRUE)
  endif()
endforeach()
if(NOT _rost_eigen_in_root AND NOT DEFINED Eigen3_DIR AND EXISTS /usr/share/eigen3/cmake/Eigen3Config.cmake)
  set(Eigen3_DIR /usr/share/eigen3/cmake CACHE PATH "Eigen3 (header-only) package directory")
endif()

# Run target programs (ctest, gtest_discover_tests at build time) with qemu-user.
find_program(ROST_QEMU_EXECUTABLE ${ROST_CROSS_QEMU})
if(ROST_QEMU_EXECUTABLE)
  set(CMAKE_CROSSCOMPILING_EMULATOR "${ROST_QEMU_EXECUTABLE};-L;${_rost_qemu_prefix}")
endif()
