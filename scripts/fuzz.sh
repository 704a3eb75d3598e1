#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/) with clang, AddressSanitizer and
# UndefinedBehaviorSanitizer in build-fuzz/, and runs each for a bounded time
# from its committed seed corpus (fuzz/corpus/<target>/). Fails on any crash,
# leak, timeout or sanitizer report; the input that caused it is kept in
# build-fuzz/artifacts/<target>/.
#
# Inputs the run found that add coverage over the committed corpus are
# copied to build-fuzz/corpus-additions/<target>/; with --update they go
# straight into fuzz/corpus/<target>/, ready to commit.
#
# Usage: scripts/fuzz.sh [SECONDS_PER_TARGET] [--update] [--seeds] [TARGET...]
#   SECONDS_PER_TARGET  default 30
#   --seeds             regenerate the binary seeds (checkpoint, vocabulary) first
#   TARGET              word_stream checkpoint vocabulary config_file image_file (default: all)
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

seconds=30
update=0
seeds=0
targets=()
for arg in "$@"; do
  case "$arg" in
    --update) update=1 ;;
    --seeds) seeds=1 ;;
    ''|*[!0-9]*) targets+=("$arg") ;;
    *) seconds=$arg ;;
  esac
done
[ ${#targets[@]} -gt 0 ] || targets=(word_stream checkpoint vocabulary config_file image_file)

# Largest input per target (bytes): enough for a seed checkpoint or a few
# hundred vocabulary words, small enough to keep executions fast.
max_len() {
  case "$1" in
    checkpoint) echo 16384 ;;
    vocabulary) echo 16384 ;;
    *) echo 4096 ;;
  esac
}

build=build-fuzz
# fuzz/ builds the parsers alone: no vision, no ROS (ROST_ROS=OFF, as in the sanitizer and cross builds).
cmake -S fuzz -B "$build" -G Ninja -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DROST_ROS=OFF --no-warn-unused-cli >/dev/null
cmake --build "$build" -j 2

if [ "$seeds" = 1 ]; then
  "$build/make_fuzz_seeds" fuzz/corpus
fi

export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:symbolize=1:strict_string_checks=1:detect_stack_use_after_return=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"

failed=()
for t in "${targets[@]}"; do
  bin="$build/fuzz_$t"
  [ -x "$bin" ] || { echo "fuzz.sh: unknown target '$t'" >&2; exit 2; }
  seed_dir="fuzz/corpus/$t"
  work="$build/corpus/$t"
  artifacts="$build/artifacts/$t"
  mkdir -p "$work" "$artifacts" "$seed_dir"
  echo "=== fuzz_$t: ${seconds}s"
  start=$(date +%s)
  # New inputs go to the first corpus directory (the work one); the
  # committed seeds are read only.
  if ! "$bin" "$work" "$seed_dir" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
      -max_len="$(max_len "$t")" -artifact_prefix="$artifacts/" -print_final_stats=1 \
      >"$build/fuzz_$t.log" 2>&1; then
    echo "fuzz_$t FAILED (log: $build/fuzz_$t.log, input: $(ls -t "$artifacts" | head -1))"
    grep -E "ERROR|SUMMARY|runtime error|Test unit written" "$build/fuzz_$t.log" | head -20 || true
    failed+=("$t")
    continue
  fi
  grep -E "^stat::(number_of_executed_units|peak_rss_mb)|^#[0-9]+.*DONE" "$build/fuzz_$t.log" | tr '\n' ' ' || true
  echo
  # Keep what adds coverage over the committed corpus: merge into a copy of
  # it and take the files the merge added.
  merged="$build/merge/$t"
  rm -rf "$merged" && mkdir -p "$merged"
  cp -r "$seed_dir"/. "$merged"/
  "$bin" -merge=1 "$merged" "$work" -max_len="$(max_len "$t")" >"$build/merge_$t.log" 2>&1 || true
  additions="$build/corpus-additions/$t"
  rm -rf "$additions" && mkdir -p "$additions"
  n=0
  for f in "$merged"/*; do
    [ -e "$seed_dir/$(basename "$f")" ] && continue
    cp "$f" "$additions/"
    n=$((n + 1))
  done
  if [ "$update" = 1 ] && [ "$n" -gt 0 ]; then
    cp "$additions"/* "$seed_dir"/
    echo "fuzz_$t: $n new inputs added to $seed_dir (commit them)"
  else
    echo "fuzz_$t: $n inputs add coverage over $seed_dir: $additions ($(( $(date +%s) - start )) s)"
  fi
done

if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz.sh: FAILED: ${failed[*]}" >&2
  exit 1
fi
echo "fuzz.sh: all targets ran ${seconds}s without a crash, leak or sanitizer report"
