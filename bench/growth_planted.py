#!/usr/bin/env python3
"""Topic growth on planted streams (issue 28, item 1).

T topics on disjoint blocks of V/T word ids; 600 documents of 100 words in
regimes of 30 documents, each document 80 % the regime's topic and 20 %
drawn uniformly over all topics. For each (T, V) and gamma, runs

    topics.refine.t -i words.csv --grow.topics.size=true -K 100 --iter 100 --gamma G

and the same command with -K T and no growth, and prints a markdown table:
large topics (each holding at least 2 % of the words, labels of
--out.topics), topics open at the end (rows of topicmodel.csv), purity,
fixed-K purity, and their ratio.

usage: bench/growth_planted.py [--bin build/bin/topics.refine.t] [--seed S]
"""
import argparse
import collections
import os
import random
import subprocess
import sys
import tempfile

CASES = [(5, 200), (8, 2000), (5, 10000)]
GAMMAS = [1e-7, 1e-5, 1e-3, 1e-1]
DOCS, WORDS, REGIME = 600, 100, 30


def planted(T, V, seed):
    rng = random.Random(seed * 7919 + T * 131 + V)
    block = V // T
    lines, truth = [], []
    regime_topic = 0
    for d in range(DOCS):
        if d % REGIME == 0:
            regime_topic = rng.randrange(T)
        words, labels = [], []
        for _ in range(WORDS):
            t = regime_topic if rng.random() < 0.8 else rng.randrange(T)
            words.append(t * block + rng.randrange(block))
            labels.append(t)
        lines.append(",".join([str(d)] + [str(w) for w in words]))
        truth.append(labels)
    return "\n".join(lines) + "\n", truth


def read_labels(path):
    rows = []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if line:
                rows.append([int(x) for x in line.split(",")[1:]])
    return rows


def purity(found, truth):
    joint = collections.Counter()
    for zs, ts in zip(found, truth):
        for z, t in zip(zs, ts):
            joint[(z, t)] += 1
    best = collections.defaultdict(int)
    for (z, _), c in joint.items():
        best[z] = max(best[z], c)
    total = sum(len(ts) for ts in truth)
    return sum(best.values()) / total


def run(binary, words, out, K, grow, gamma, seed):
    cmd = [binary, "-i", words, "-K", str(K), "--iter", "100", "--seed", str(seed),
           "--out.topics=" + os.path.join(out, "topics.csv"),
           "--out.topicmodel=" + os.path.join(out, "topicmodel.csv")]
    if grow:
        cmd += ["--grow.topics.size=true", "--gamma=%g" % gamma]
    subprocess.run(cmd, check=True, cwd=out, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    found = read_labels(os.path.join(out, "topics.csv"))
    with open(os.path.join(out, "topicmodel.csv")) as f:
        rows = sum(1 for line in f if line.strip())
    return found, rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default="build/bin/topics.refine.t")
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    binary = os.path.abspath(a.bin)
    print("| T | V | gamma | large topics | topics open | purity | fixed-K purity | ratio | bar |")
    print("|---|---|---|---|---|---|---|---|---|")
    met = 0
    total = 0
    for T, V in CASES:
        text, truth = planted(T, V, a.seed)
        with tempfile.TemporaryDirectory() as tmp:
            words = os.path.join(tmp, "words.csv")
            with open(words, "w") as f:
                f.write(text)
            fixed, _ = run(binary, words, tmp, T, False, 0, a.seed)
            pf = purity(fixed, truth)
            for g in GAMMAS:
                found, rows = run(binary, words, tmp, 100, True, g, a.seed)
                n = sum(len(z) for z in found)
                sizes = collections.Counter(z for zs in found for z in zs)
                large = sum(1 for c in sizes.values() if c >= 0.02 * n)
                p = purity(found, truth)
                ok = T - 1 <= large <= T + 2 and rows <= 2 * T and p >= 0.9 * pf
                met += ok
                total += 1
                print("| %d | %d | %g | %d | %d | %.3f | %.3f | %.2f | %s |"
                      % (T, V, g, large, rows, p, pf, p / pf, "yes" if ok else "no"), flush=True)
    print("\n%d of %d rows meet the bar" % (met, total))
    return 0


if __name__ == "__main__":
    sys.exit(main())
