#!/usr/bin/env bash
# Token updates per second of topics.refine.t (rost-cli's command on rost) on
# a planted stream of 10^5 documents, threads 1 and 2, the median of 3 runs
# of each (bench/RESULTS.md, "rost-cli's commands"). The rate is the one the
# command logs: token refinements of the batch sweeps / their wall time.
#   bench/rostcli/bench.sh [BUILD_DIR] [DOCS]     (defaults: build, 100000)
set -euo pipefail
cd "$(dirname "$0")/../.."
build=${1:-build}
docs=${2:-100000}
cmd=$build/bin/topics.refine.t
[ -x "$cmd" ] || { echo "bench: $cmd not built" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# 20 topics of 50 words (V = 1000), 20 words per document, a topic per run of 25 documents.
/usr/bin/python3 - "$docs" >"$work/words.csv" <<'PY'
import random, sys
rng = random.Random(1)
n = int(sys.argv[1])
out = []
t = 0
for d in range(n):
    if d % 25 == 0:
        t = rng.randrange(20)
    out.append(",".join([str(d)] + [str(t * 50 + rng.randrange(50)) for _ in range(20)]))
sys.stdout.write("\n".join(out) + "\n")
PY
flags=(-i "$work/words.csv" -V 1000 -K 100 -n 10 --ppx.rate 10 --g.time 1 --cell.space 0)
echo "topics.refine.t ${flags[*]/$work\//} ($docs documents; commit $(git rev-parse --short HEAD))"
for threads in 1 2; do
  rates=()
  for rep in 1 2 3; do
    (cd "$work" && "$OLDPWD/$cmd" "${flags[@]}" --threads "$threads" --logfile "log.$threads.$rep")
    rates+=("$(sed -n 's/.* s: \([0-9.e+]*\) token updates\/s.*/\1/p' "$work/log.$threads.$rep")")
  done
  median=$(printf '%s\n' "${rates[@]}" | sort -g | sed -n 2p)
  printf 'threads %d: %s token updates/s (median of %s)\n' "$threads" "$median" "${rates[*]}"
done
