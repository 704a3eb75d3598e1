#!/usr/bin/env bash
# Every core past two (issue 32, items 2 and 4; bench/RESULTS.md "Every core
# past eight threads"): on a machine with many cores, in one run,
#   bench    bench_parallel's BM_RefineAllScaling (batch sweeps, 1 to 16
#            threads, K = 16 and 64) on the stream as a grid (with positions)
#            and as a word stream (one cell a step, as topics.refine.t);
#   command  the whole `rost refine` at each thread count, K = 16 and 64, grid
#            and word stream, RUNS runs interleaved, medians, and whether the
#            outputs are the same bytes for every thread count;
#   phases   the rest of a command: bench_parallel's reading, set-up (the
#            ring's pages zeroed on N threads) and final pass, and the start
#            of a process (`rost --version`);
#   cli      refinement alone: topics.refine.t's 20 sweeps on the stream (one
#            document an observation), the time its log gives, K = 16 and 64;
#   budget   bench/budget_threads.py: mean instantaneous and final perplexity
#            under the paper's time budget (10 and 40 ms) at each thread count.
# Results go to stdout and OUT/ (bench JSON, times.csv).
#
# Usage: bench/threads_scaling.sh WORDS.csv POSITIONS.csv OUT
# Settings (environment): ROST (build/rost), BENCH_PARALLEL
# (build/bench/bench_parallel), TRT (build/bin/topics.refine.t), THREADS ("1 2 4 8 16"), RUNS (3), PARTS
# ("bench command budget"), REPS (3, bench_parallel's repetitions).
set -euo pipefail
words=$(realpath "$1") positions=$(realpath "$2") out=$3
here=$(cd "$(dirname "$0")/.." && pwd)
rost=${ROST:-$here/build/rost}
bench=${BENCH_PARALLEL:-$here/build/bench/bench_parallel}
threads=${THREADS:-1 2 4 8 16}
runs=${RUNS:-3}
trt=$(realpath "${TRT:-$here/build/bin/topics.refine.t}")
parts=${PARTS:-bench phases cli command budget}
reps=${REPS:-3}
py=$(command -v /usr/bin/python3 || command -v python3)
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "machine: $(nproc) CPUs; $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"
# bench_parallel's rows (medians with repetitions); a failed run stops the script with its output.
run_bench() {
  if ! "$bench" "$@" > "$tmp/bench.txt" 2>&1; then
    cat "$tmp/bench.txt" >&2
    echo "threads_scaling: $bench $* failed" >&2
    exit 1
  fi
  grep -E '^BM' "$tmp/bench.txt" | grep -v '_mean \|_stddev \|_cv ' || { echo "threads_scaling: $bench ran no benchmark" >&2; exit 1; }
}
median() { sort -n | awk '{ x[NR] = $1 } END { print (NR % 2) ? x[(NR + 1) / 2] : (x[NR / 2] + x[NR / 2 + 1]) / 2 }'; }

if [[ " $parts " == *" bench "* ]]; then
  filter="BM_RefineAllScaling/threads:($(echo $threads | tr ' ' '|'))/"
  for layout in grid stream; do
    p=$positions
    [ "$layout" = stream ] && p=""
    echo "== bench_parallel, $layout"
    run_bench "$words" $p --benchmark_filter="$filter" --benchmark_repetitions="$reps" \
      --benchmark_report_aggregates_only=true --benchmark_out="$out/bench-$layout.json" --benchmark_out_format=json
  done
fi

if [[ " $parts " == *" phases "* ]]; then
  echo "== bench_parallel, the rest of a command"
  run_bench "$words" "$positions" --benchmark_filter='Read|SetUp|Final.*batch:1' --benchmark_repetitions="$reps" \
    --benchmark_report_aggregates_only=true
  for r in 1 2 3 4 5; do
    s=$(date +%s%N); "$rost" --version > /dev/null; e=$(date +%s%N)
    echo $(( (e - s) / 1000 ))
  done | sort -n | awk '{ x[NR] = $1 } END { print "== process start (rost --version), median of 5: " x[3] " us" }'
fi

if [[ " $parts " == *" cli "* ]]; then
  for K in 16 64; do
    line="== topics.refine.t -K $K -n 20, refinement alone:"
    one=""
    for t in $threads; do
      for r in $(seq 1 "$runs"); do
        mkdir -p "$tmp/trt-$K-$t" && (cd "$tmp/trt-$K-$t" && "$trt" -i "$words" -K "$K" -n 20 --threads "$t" > /dev/null)
        sed -n 's/^refined [0-9]* tokens in \([0-9.]*\) s.*/\1/p' "$tmp/trt-$K-$t/topics.log"
      done > "$tmp/trt-times"
      [ -s "$tmp/trt-times" ] || { echo "threads_scaling: no 'refined N tokens in S s' line in topics.refine.t's topics.log" >&2; exit 1; }
      m=$(median < "$tmp/trt-times")
      [ -n "$one" ] || one=$m
      line+=" $t: ${m}s ($(awk -v a="$one" -v b="$m" 'BEGIN { printf "%.2f", a / b }')x)"
      cmp -s "$tmp/trt-$K-1/topics.csv" "$tmp/trt-$K-$t/topics.csv" || line+=" [topics.csv differs]"
    done
    echo "$line"
  done
fi

if [[ " $parts " == *" command "* ]]; then
  echo "layout,K,threads,run,seconds" > "$out/times.csv"
  for layout in grid stream; do
    for K in 16 64; do
      args=("$words" -K "$K" -q)
      [ "$layout" = grid ] && args+=(--positions "$positions")
      for r in $(seq 1 "$runs"); do
        for t in $threads; do
          s=$(date +%s%N)
          "$rost" refine "${args[@]}" --threads "$t" --out "$tmp/$layout-$K-$t"
          e=$(date +%s%N)
          echo "$layout,$K,$t,$r,$(awk -v a="$s" -v b="$e" 'BEGIN { printf "%.3f", (b - a) / 1e9 }')" >> "$out/times.csv"
        done
      done
      line="== rost refine, $layout, K = $K:"
      one=""
      for t in $threads; do
        m=$(grep "^$layout,$K,$t," "$out/times.csv" | cut -d, -f5 | median)
        [ -n "$one" ] || one=$m
        line+=" $t: ${m}s ($(awk -v a="$one" -v b="$m" 'BEGIN { printf "%.2f", a / b }')x)"
        for f in topics.csv topicmodel.csv perplexity.csv; do
          cmp -s "$tmp/$layout-$K-1/$f" "$tmp/$layout-$K-$t/$f" || line+=" [$f differs]"
        done
      done
      echo "$line"
    done
  done
fi

if [[ " $parts " == *" budget "* ]]; then
  echo "== rost refine --budget.ms (medians of $runs runs' means)"
  ROST_TOOL="$rost" "$py" "$here/bench/budget_threads.py" --words "$words" --positions "$positions" \
    --budget 10 40 --threads $threads --repeat "$runs"
fi
