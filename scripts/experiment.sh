#!/usr/bin/env bash
# The paper's section VII experiment on real footage (bench/experiment/README.md).
#
#   scripts/experiment.sh --small      diver, first 200 frames, 3 seeds, 8 strategies, T_R = 40 ms,
#                                      one time-budget cross-check; a few minutes
#   scripts/experiment.sh --reduced    diver, mire-2, vtest (first 200 frames each), 3 seeds,
#                                      8 strategies, T_R = 40 and 160 ms, time-budget cross-checks,
#                                      eta/q sweep; about 40-60 minutes on 2 free cores
#   scripts/experiment.sh --full       diver, mire-2, vtest (all frames), 10 seeds, 8 strategies,
#                                      T_R = 40 and 160 ms, cross-checks, sweep; about 4-5 hours
#
# Options: --build DIR (default build-experiment), --jobs N (parallel runs, default 2),
#   --no-budget-sweep / --budget-sweep (all strategies at 1..256 step refinements per
#   observation on the first dataset; on in --reduced and --full),
#   --out DIR (raw outputs, default data/experiment/out-MODE), --no-results (leave
#   bench/RESULTS.md and the committed figures alone), --no-sweep, --no-timed,
#   --frames N, --seeds N, --datasets "diver mire-2 vtest", --tr "40 160" (the T_R values, ms),
#   --tokens-per-second R
#   (skip calibration: use this rate, overhead 0), --calibration FILE (reuse one),
#   --report-only (redo the tables, plots and RESULTS.md sections from the raw CSV of
#   an earlier run in --out).
#
# Steps: build the harness; fetch the footage (scripts/fetch-footage.sh); extract the
# words of each dataset once into data/experiment/NAME (cached; an ORB vocabulary is
# trained into data/experiment/vocabulary.rostvoc with `rost vocab` when the build has
# no built-in one); calibrate T_R -> tokens per observation on this machine; run; write
# tables and plots; rewrite this mode's section of bench/RESULTS.md.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
mode=small
build="$here/build-experiment"
jobs=2
out=""
results=1
sweep=""
budget_sweep=""
timed=1
frames=""
seeds=""
datasets=""
rate=""
tr_given=""
calibration=""
report_only=0
while [ $# -gt 0 ]; do
  case "$1" in
    --small|--reduced|--full) mode=${1#--}; shift ;;
    --build) build=$2; shift 2 ;;
    --jobs) jobs=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --no-results) results=0; shift ;;
    --no-sweep) sweep=0; shift ;;
    --sweep) sweep=1; shift ;;
    --no-timed) timed=0; shift ;;
    --no-budget-sweep) budget_sweep=0; shift ;;
    --budget-sweep) budget_sweep=1; shift ;;
    --frames) frames=$2; shift 2 ;;
    --seeds) seeds=$2; shift 2 ;;
    --datasets) datasets=$2; shift 2 ;;
    --tr) tr_given=$2; shift 2 ;;
    --tokens-per-second) rate=$2; shift 2 ;;
    --calibration) calibration=$2; shift 2 ;;
    --report-only) report_only=1; shift ;;
    -h|--help) sed -n '2,27p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "experiment: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done

case $mode in
  small)   : "${frames:=200}"; : "${seeds:=3}"; : "${datasets:=diver}"; trs="40"; : "${sweep:=0}"; : "${budget_sweep:=0}"
           timed_strategies="uni+now"; timed_seeds=1 ;;
  reduced) : "${frames:=200}"; : "${seeds:=3}"; : "${datasets:=diver mire-2 vtest}"; trs="40 160"; : "${sweep:=1}"; : "${budget_sweep:=1}"
           timed_strategies="now,uniform,uni+now"; timed_seeds=1 ;;
  full)    : "${frames:=0}"; : "${seeds:=10}"; : "${datasets:=diver mire-2 vtest}"; trs="40 160"; : "${sweep:=1}"; : "${budget_sweep:=1}"
           timed_strategies="now,uniform,uni+now"; timed_seeds=2 ;;
esac
[ -n "$tr_given" ] && trs=$tr_given
[ -n "$out" ] || out="$here/data/experiment/out-$mode"
start_s=$(date +%s)
started=$(date -u +%Y-%m-%dT%H:%M:%SZ)
log() { echo "experiment [$(( $(date +%s) - start_s ))s]: $*" >&2; }

