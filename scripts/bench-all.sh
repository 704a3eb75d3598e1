#!/usr/bin/env bash
# Runs every benchmark under bench/ and rewrites their figures in bench/RESULTS.md.
#
#   scripts/bench-all.sh [--build DIR] [--repetitions N] [--experiment none|small|reduced|full]
#                        [--with-cross] [--only NAME[,NAME...]] [--list]
#
# Each bench owns one delimited section of bench/RESULTS.md,
#     <!-- begin:NAME --> ... <!-- end:NAME -->
# and only the text between its markers is rewritten (scripts/results-section.py):
# hand-written findings around the markers and other benches' sections stay as they
# are. Move a bench's markers anywhere in the file and later runs update it there.
#
# What runs:
#   * every Google Benchmark program the build puts in bench/ (linked against
#     libbenchmark), each `--benchmark_repetitions=N` (default 5), medians;
#     rendered by the bench's own renderer when it has one:
#       - scripts/bench-NAME.sh BUILD_DIR JSON  (prints the section's markdown), or
#       - a renderer known here (bench_scaling: bench/scaling_report.py),
#     else as a generic table; section NAME, under "## Benchmark programs" unless
#     its markers are already elsewhere;
#   * the plain measurement programs in bench/ (bench_soak, bench_checkpoint,
#     footprint memory; or scripts/bench-NAME.sh BUILD_DIR when it exists), their
#     output verbatim in section NAME;
#   * the paper experiment, scripts/experiment.sh --small by default (sections
#     experiment-MODE under "## Paper experiment (issue 6)"); --experiment none skips it;
#   * with --with-cross, scripts/cross-footprint.sh (needs the cross builds of
#     scripts/cross-test.sh; section footprint under "## ARM footprint (issue 5)").
# Build directory default: build-bench (configured with -DROST_WERROR=ON if missing,
# built with -j2). The run's command, commit, machine and duration go to section bench-all.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build="$here/build-bench"
reps=5
experiment=small
cross=0
only=""
list=0
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build=$2; shift 2 ;;
    --repetitions) reps=$2; shift 2 ;;
    --experiment) experiment=$2; shift 2 ;;
    --with-cross) cross=1; shift ;;
    --only) only=",$2,"; shift 2 ;;
    --list) list=1; shift ;;
    -h|--help) sed -n '2,30p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench-all: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
case $experiment in none|small|reduced|full) ;; *) echo "bench-all: --experiment none|small|reduced|full" >&2; exit 2 ;; esac

py=python3
[ -x /usr/bin/python3 ] && py=/usr/bin/python3
results="$here/bench/RESULTS.md"
section() { "$py" "$here/scripts/results-section.py" replace "$results" "$@"; }
wanted() { [ -z "$only" ] || [[ "$only" == *",$1,"* ]]; }
start_s=$(date +%s)
started=$(date -u +%Y-%m-%dT%H:%M:%SZ)
log() { echo "bench-all [$(( $(date +%s) - start_s ))s]: $*" >&2; }

# ---- build every bench program --------------------------------------------------------------------
if [ ! -f "$build/build.ninja" ]; then
  log "configuring $build"
  cmake -S "$here" -B "$build" -G Ninja -DROST_WERROR=ON >/dev/null
fi
targets=$(ninja -C "$build" -t targets all | sed -n 's#^\(bench/[A-Za-z0-9_-]*\): CXX_EXECUTABLE_LINKER.*#\1#p')
log "building: $(echo $targets | tr '\n' ' ')"
# shellcheck disable=SC2086
ninja -C "$build" -j2 $targets >/dev/null

tmp=$(mktemp -d)
tmpdir="$tmp/scratch"
mkdir -p "$tmpdir"
trap 'rm -rf "$tmp"' EXIT
benches=()
plain=()
for t in $targets; do
  exe="$build/$t"
  [ -x "$exe" ] || continue
  # A Google Benchmark program: linked against libbenchmark, or carrying its flags (static).
  if ldd "$exe" 2>/dev/null | grep -q libbenchmark || grep -aq -- "benchmark_repetitions" "$exe"; then
    benches+=("$(basename "$t")")
  else
    plain+=("$(basename "$t")")
  fi
done
# Plain measurement programs (their own main): how to run each. A program with a
# scripts/bench-NAME.sh runner uses that instead (it prints the section's markdown).
plain_args() {
  case "$1" in
    bench_soak) echo "" ;;                    # 1,000,000 observations through the threads
    bench_checkpoint) echo "$tmpdir" ;;       # checkpoint files go to a scratch directory
    footprint) echo "memory" ;;               # instruction counts: scripts/cross-footprint.sh
    *) return 1 ;;                            # tools and tests (rost_experiment, quantize_count, ...)
  esac
}
runnable_plain=()
for b in "${plain[@]}"; do
  if [ -x "$here/scripts/bench-$b.sh" ] || plain_args "$b" >/dev/null; then runnable_plain+=("$b"); fi
done

