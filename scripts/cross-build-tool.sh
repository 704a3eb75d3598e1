#!/usr/bin/env bash
# Cross-builds rost's vision parts and the `rost` tool for 64-bit ARM boards
# (aarch64) against Debian's arm64 packages of OpenCV and libcamera
# (docs/cross.md, "The rost tool for a board").
#
#   scripts/cross-build-tool.sh [--sysroot DIR] [--build-dir DIR] [--refresh] [--no-test]
#
# Installing libopencv-dev:arm64 next to the amd64 one is not possible on
# Debian 12 (multiarch conflicts: libopencv-dev, libopenexr-dev, libgdal-dev
# and others are not Multi-Arch: same, so apt would remove the amd64 OpenCV).
# So this script makes a separate sysroot: apt, with a private state directory
# and the machine's own package sources, resolves and downloads libopencv-dev,
# libcamera-dev, libcli11-dev, libeigen3-dev and the C/C++ runtime for arm64 (about 430
# packages, 245 MB), unpacks them with dpkg -x into DIR and makes absolute
# symlinks relative. Nothing is installed on this machine and its package
# database is not touched. Then it configures with
# ROST_SYSROOT=DIR and toolchains/aarch64-linux-gnu.cmake, builds everything
# with ROST_VISION=ON and ROST_LIBCAMERA=ON, and (unless --no-test) runs the
# tests under qemu-aarch64 with the sysroot's libraries, `rost --help` and
# `rost-vision run --help`.
#
#   --sysroot DIR    where the arm64 root is made, outside the source tree
#                    (default: ~/.cache/rost/sysroot-arm64)
#   --build-dir DIR  the build directory (default: build-aarch64-tool)
#   --refresh        download and unpack again even if DIR is complete
#   --no-test        build only
# Environment: ROST_JOBS (default 2), ROST_CROSS_EXCLUDE (ctest -E regex; set it
# empty to run every test). Excluded by default: the time-budget test that
# scripts/cross-test.sh also excludes under emulation, and the tool tests (and
# the rost-cli commands' test, RostCli) that
# start the `rost` binary through /bin/sh (std::system): the shell is this
# machine's, which cannot execute an aarch64 program without binfmt_misc
# (not available in containers); the tool itself runs under qemu below.
#
# Needs: apt-get and dpkg (Debian), g++-aarch64-linux-gnu, cmake, ninja-build,
# qemu-user (tests), googletest (sources). Exit 2 when one is missing.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
sysroot=${XDG_CACHE_HOME:-$HOME/.cache}/rost/sysroot-arm64
build=$here/build-aarch64-tool
refresh=0
test=1
while [ $# -gt 0 ]; do
  case "$1" in
    --sysroot) sysroot=$2; shift 2 ;;
    --sysroot=*) sysroot=${1#--sysroot=}; shift ;;
    --build-dir) build=$2; shift 2 ;;
    --build-dir=*) build=${1#--build-dir=}; shift ;;
    --refresh) refresh=1; shift ;;
    --no-test) test=0; shift ;;
    -h|--help) sed -n '2,35p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "cross-build-tool: unknown argument '$1'" >&2; exit 2 ;;
  esac
done
jobs=${ROST_JOBS:-2}
exclude=${ROST_CROSS_EXCLUDE-'^EngineThreads\.EachObservationRefinesUntilNearItsTimeBudgetDeadline$|^FaultsOverload\.StarvedRefiner|^FaultsCrash\.KillDuringCheckpoint|^ToolCli\.|^ToolEndToEnd\.|^RostCli\.'}

missing=()
for tool in apt-get:apt dpkg:dpkg cmake:cmake ninja:ninja-build aarch64-linux-gnu-g++:g++-aarch64-linux-gnu \
            aarch64-linux-gnu-gcc:gcc-aarch64-linux-gnu qemu-aarch64:qemu-user; do
  command -v "${tool%%:*}" >/dev/null 2>&1 || missing+=("${tool#*:}")
