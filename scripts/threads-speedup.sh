#!/usr/bin/env bash
# Issue 13's bar, measured: wall time of the whole `rost refine WORDS
# --positions POSITIONS --out DIR -q` (default settings, summary.png too)
# with --threads 1 and --threads 2, RUNS runs each, interleaved, the median
# and the ratio; then whether the outputs are byte-identical. Give more
# rost binaries (an older build) to measure them in the same interleaved
# runs. Then, where taskset is at hand, the first binary's one-thread time on
# each of CPUs 0 and 1 alone: where the two differ (a virtual machine whose
# second core shares its caches with another guest), two threads cannot
# beat the time both would take together, 1 / (1/T0 + 1/T1), and the script
# says so. Last, where build/bench/bench_kernel is built, the one-thread time
# on CPU 0 while the refinement kernel's benchmark runs on CPU 1: where that
# load slows CPU 0 down, the two "cores" are one core's two hardware threads
# (SMT), which share its caches and execution units, and two threads cannot
# speed refinement up much. bench/RESULTS.md, "Every core".
# Usage: scripts/threads-speedup.sh WORDS.csv POSITIONS.csv [RUNS] [ROST...]
set -euo pipefail
words=$1 positions=$2 runs=${3:-9}
shift $(( $# < 3 ? $# : 3 ))
cd "$(dirname "$0")/.."
tools=("$@")
[ ${#tools[@]} -gt 0 ] || tools=(build/rost)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

for i in $(seq 1 "$runs"); do
  for b in "${!tools[@]}"; do
    for t in 1 2; do
      /usr/bin/time -f "%e" -o "$tmp/time" "${tools[$b]}" refine "$words" --positions "$positions" \
        --out "$tmp/out$b-$t" --threads "$t" -q
      cat "$tmp/time" >> "$tmp/times$b-$t"
    done
  done
done
median() { sort -n "$1" | awk '{ x[NR] = $1 } END { print (NR % 2) ? x[(NR + 1) / 2] : (x[NR / 2] + x[NR / 2 + 1]) / 2 }'; }
for b in "${!tools[@]}"; do
  m1=$(median "$tmp/times$b-1") m2=$(median "$tmp/times$b-2")
  echo "${tools[$b]}: threads 1: $(sort -n "$tmp/times$b-1" | tr '\n' ' ')s (median $m1)"
  echo "${tools[$b]}: threads 2: $(sort -n "$tmp/times$b-2" | tr '\n' ' ')s (median $m2)"
  echo "${tools[$b]}: speed-up $(awk -v a="$m1" -v b="$m2" 'BEGIN { printf "%.2f", a / b }')x"
  # Each run at one thread is followed by one at two: the median of the
  # pairs' ratios is less moved by the host's busy spells than the ratio of
  # the medians (a spell that slows both runs of a pair cancels out).
  paste "$tmp/times$b-1" "$tmp/times$b-2" | awk '{ print $1 / $2 }' > "$tmp/ratios$b"
  echo "${tools[$b]}: median of the $runs pairs' speed-ups $(median "$tmp/ratios$b" | awk '{ printf "%.2f", $1 }')x"
  for f in topics.csv topicmodel.csv perplexity.csv surprise.csv surprise_cells.csv; do
    cmp -s "$tmp/out$b-1/$f" "$tmp/out$b-2/$f" || { echo "${tools[$b]}: $f differs between 1 and 2 threads"; exit 1; }
  done
  echo "${tools[$b]}: outputs of --threads 1 and 2 byte-identical"
done

command -v taskset > /dev/null && [ "$(nproc)" -ge 2 ] || exit 0
for i in $(seq 1 "$runs"); do
  for c in 0 1; do
    /usr/bin/time -f "%e" -o "$tmp/time" taskset -c "$c" "${tools[0]}" refine "$words" --positions "$positions" \
      --out "$tmp/pinned" --threads 1 -q
    cat "$tmp/time" >> "$tmp/cpu$c"
  done
done
c0=$(median "$tmp/cpu0") c1=$(median "$tmp/cpu1") m2=$(median "$tmp/times0-2")
echo "${tools[0]}: threads 1 on CPU 0 alone: median ${c0}s; on CPU 1 alone: median ${c1}s"
awk -v a="$c0" -v b="$c1" -v t2="$m2" 'BEGIN {
  ideal = 1 / (1 / a + 1 / b); fast = a < b ? a : b; slow = a < b ? b : a
  printf "cores: the slower takes %.2fx the faster'"'"'s time; two threads at best %.3fs (both cores busy to the end, nothing serial):\n", slow / fast, ideal
  printf "  at most %.2fx the faster core alone; measured %.2fx of it (%.0f %% of that best)\n", fast / ideal, fast / t2, 100 * ideal / t2
}'

kernel=build/bench/bench_kernel
[ -x "$kernel" ] || exit 0
for i in $(seq 1 "$runs"); do
  taskset -c 1 "$kernel" --benchmark_filter='^BM_Refine/K:16/scalar:0/W:256$' --benchmark_min_time=60 > /dev/null 2>&1 &
  load=$!
  sleep 0.5
  /usr/bin/time -f "%e" -o "$tmp/time" taskset -c 0 "${tools[0]}" refine "$words" --positions "$positions" \
    --out "$tmp/pinned" --threads 1 -q
  kill "$load" 2> /dev/null || true
  wait "$load" 2> /dev/null || true
  cat "$tmp/time" >> "$tmp/loaded"
done
l0=$(median "$tmp/loaded")
awk -v a="$c0" -v l="$l0" 'BEGIN {
  printf "threads 1 on CPU 0 while the K = 16 kernel runs on CPU 1: median %.2fs, %.2fx its time alone", l, l / a
  if (l / a > 1.3) printf ": CPUs 0 and 1 share one core (SMT siblings), so two threads cannot reach twice one"
  printf "\n"
}'