# Plots need matplotlib: Debian's python3-matplotlib, for Debian's own python3 (a
# python3 earlier on PATH, e.g. from pyenv, may not see it).
py=python3
[ -x /usr/bin/python3 ] && py=/usr/bin/python3
if ! "$py" -c 'import matplotlib' 2>/dev/null; then
  if [ "$(id -u)" = 0 ]; then
    log "installing python3-matplotlib"
    apt-get install -y python3-matplotlib >/dev/null 2>&1 || { apt-get update >/dev/null 2>&1 && apt-get install -y python3-matplotlib >/dev/null; }
  else
    echo "experiment: python3-matplotlib is needed for the plots (apt-get install python3-matplotlib)" >&2; exit 1
  fi
fi

if [ "$report_only" = 0 ]; then
# ---- build ------------------------------------------------------------------------------------
if [ ! -f "$build/build.ninja" ]; then
  cmake -S "$here" -B "$build" -G Ninja -DROST_WERROR=ON >/dev/null
fi
ninja -C "$build" -j2 rost_experiment rost_experiment_extract rost >/dev/null
exp="$build/bench/rost_experiment"
extract="$build/bench/rost_experiment_extract"
rosttool="$build/rost"

# ---- footage and words ---------------------------------------------------------------------------
declare -A pkg=([diver]=pd-extendedview [mire-2]=visp-images-data [vtest]=opencv-doc)
declare -A src=(
  [diver]=pd-extendedview/usr/share/doc/pd-extendedview/media/diver.mov
  [mire-2]=visp-images-data/usr/share/visp-images-data/ViSP-images/mire-2
  [vtest]=opencv-doc/usr/share/doc/opencv-doc/examples/data/vtest.avi)
need=()
for d in $datasets; do
  [ -n "${pkg[$d]:-}" ] || { echo "experiment: unknown dataset '$d' (diver, mire-2, vtest)" >&2; exit 2; }
  need+=("${pkg[$d]}")
done
"$here/scripts/fetch-footage.sh" "${need[@]}" >/dev/null

vocab_args=()
vocab_id=built-in
if ! "$extract" --check-vocabulary >/dev/null; then
  voc="$here/data/experiment/vocabulary.rostvoc"
  if [ ! -f "$voc" ]; then
    log "no built-in ORB vocabulary: training one (5000 words) on the three datasets with rost vocab"
    "$here/scripts/fetch-footage.sh" >/dev/null
    mkdir -p "$here/data/experiment"
    "$rosttool" vocab --quiet --every 4 --max-descriptors 200000 --threads 2 -o "$voc" \
      "$here/data/${src[diver]}" "$here/data/${src[mire-2]}" "$here/data/${src[vtest]}" ||
      { st=$?; [ -s "$voc" ] || exit "$st"; log "rost vocab exited with status $st after writing $voc; using it"; }
  fi
  vocab_args=(--vocabulary "$voc")
  vocab_id=$(sha256sum "$voc" | cut -c1-16)
fi
for d in $datasets; do
  dir="$here/data/experiment/$d"
  if [ ! -f "$dir/dataset.txt" ] || [ "$(cat "$dir/.vocabulary" 2>/dev/null)" != "$vocab_id" ]; then
    log "extracting the words of $d"
    mkdir -p "$dir"
    "$extract" --input "$here/data/${src[$d]}" --name "$d" --out "$dir" "${vocab_args[@]}" >&2
    echo "$vocab_id" > "$dir/.vocabulary"
  fi
done