done
[ -f /usr/src/googletest/CMakeLists.txt ] || missing+=(googletest)
if [ ${#missing[@]} -gt 0 ]; then
  echo "cross-build-tool: missing packages; install them with:" >&2
  echo "  apt-get install -y ${missing[*]}" >&2
  exit 2
fi

# The arm64 packages the vision parts and the tool build against. libc6-dev
# and libstdc++-12-dev put the target's C runtime and crt files in the sysroot
# (the cross compiler takes its C++ headers from its own installation).
packages=(libopencv-dev libcamera-dev libcli11-dev libpng-dev libeigen3-dev libc6-dev libstdc++-12-dev)

t0=$(date +%s)
stamp=$sysroot/.rost-sysroot-complete
if [ "$refresh" = 1 ] || [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "${packages[*]}" ]; then
  echo "=== cross-build-tool: arm64 sysroot in $sysroot"
  state=$sysroot.apt
  mkdir -p "$state/lists/partial" "$state/archives/partial"
  : > "$state/status"
  # A private apt: its own lists, cache and (empty) package status, arm64 as
  # the only architecture, the machine's sources, no lock on the real database.
  apt_opts=(-q -o "Dir::State=$state" -o "Dir::State::Lists=$state/lists" -o "Dir::State::status=$state/status"
            -o "Dir::Cache=$state" -o "Dir::Cache::archives=$state/archives"
            -o APT::Architecture=arm64 -o APT::Architectures=arm64 -o Debug::NoLocking=1
            -o Dir::Etc::preferences=/dev/null -o Dir::Etc::preferencesparts=/dev/null
            -o APT::Sandbox::User=root)
  apt-get "${apt_opts[@]}" update
  apt-get "${apt_opts[@]}" install -y --download-only --no-install-recommends "${packages[@]}"
  t1=$(date +%s)
  rm -rf "$sysroot"
  mkdir -p "$sysroot"
  n=0
  for deb in "$state"/archives/*.deb; do
    dpkg -x "$deb" "$sysroot"
    n=$((n + 1))
  done
  # Absolute symlinks (libz.so -> /lib/...) would point into this machine's
  # root: make them relative so they resolve inside the sysroot.
  while IFS= read -r link; do
    target=$(readlink "$link")
    ln -sfn "$(realpath -m --relative-to="$(dirname "$link")" "$sysroot$target")" "$link"
  done < <(find "$sysroot" -type l -lname '/*')
  # dpkg -x runs no maintainer scripts, so the update-alternatives links a
  # real install makes are missing; OpenCV's libraries need these two.
  for alt in blas/libblas.so.3 lapack/liblapack.so.3; do
    lib=$sysroot/usr/lib/aarch64-linux-gnu
    [ -e "$lib/$alt" ] && [ ! -e "$lib/${alt#*/}" ] && ln -s "$alt" "$lib/${alt#*/}"
  done
  echo "${packages[*]}" > "$stamp"
  t2=$(date +%s)
  echo "=== cross-build-tool: $n packages, download $((t1 - t0)) s, unpack $((t2 - t1)) s, $(du -sh "$sysroot" | cut -f1)"
fi

t3=$(date +%s)
echo "=== cross-build-tool: configure $build"
ROST_SYSROOT=$sysroot cmake -G Ninja -S "$here" -B "$build" \
  -DCMAKE_TOOLCHAIN_FILE="$here/toolchains/aarch64-linux-gnu.cmake" -DROST_SYSROOT="$sysroot" -DROST_ROS=OFF \
  -DCMAKE_BUILD_TYPE=Release -DROST_WERROR=ON -DROST_GTEST_FROM_SOURCE=ON \
  -DROST_VISION=ON -DROST_LIBCAMERA=ON -DROST_BUILD_TESTS=ON -DROST_BUILD_BENCH=ON -DROST_BUILD_EXAMPLES=ON \
  -DROST_PYTHON=OFF  # the host's python3 headers are not the board's (docs/python.md, "On a board")
echo "=== cross-build-tool: build"
cmake --build "$build" -j "$jobs"
t4=$(date +%s)
echo "=== cross-build-tool: built in $((t4 - t3)) s"
tool=
for cand in "$build/rost"; do
  if [ -x "$cand" ]; then
    tool=$cand
    break
  fi
done
[ -z "$tool" ] || file "$tool" 2>/dev/null || true
status=0
if [ "$test" = 1 ]; then
  echo "=== cross-build-tool: tests under qemu-aarch64 (sysroot libraries)"
  ctest_args=(-j "$jobs" --output-on-failure)
  [ -z "$exclude" ] || ctest_args+=(-E "$exclude")
  (cd "$build" && ctest "${ctest_args[@]}") || status=1
  if [ -n "$tool" ]; then
    qemu-aarch64 -L "$sysroot" "$tool" --help >/dev/null && echo "rost --help under qemu: ok" || status=1
    # `rost run` becomes rost-vision (execv), which qemu-user cannot follow: run it directly.
    qemu-aarch64 -L "$sysroot" "$(dirname "$tool")/rost-vision" run --help >/dev/null &&
      echo "rost-vision run --help under qemu: ok" || status=1
  fi
fi
echo "=== cross-build-tool: total $(( $(date +%s) - t0 )) s"
exit $status
