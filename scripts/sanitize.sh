#!/usr/bin/env bash
# Builds the whole test suite under a sanitizer and runs it with ctest:
#   scripts/sanitize.sh address   AddressSanitizer + UndefinedBehaviorSanitizer
#                                 (every report fatal) in build-asan/
#   scripts/sanitize.sh thread    ThreadSanitizer in build-tsan/
# Extra arguments go to ctest (e.g. -R test_engine). The Python package is
# not built here (ROST_PYTHON=OFF): a sanitized extension would need the
# sanitizer's runtime preloaded into an uninstrumented python3. Suppressions for
# third-party code that is not built with the sanitizer live in
# tests/sanitizers/ (each entry says why).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
mode=${1:-}
shift || true
case "$mode" in
  address)
    dir=build-asan
    single_threaded=
    # -O1, as AddressSanitizer's documentation advises: the build takes about
    # half as long as at -O2 and the suite runs as fast (bench/RESULTS.md, "CI").
    opt=-O1
    flags="-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer"
    # No detect_stack_use_after_return: its fake stacks are touched slot by slot
    # over a long run, so resident memory creeps up and the tests that check
    # memory stays flat would measure the sanitizer, not the engine.
    export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:strict_string_checks=1:check_initialization_order=1:fast_unwind_on_malloc=0"
    export LSAN_OPTIONS="suppressions=$root/tests/sanitizers/lsan.supp:print_suppressions=0"
    export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:suppressions=$root/tests/sanitizers/ubsan.supp"
    ;;
  thread)
    dir=build-tsan
    opt=-O2
    flags="-fsanitize=thread -fno-omit-frame-pointer"
    export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$root/tests/sanitizers/tsan.supp:print_suppressions=0"
    # ThreadSanitizer finds races, and these suites start no thread of their
    # own: the sampler's and the recovery's statistical tests (one thread by
    # construction), pixel formats, image files and vocabulary files (pure
    # functions), and the tool's argument errors (ToolCli: its runs' threads are
    # ToolEndToEnd's, ToolTrust's and ToolWords', which stay). They run in the
    # plain build and under ASan+UBSan; here they took about 200 of 580 s.
    single_threaded='^(ToolCli|VisionImageFile|VocabularyFileErrors|VisionPixelFormat|NeighbourhoodMatters|BatchGibbsRecovery|GrowthConditional|ExactConditionalInCell|Scenes/ExactConditional|AllStrategies/StrategyDraws|RadiusZeroIsLda)\.'
    ;;
  *)
    echo "usage: scripts/sanitize.sh address|thread [ctest args]" >&2
    exit 2
    ;;
esac
jobs=${ROST_JOBS:-2}
# -g1 (line tables): a report's stack still names file and line, and the
# build takes about a third less time than with full debug information.
cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="$opt -g1 -DNDEBUG" \
  -DROST_WERROR=ON \
  -DROST_BUILD_BENCH=OFF -DROST_BUILD_EXAMPLES=OFF -DROST_PYTHON=OFF -DROST_ROS=OFF \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="$flags" -DCMAKE_SHARED_LINKER_FLAGS="$flags" >/dev/null
cmake --build "$dir" -j "$jobs"
# Sanitized runs are several times slower. The tests that measure time (label
# `timed`: deadlines, budgets, the engine's threads) run one at a time, so a
# neighbour's load does not decide them on a 2-core machine; the rest run two
# at a time (ROST_CTEST_JOBS), which halves the step's test time.
exclude=()
[ -n "$single_threaded" ] && exclude=(-E "$single_threaded")
ctest --test-dir "$dir" --output-on-failure -j "${ROST_CTEST_JOBS:-2}" -LE timed "${exclude[@]}" "$@"
ctest --test-dir "$dir" --output-on-failure -j 1 -L timed "${exclude[@]}" "$@"
