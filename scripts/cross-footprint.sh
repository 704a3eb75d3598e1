#!/usr/bin/env bash
# The figures of bench/RESULTS.md, "ARM footprint (issue 5)": library and tool
# sizes, the memory the model and engine allocate, and instructions per token
# refinement at K = 16 on x86-64, aarch64 and armhf.
#
#   scripts/cross-footprint.sh [--build-root DIR]
#
# Uses the build directories of scripts/cross-test.sh (build-aarch64,
# build-armhf; run it first) and a native one (build-cross-host, configured
# here), plus build-aarch64-tool from scripts/cross-build-tool.sh
# when it exists. Instruction counts: the difference between
# `footprint refine 3` and `footprint refine 0` (same set-up, three more batch
# sweeps) divided by the tokens those sweeps refined, counted
#   * on ARM and x86-64 with bench/qemu_insn_count.c, a qemu-user plugin
#     (compiled here for the host), and
#   * on x86-64 also with valgrind --tool=callgrind (valgrind cannot run
#     aarch64 programs on an x86-64 host).
# Needs cmake, ninja, a host C compiler, qemu-user, valgrind, binutils for
# each target (installed with the cross compilers).
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build_root=$here
while [ $# -gt 0 ]; do
  case "$1" in
    --build-root) build_root=$2; shift 2 ;;
    --build-root=*) build_root=${1#--build-root=}; shift ;;
    -h|--help) sed -n '2,20p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "cross-footprint: unknown argument '$1'" >&2; exit 2 ;;
  esac
done
jobs=${ROST_JOBS:-2}
sweeps=3

host=$build_root/build-cross-host
cmake -G Ninja -S "$here" -B "$host" -DCMAKE_BUILD_TYPE=Release -DROST_WERROR=ON -DROST_BUILD_BENCH=ON \
  -DROST_BUILD_EXAMPLES=OFF -DROST_VISION=OFF >/dev/null
cmake --build "$host" -j "$jobs" --target footprint rost_core >/dev/null

plugin=$host/qemu_insn_count.so
cc -shared -fPIC -O2 -Wall -Wextra -o "$plugin" "$here/bench/qemu_insn_count.c"

# insns RUNNER... -- PROGRAM ARGS: instructions the program executes.
qemu_insns() {  # qemu prefix program args...
  local qemu=$1 prefix=$2
  shift 2
  local log
  log=$(mktemp)
  "$qemu" ${prefix:+-L "$prefix"} -plugin "$plugin" -d plugin -D "$log" "$@" >/dev/null
  sed -n 's/^insns: //p' "$log"
  rm -f "$log"
}
callgrind_insns() {
  local out
  out=$(mktemp)
  valgrind --tool=callgrind --callgrind-out-file="$out" "$@" 2>&1 >/dev/null | sed -n 's/.*Collected : //p'
  rm -f "$out"
}
tokens_of() { "$@" | sed -n 's/.* tokens=//p'; }

per_token() {  # label counter [qemu prefix] program [--scalar]
  local label=$1 counter=$2 qemu=$3 prefix=$4 prog=$5 mode=${6:-}
  local i0 i1 n
  if [ "$counter" = callgrind ]; then
    i0=$(callgrind_insns "$prog" refine 0 $mode)
    i1=$(callgrind_insns "$prog" refine $sweeps $mode)
    n=$(tokens_of "$prog" refine $sweeps $mode)
  else
    i0=$(qemu_insns "$qemu" "$prefix" "$prog" refine 0 $mode)
    i1=$(qemu_insns "$qemu" "$prefix" "$prog" refine $sweeps $mode)
    if [ -n "$qemu" ]; then n=$(tokens_of "$qemu" ${prefix:+-L "$prefix"} "$prog" refine $sweeps $mode)
    else n=$(tokens_of "$prog" refine $sweeps $mode); fi
  fi
  awk -v l="$label" -v a="$i0" -v b="$i1" -v n="$n" \
    'BEGIN { printf "| %s | %d | %d | %d | %.1f |\n", l, a, b, n, (b - a) / n }'
}

echo "## instructions per token refinement (K = 16, V = 5436, 80 cells, ${sweeps} sweeps after 2)"
echo "| target, kernel, counter | insns refine 0 | insns refine $sweeps | tokens | insns/token |"
echo "|---|---|---|---|---|"
per_token "x86-64 sse2, callgrind" callgrind "" "" "$host/bench/footprint"
per_token "x86-64 scalar, callgrind" callgrind "" "" "$host/bench/footprint" --scalar
per_token "x86-64 sse2, qemu plugin" qemu qemu-x86_64 "" "$host/bench/footprint"
for t in aarch64 armhf; do
  dir=$build_root/build-$t
  if [ ! -x "$dir/bench/footprint" ]; then
    echo "| $t | (no $dir/bench/footprint: run scripts/cross-test.sh $t first) | | | |"
    continue
  fi
  case $t in
    aarch64) qemu=qemu-aarch64; prefix=/usr/aarch64-linux-gnu ;;
    armhf) qemu=qemu-arm; prefix=/usr/arm-linux-gnueabihf ;;
  esac
  per_token "$t neon, qemu plugin" qemu $qemu $prefix "$dir/bench/footprint"
  per_token "$t scalar, qemu plugin" qemu $qemu $prefix "$dir/bench/footprint" --scalar
done

echo
echo "## sizes (bytes)"
echo "| target | librost_core.a file | core text+data+bss (size -t) | footprint stripped | rost tool stripped |"
echo "|---|---|---|---|---|"
sizes() {  # label dir binutils-prefix
  local label=$1 dir=$2 pre=$3 lib core fp tool="-"
  lib=$(stat -c %s "$dir/librost_core.a")
  core=$("${pre}size" -t "$dir/librost_core.a" | awk '/TOTALS/ { print $1 " + " $2 " + " $3 }')
  fp=$(tmp=$(mktemp) && "${pre}strip" -o "$tmp" "$dir/bench/footprint" && stat -c %s "$tmp" && rm -f "$tmp")
  for cand in "$dir-tool/rost" "$dir/rost"; do
    if [ -x "$cand" ]; then
      tool=$(tmp=$(mktemp) && "${pre}strip" -o "$tmp" "$cand" && stat -c %s "$tmp" && rm -f "$tmp")
      break
    fi
  done
  echo "| $label | $lib | $core | $fp | $tool |"
}
sizes x86-64 "$host" ""
[ -f "$build_root/build-aarch64/librost_core.a" ] && sizes aarch64 "$build_root/build-aarch64" aarch64-linux-gnu-
[ -f "$build_root/build-armhf/librost_core.a" ] && sizes armhf "$build_root/build-armhf" arm-linux-gnueabihf-

echo
echo "## memory (footprint memory)"
echo '```'
echo "x86-64:"; "$host/bench/footprint" memory
[ -x "$build_root/build-aarch64/bench/footprint" ] &&
  { echo "aarch64:"; qemu-aarch64 -L /usr/aarch64-linux-gnu "$build_root/build-aarch64/bench/footprint" memory; }
[ -x "$build_root/build-armhf/bench/footprint" ] &&
  { echo "armhf:"; qemu-arm -L /usr/arm-linux-gnueabihf "$build_root/build-armhf/bench/footprint" memory; }
echo '```'
