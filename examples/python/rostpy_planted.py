#!/usr/bin/env python3
"""A rostpy script, run by rost: `import rost.rostpy as rostpy` is its only change.

A planted stream: 5 topics on disjoint blocks of V/5 word ids, 300 documents of
100 words in regimes of 30 documents; 80 % of a document's words come from its
regime's topic, 20 % from a topic drawn uniformly. ROST_t learns the topics
from the documents at time stamps 10, 13, 16, ... (60 sweeps of parallel_refine)
and prints the purity of its maximum-likelihood labels against the planted topics.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/rostpy_planted.py [--seed 7] [--threads 2]
"""

import argparse

import numpy as np

import rost.rostpy as rostpy

V, K, DOCUMENTS, WORDS, REGIME = 200, 5, 300, 100, 30


def planted_stream(seed):
    """[(words, topics)] of each document (lists of ints; topics: the planted topic of each word)."""
    rng = np.random.default_rng(seed)
    regimes = rng.integers(0, K, size=-(-DOCUMENTS // REGIME))
    stream = []
    for d in range(DOCUMENTS):
        own = rng.random(WORDS) < 0.8
        topics = np.where(own, regimes[d // REGIME], rng.integers(0, K, size=WORDS))
        words = topics * (V // K) + rng.integers(0, V // K, size=WORDS)
        stream.append((words.tolist(), topics.tolist()))
    return stream


def purity(labels, truth):
    """The share of words whose label's most common planted topic is their own."""
    labels, truth = np.concatenate(labels), np.concatenate(truth)
    return sum(np.bincount(truth[labels == k]).max() for k in np.unique(labels)) / len(truth)


def learn(stream, threads=2, sweeps=60):
    """The rostpy part: the maximum-likelihood labels of each document."""
    model = rostpy.ROST_t(V=V, K=K, alpha=0.1, beta=0.5, gamma=0)
    for i, (words, _) in enumerate(stream):
        model.add_observation([10 + 3 * i], words)
    for _ in range(sweeps):
        rostpy.parallel_refine(model, threads)
    return [model.get_ml_topics_for_pose([10 + 3 * i]) for i in range(len(stream))]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    stream = planted_stream(args.seed)
    labels = learn(stream, args.threads)
    print(f"purity {purity(labels, [t for _, t in stream]):.4f} ({DOCUMENTS} documents, K = {K}, V = {V})")


if __name__ == "__main__":
    main()