if [ "$list" = 1 ]; then
  printf '%s\n' "${benches[@]}" "${runnable_plain[@]}"
  echo "experiment-$experiment"
  [ "$cross" = 1 ] && echo footprint
  exit 0
fi

commit=$(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown)
git -C "$here" diff --quiet HEAD -- src include bench 2>/dev/null || commit="$commit (work tree with local changes)"
cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -n1)
machine="$(nproc) x $cpu, $(uname -m)"

# ---- Google Benchmark programs ------------------------------------------------------------------------
ran=()
for b in "${benches[@]}"; do
  wanted "$b" || continue
  log "running $b ($reps repetitions; load average $(cut -d' ' -f1-3 /proc/loadavg))"
  json="$tmp/$b.json"
  if ! "$build/bench/$b" --benchmark_repetitions="$reps" --benchmark_report_aggregates_only=true \
       --benchmark_out="$json" --benchmark_out_format=json >"$tmp/$b.txt" 2>&1; then
    log "$b failed; its section is left as it was (output: $tmp/$b.txt)"
    tail -n 5 "$tmp/$b.txt" >&2
    continue
  fi
  cmd="build/bench/$b --benchmark_repetitions=$reps --benchmark_report_aggregates_only=true"
  if [ -x "$here/scripts/bench-$b.sh" ]; then
    "$here/scripts/bench-$b.sh" "$build" "$json" > "$tmp/$b.md"
    section "$b" "$tmp/$b.md" --heading "## Benchmark programs"
  elif [ "$b" = bench_scaling ]; then
    "$py" "$here/bench/scaling_report.py" "$json" --command "$cmd" --commit "$commit" --machine "$machine" \
      > "$tmp/$b.md"
    section scaling "$tmp/$b.md" --heading "## Scaling (issue 6)"
  else
    { echo "\`$cmd\` — commit \`$commit\`, $machine"; echo
      "$py" "$here/scripts/results-section.py" gbench "$json"; } > "$tmp/$b.md"
    section "$b" "$tmp/$b.md" --heading "## Benchmark programs"
  fi
  ran+=("$b")
done

# ---- plain measurement programs ---------------------------------------------------------------------
for b in "${runnable_plain[@]}"; do
  wanted "$b" || continue
  if [ -x "$here/scripts/bench-$b.sh" ]; then
    log "running scripts/bench-$b.sh"
    if "$here/scripts/bench-$b.sh" "$build" > "$tmp/$b.md" 2> "$tmp/$b.err"; then
      section "$b" "$tmp/$b.md" --heading "## Benchmark programs"
      ran+=("$b")
    else
      log "scripts/bench-$b.sh failed; its section is left as it was"; tail -n 5 "$tmp/$b.err" >&2
    fi
    continue
  fi
  args=$(plain_args "$b")
  log "running $b $args (load average $(cut -d' ' -f1-3 /proc/loadavg))"
  t0=$(date +%s)
  # shellcheck disable=SC2086
  if "$build/bench/$b" $args > "$tmp/$b.txt" 2>&1; then
    { echo "\`build/bench/$b $args\` — commit \`$commit\`, $machine, $(( $(date +%s) - t0 )) s"; echo
      echo '```text'; cat "$tmp/$b.txt"; echo '```'; } > "$tmp/$b.md"
    section "$b" "$tmp/$b.md" --heading "## Benchmark programs"
    ran+=("$b")
  else
    log "$b failed; its section is left as it was"; tail -n 5 "$tmp/$b.txt" >&2
  fi
done

# ---- the paper experiment ---------------------------------------------------------------------------------
if [ "$experiment" != none ] && wanted "experiment-$experiment"; then
  log "paper experiment: scripts/experiment.sh --$experiment"
  "$here/scripts/experiment.sh" "--$experiment" --build "$build"
  ran+=("experiment-$experiment")
fi

# ---- ARM footprint ------------------------------------------------------------------------------------------
if [ "$cross" = 1 ] && wanted footprint; then
  log "ARM footprint: scripts/cross-footprint.sh"
  if "$here/scripts/cross-footprint.sh" > "$tmp/footprint.raw" 2> "$tmp/footprint.err"; then
    { echo "\`scripts/cross-footprint.sh\` — commit \`$commit\`, $machine"; echo
      sed 's/^## /#### /' "$tmp/footprint.raw"; } > "$tmp/footprint.md"
    section footprint "$tmp/footprint.md" --heading "## ARM footprint (issue 5)"
    ran+=(footprint)
  else
    log "cross-footprint.sh failed (run scripts/cross-test.sh first?); its section is left as it was"
    tail -n 5 "$tmp/footprint.err" >&2
  fi
fi

duration=$(( $(date +%s) - start_s ))
{ echo "Last \`scripts/bench-all.sh\` run: started $started, $((duration / 60)) min $((duration % 60)) s;"
  echo "commit \`$commit\`; $machine; sections rewritten: ${ran[*]:-none}."; } > "$tmp/bench-all.md"
section bench-all "$tmp/bench-all.md"
log "done in $((duration / 60)) min $((duration % 60)) s: ${ran[*]:-nothing}"
