#!/usr/bin/env bash
# The price and the point of refinement in windows (issue 13; bench/RESULTS.md
# "Every core"), on a real word stream (words.csv and positions.csv of
# `rost run`):
#   1. equal refinement counts: the mean final perplexity of `rost refine` for
#      refine.window 1 (the exact serial sampler) against 64, 256 and 1024, over
#      SEEDS seeds (mean and standard error);
#   2. equal time budget (--budget.ms 40): 1 thread against 2, same seeds;
#   3. wall time of `rost refine` with --threads 1 and 2 (median of 5) and
#      whether their outputs are byte-identical.
# Usage: scripts/parallel-price.sh WORDS.csv POSITIONS.csv [SEEDS]
set -euo pipefail
words=$1 positions=$2 seeds=${3:-10}
cd "$(dirname "$0")/.."
rost=build/rost
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# Mean of the `final` column of perplexity.csv.
final_mean() { awk -F, 'NR > 1 && $3 != "nan" { s += $3; n++ } END { printf "%.3f", s / n }' "$1/perplexity.csv"; }
# Mean and standard error of the numbers on standard input.
mean_se() { awk '{ x[NR] = $1; s += $1 } END { m = s / NR; for (i = 1; i <= NR; i++) v += (x[i] - m)^2;
  printf "%.2f ± %.2f", m, sqrt(v / (NR - 1) / NR) }'; }

echo "## equal refinement counts (budget.refines 40), $seeds seeds: mean final perplexity ± s.e."
for w in 1 64 256 1024; do
  for s in $(seq 1 "$seeds"); do
    "$rost" refine "$words" --positions "$positions" --out "$tmp/w$w-$s" --refine.window "$w" --seed "$s" -q --no-summary
    final_mean "$tmp/w$w-$s"; echo
  done | mean_se | sed "s/^/refine.window $w: /"; echo
done

echo "## equal time budget (budget.ms 40), $seeds seeds: mean final perplexity ± s.e."
for t in 1 2; do
  for s in $(seq 1 "$seeds"); do
    "$rost" refine "$words" --positions "$positions" --out "$tmp/t$t-$s" --threads "$t" --budget.ms 40 --seed "$s" \
      -q --no-summary
    final_mean "$tmp/t$t-$s"; echo
  done | mean_se | sed "s/^/threads $t: /"; echo
done

echo "## rost refine wall time, median of 5 (default settings)"
for t in 1 2; do
  for i in 1 2 3 4 5; do
    /usr/bin/time -f "%e" "$rost" refine "$words" --positions "$positions" --out "$tmp/speed$t" --threads "$t" -q \
      --no-summary 2>&1 >/dev/null | tail -n 1
  done | sort -n | sed -n 3p | sed "s/^/threads $t: /;s/$/ s/"
done
for f in topics.csv topicmodel.csv perplexity.csv surprise.csv surprise_cells.csv; do
  cmp -s "$tmp/speed1/$f" "$tmp/speed2/$f" || { echo "$f differs between 1 and 2 threads"; exit 1; }
done
echo "outputs of --threads 1 and --threads 2: byte-identical"
