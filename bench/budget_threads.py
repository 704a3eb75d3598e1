#!/usr/bin/env python3
"""Threads under a time budget (issue 32, item 4): the mean instantaneous and final perplexity of
`rost refine` on the diver stream with the paper's time budget T_R (`--budget.ms`) for 1, 2, 4, ...
refinement threads, each measured `--repeat` times (the median of the means). A time budget is not
reproducible: a busy machine refines less, so run it on a quiet one and compare within one run.

  build/rost run data/pd-extendedview/usr/share/doc/pd-extendedview/media/diver.mov --out /tmp/diver -q
  python3 bench/budget_threads.py --words /tmp/diver/words.csv --positions /tmp/diver/positions.csv \\
      --budget 10 40 --threads 1 2
"""

import argparse
import csv
import os
import statistics
import subprocess
import tempfile


def means(tool, words, positions, budget, threads, out):
    subprocess.run([tool, "refine", words, "--positions", positions, "--budget.ms", str(budget),
                    "--threads", str(threads), "--out", out, "-q"], check=True)
    with open(os.path.join(out, "perplexity.csv")) as f:
        rows = list(csv.DictReader(f))
    return (statistics.fmean(float(r["instantaneous"]) for r in rows),
            statistics.fmean(float(r["final"]) for r in rows))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tool", default=os.environ.get("ROST_TOOL", "build/rost"))
    ap.add_argument("--words", required=True)
    ap.add_argument("--positions", required=True)
    ap.add_argument("--budget", type=float, nargs="+", default=[10, 40])
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    print(f"| T_R (ms) | threads | mean instantaneous perplexity | mean final perplexity |")
    print("|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for budget in a.budget:
            for threads in a.threads:
                runs = [means(a.tool, a.words, a.positions, budget, threads, os.path.join(tmp, f"r{budget}-{threads}-{i}"))
                        for i in range(a.repeat)]
                inst = statistics.median(r[0] for r in runs)
                final = statistics.median(r[1] for r in runs)
                print(f"| {budget:g} | {threads} | {inst:.1f} | {final:.1f} |", flush=True)


if __name__ == "__main__":
    main()