# ---- calibration: T_R -> tokens per observation ------------------------------------------------------
mkdir -p "$out"
rm -f "$out"/*.runs.csv "$out"/*.steps.csv "$out"/*.info.txt
first=${datasets%% *}
if [ -n "$calibration" ]; then
  cp "$calibration" "$out/calibration.txt"
elif [ -n "$rate" ]; then
  { echo "# given on the command line"; echo "tokens_per_second=$rate"; echo "overhead_ms=0"
    for t in $trs; do echo "tokens_${t}ms=$("$py" -c "print(round($rate*$t/1000))")"; done; } > "$out/calibration.txt"
else
  log "calibrating on $first (load average: $(cut -d' ' -f1-3 /proc/loadavg))"
  "$exp" calibrate --dataset "$here/data/experiment/$first" --frames 60 --repeats 3 \
    --tr-ms "$(echo $trs | tr ' ' ,)" --out "$out/calibration.txt" 2>"$out/calibration.log" >/dev/null
fi
budgets=()
for t in $trs; do
  n=$(sed -n "s/^tokens_${t}ms=//p" "$out/calibration.txt")
  [ -n "$n" ] || { echo "experiment: $out/calibration.txt has no tokens_${t}ms" >&2; exit 1; }
  budgets+=(--budget "$t=tokens:$n")
  log "T_R = $t ms -> $n tokens per observation"
done

# ---- runs ------------------------------------------------------------------------------------------
for d in $datasets; do
  log "$d: 8 strategies x $(( ${#budgets[@]} / 2 )) budgets x $seeds seeds"
  "$exp" run --dataset "$here/data/experiment/$d" --frames "$frames" --strategies all "${budgets[@]}" \
    --seeds "$seeds" --jobs "$jobs" --out "$out" 2>>"$out/run.log"
  if [ "$mode" != small ]; then
    # The instantaneous floor, with as many sweeps as the batch reference at the first T_R.
    sweeps=$(awk -F, -v tr="${trs%% *}" 'NR > 1 && $7 == tr && $8 == "tokens" { print $20; exit }' "$out/$d.runs.csv")
    log "$d: instantaneous floor (batch on prefixes, $sweeps sweeps)"
    "$exp" floor --dataset "$here/data/experiment/$d" --frames "$frames" --sweeps "$sweeps" --seeds "$seeds" \
      --points 10 --jobs "$jobs" --out "$out" 2>>"$out/run.log"
    log "$d: online final states against batch (Uniform, Uni+Now; 2 seeds)"
    "$exp" modes --dataset "$here/data/experiment/$d" --frames "$frames" --strategies uniform,uni+now \
      "${budgets[0]}" "${budgets[1]}" --seeds 2 --extra 2 --jobs "$jobs" --out "$out" 2>>"$out/run.log"
  fi
done
if [ "$timed" = 1 ]; then
  tb=()
  for t in $trs; do tb+=(--budget "$t=time"); done
  # The refiner thread runs as onboard (SCHED_FIFO, pinned; fallback logged where not
  # permitted), so other work on a shared machine does not eat its T_R.
  log "$first: time budgets through the threaded engine ($timed_strategies)"
  "$exp" run --dataset "$here/data/experiment/$first" --frames "$frames" --strategies "$timed_strategies" \
    "${tb[@]}" --seeds "$timed_seeds" --jobs "$jobs" --tag "$first-timed" --realtime --out "$out" 2>>"$out/run.log"
fi
if [ "$sweep" = 1 ]; then
  t1=${trs%% *}
  n1=$(sed -n "s/^tokens_${t1}ms=//p" "$out/calibration.txt")
  mkdir -p "$out/sweep"
  cp "$out/calibration.txt" "$out/sweep/"
  # At T_R and at two small budgets (4 and 32 whole-step refinements per observation,
  # the regime of slower kernels and boards), so the defaults hold across budgets.
  wpf=$(sed -n 's/^words_per_frame=//p' "$here/data/experiment/$first/dataset.txt")
  r=$(sed -n 's/^tokens_per_second=//p' "$out/calibration.txt")
  sb=(--budget "$t1=tokens:$n1")
  for k in 4 32; do
    n=$("$py" -c "print(max(1, round($k * $wpf)))")
    sb+=(--budget "$("$py" -c "print('%.4g' % ($n / $r * 1e3))")=tokens:$n")
  done
  log "$first: eta/q sweep of the mixed strategies at T_R = $t1 ms and at 4 and 32 step refinements"
  "$exp" run --dataset "$here/data/experiment/$first" --frames "$frames" --strategies mixed \
    --eta 0.1,0.25,0.5,0.75,0.9 --q 0.02,0.1,0.5 "${sb[@]}" --seeds "$seeds" --jobs "$jobs" \
    --tag "sweep-$first" --out "$out/sweep" 2>>"$out/run.log"
fi

if [ "$budget_sweep" = 1 ]; then
  # Every strategy at budgets of 1 to 256 whole-step refinements per observation, to
  # show where each one's advantage lies (the T_R budgets above are at the top end).
  wpf=$(sed -n 's/^words_per_frame=//p' "$here/data/experiment/$first/dataset.txt")
  r=$(sed -n 's/^tokens_per_second=//p' "$out/calibration.txt")
  bs=()
  for k in 1 4 16 64 256; do
    n=$("$py" -c "print(max(1, round($k * $wpf)))")
    bs+=(--budget "$("$py" -c "print('%.4g' % ($n / $r * 1e3))")=tokens:$n")
  done
  mkdir -p "$out/budgets"
  cp "$out/calibration.txt" "$out/budgets/"
  log "$first: all strategies against the budget (1 to 256 step refinements per observation)"
  "$exp" run --dataset "$here/data/experiment/$first" --frames "$frames" --strategies all "${bs[@]}" \
    --seeds "$seeds" --jobs "$jobs" --tag "budgets-$first" --no-steps --out "$out/budgets" 2>>"$out/run.log"
fi

fi  # report_only

# ---- report ------------------------------------------------------------------------------------------
duration=$(( $(date +%s) - start_s ))
if [ "$report_only" = 0 ]; then {
commit=$(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown)
git -C "$here" diff --quiet HEAD -- src include bench 2>/dev/null || commit="$commit (work tree with local changes)"
cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -n1)
machine="$(nproc) x $cpu, $(uname -m), load average at the end $(cut -d' ' -f1-3 /proc/loadavg)"
cmdline="scripts/experiment.sh --$mode (frames ${frames/#0/all}, seeds $seeds, datasets $datasets, T_R $trs ms, jobs $jobs)"
{ echo "command=$cmdline"; echo "commit=$commit"; echo "machine=$machine"; echo "started=$started"
  echo "duration=$((duration / 60)) min $((duration % 60)) s"
  if [ "$vocab_id" = built-in ]; then echo "note=ORB vocabulary: the library's built-in one"
  else echo "note=ORB vocabulary: data/experiment/vocabulary.rostvoc (sha256 $vocab_id...), trained by rost vocab on every 4th frame of the three datasets (the build has no built-in one)"; fi
} > "$out/run.txt"
if [ "$sweep" = 1 ]; then cp "$out/run.txt" "$out/sweep/"; fi
if [ "$budget_sweep" = 1 ]; then cp "$out/run.txt" "$out/budgets/"; fi
}; fi
figs="$here/bench/experiment/figures"
sums="$here/bench/experiment/results"
if [ "$results" = 1 ]; then
  "$py" "$here/bench/experiment/report.py" paper --results "$out" --figures "$figs" --fig-stem "$mode-" \
    --fig-link "experiment/figures/" --summary "$sums/$mode-summary.csv" \
    --summary-link "bench/experiment/results/$mode-summary.csv" --markdown "$out/section.md"
  { echo "### Run: --$mode"; echo; cat "$out/section.md"; } > "$out/section-titled.md"
  "$py" "$here/scripts/results-section.py" replace "$here/bench/RESULTS.md" "experiment-$mode" \
    "$out/section-titled.md" --heading "## Paper experiment (issue 6)"
  if [ "$sweep" = 1 ] && [ -d "$out/sweep" ]; then
    "$py" "$here/bench/experiment/report.py" sweep --results "$out/sweep" --figures "$figs" --fig-stem "$mode-" \
      --fig-link "experiment/figures/" --summary "$sums/$mode-sweep-summary.csv" --markdown "$out/sweep.md"
    { echo "### Tuning sweep (eta, q): --$mode"; echo; cat "$out/sweep.md"; } > "$out/sweep-titled.md"
    "$py" "$here/scripts/results-section.py" replace "$here/bench/RESULTS.md" "experiment-sweep-$mode" \
      "$out/sweep-titled.md" --heading "## Paper experiment (issue 6)"
  fi
  if [ "$budget_sweep" = 1 ] && [ -d "$out/budgets" ]; then
    "$py" "$here/bench/experiment/report.py" budget --results "$out/budgets" --figures "$figs" --fig-stem "$mode-" \
      --fig-link "experiment/figures/" --summary "$sums/$mode-budget-summary.csv" --markdown "$out/budgets.md"
    { echo "### Ratios against the budget: --$mode"; echo; cat "$out/budgets.md"; } > "$out/budgets-titled.md"
    "$py" "$here/scripts/results-section.py" replace "$here/bench/RESULTS.md" "experiment-budget-$mode" \
      "$out/budgets-titled.md" --heading "## Paper experiment (issue 6)"
  fi
  log "wrote bench/RESULTS.md sections experiment-$mode$([ "$sweep" = 1 ] && echo " and experiment-sweep-$mode"), figures in $figs"
else
  "$py" "$here/bench/experiment/report.py" paper --results "$out" --figures "$out/figures" \
    --fig-link "figures/" --summary "$out/summary.csv" --markdown "$out/section.md"
  log "report in $out/section.md"
fi
log "done in $((duration / 60)) min $((duration % 60)) s; raw CSV in $out"
