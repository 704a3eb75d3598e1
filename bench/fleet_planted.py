#!/usr/bin/env python3
"""Planted missions for the fleet (issue 29, items 5 and 6; docs/fleet.md): how well merged
topic models agree with the topics planted in several missions.

Each planted topic owns a disjoint block of words. A mission has 300 documents of 100 words in
regimes of 30 documents; in a regime 80 % of a document's words come from the regime's topic and
20 % uniformly over the mission's topics. Missions share `--shared` topics and each has `--own`
of its own. Every mission is refined alone (`rost refine -K 6` by rost.fleet.run), the models
merged, and the labels lifted through lifting.csv; then every mission is labelled again in the
merged topics (`--in.topicmodel merged/topicmodel.csv --topicmodel.fixed`). Scores, against the
planted topic of every word, all missions jointly: purity, AMI (adjusted mutual information,
arithmetic normalisation), and the global topics holding >= 2 % of all words; identity matching
(every mission's topic i taken as global topic i) is the baseline.

  PYTHONPATH=build/python ROST_TOOL=build/rost python3 bench/fleet_planted.py --missions 2 3 4 8
"""

import argparse
import os
import sys
import tempfile

import numpy as np

DOCS, WORDS, REGIME, MIX, BLOCK = 300, 100, 30, 0.8, 20


def planted_mission(topics, rng):
    """(documents int32 (DOCS, WORDS), truth int32 (DOCS, WORDS)): regimes of REGIME documents."""
    topics = np.asarray(topics)
    regimes = DOCS // REGIME
    order = np.concatenate([rng.permutation(topics) for _ in range(-(-regimes // len(topics)))])[:regimes]
    regime = np.repeat(order, REGIME)[:, None]
    uniform = topics[rng.integers(0, len(topics), (DOCS, WORDS))]
    truth = np.where(rng.random((DOCS, WORDS)) < MIX, regime, uniform).astype(np.int32)
    words = (truth * BLOCK + rng.integers(0, BLOCK, (DOCS, WORDS))).astype(np.int32)
    return words, truth


def planted_fleet(missions, shared=3, own=1, seed=1):
    """name -> (words, truth) for `missions` missions sharing topics 0..shared-1, each with `own` more."""
    rng = np.random.default_rng(seed)
    fleet = {}
    for m in range(missions):
        topics = list(range(shared)) + [shared + m * own + i for i in range(own)]
        fleet[f"m{m}"] = planted_mission(topics, rng)
    return fleet


def write_fleet(fleet, directory):
    """Writes each mission's words as <name>.csv (rost refine's words.csv); name -> path."""
    import rost.io

    paths = {}
    for name, (words, _) in fleet.items():
        paths[name] = os.path.join(directory, f"{name}.csv")
        rost.io.write_words(paths[name], np.arange(len(words)), list(words))
    return paths


def _log_factorials(n):
    return np.concatenate([[0.0], np.cumsum(np.log(np.arange(1, n + 1, dtype=np.float64)))])


def _expected_mi(a, b, n):
    """E[MI] of two labelings with cluster sizes a and b under the hypergeometric model."""
    lf = _log_factorials(n)
    emi = 0.0
    for ai in a:
        for bj in b:
            k = np.arange(max(1, ai + bj - n), min(ai, bj) + 1)
            if k.size == 0:
                continue
            logp = (lf[ai] + lf[bj] + lf[n - ai] + lf[n - bj] - lf[n] - lf[k] - lf[ai - k] - lf[bj - k]
                    - lf[n - ai - bj + k])
            emi += np.sum(k / n * np.log(n * k / (ai * bj)) * np.exp(logp))
    return emi


def scores(truth, labels):
    """(purity, AMI, topics holding >= 2 % of the words) of labels against truth (1-D int arrays)."""
    truth = np.asarray(truth).ravel()
    labels = np.asarray(labels).ravel()
    n = truth.size
    _, t = np.unique(truth, return_inverse=True)
    _, lab = np.unique(labels, return_inverse=True)
    table = np.zeros((lab.max() + 1, t.max() + 1), dtype=np.int64)
    np.add.at(table, (lab, t), 1)
    purity = table.max(axis=1).sum() / n
    a, b = table.sum(axis=1), table.sum(axis=0)
    nz = table > 0
    mi = np.sum(table[nz] / n * np.log(n * table[nz] / np.outer(a, b)[nz]))
    entropy = lambda c: -np.sum(c / n * np.log(c / n))
    emi = _expected_mi(a, b, n)
    denom = 0.5 * (entropy(a) + entropy(b)) - emi
    ami = (mi - emi) / denom if denom > 0 else 1.0
    big = int(np.sum(a >= 0.02 * n))
    return purity, ami, big


def _labels(path):
    import rost.io

    return np.concatenate(rost.io.read_topics(path)[1])


def measure(missions, out, shared=3, own=1, K=6, sweeps=50, seed=1, client=None):
    """{method: (purity, AMI, topics >= 2 %, global topics)} for one planted fleet, run in `out`."""
    import rost.fleet

    fleet = planted_fleet(missions, shared, own, seed)
    os.makedirs(out, exist_ok=True)
    paths = write_fleet(fleet, out)
    result = rost.fleet.run(paths, os.path.join(out, "fleet"), client, fixed=True, K=K, final_sweeps=sweeps,
                            seed=seed)
    truth = np.concatenate([fleet[n][1].ravel() for n in paths])
    G = result["global_counts"].shape[0]
    methods = {
        "identity": (np.concatenate([_labels(os.path.join(d, "topics.csv")) for d in result["missions"].values()]),
                     K),
        "merged": (np.concatenate([_labels(p) for p in result["topics_global"].values()]), G),
        "merged, fixed": (np.concatenate([_labels(os.path.join(d, "topics.csv")) for d in result["fixed"].values()]),
                          G),
    }
    return {m: (*scores(truth, labels), g) for m, (labels, g) in methods.items()}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--missions", type=int, nargs="+", default=[2, 3, 4, 8])
    p.add_argument("--shared", type=int, default=3)
    p.add_argument("--own", type=int, default=1)
    p.add_argument("-K", type=int, default=6)
    p.add_argument("--sweeps", type=int, default=50, help="final.sweeps of every mission")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--out", help="where the missions' files go (default: a temporary directory)")
    a = p.parse_args(argv)
    print(f"Planted missions: {a.shared} shared topics, {a.own} of each mission's own; {DOCS} documents of "
          f"{WORDS} words, regimes of {REGIME}, {MIX:.0%} the regime's topic; `rost refine -K {a.K} "
          f"--final.sweeps {a.sweeps} --seed {a.seed}`; purity and AMI of all missions' words jointly.\n")
    print("| missions | planted topics | labels | purity | AMI | topics >= 2 % | global topics |")
    print("|---:|---:|---|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for m in a.missions:
            out = os.path.join(a.out or tmp, f"fleet{m}")
            for method, (purity, ami, big, g) in measure(m, out, a.shared, a.own, a.K, a.sweeps, a.seed).items():
                print(f"| {m} | {a.shared + m * a.own} | {method} | {purity:.3f} | {ami:.3f} | {big} | {g} |")
            sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
