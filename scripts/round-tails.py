#!/usr/bin/python3
"""The rounds' tails that the cells' sizes alone make (issue 32, item 1;
bench/RESULTS.md, "Item 1, twenty-seventh session").

A round of frozen refinement ends when its last cell is done, and a cell is
refined by one thread: with two threads of equal speed the round's end waits
for the thread that took the last cell (or pair of cells). This script
replays the pool's claiming rules (src/core/worker_pool.cpp: each worker owns
the cells of its band of rows, sorted by length as layoutRounds sorts them,
takes them from the front two at a time while two are left, and a worker out
of its own cells takes the others' from the back, one at a time) on rounds
built from a real word stream's cells, with a task's cost in token updates
(its words, plus OVERHEAD for the task; a pair costs PAIR times its two
cells), and prints how far each round's end lies past an even split of its
work: the tail that no machine removes, whatever its cores.

Rounds are approximated: cells of one colour ((t + x + y) mod 2) from STEPS
steps drawn at random, as a window of 256 picks holds about three steps of
the diver stream's 80 cells; `rost refine`'s own windows draw their steps
with the sampler and count a cell picked twice as one task.

Usage: scripts/round-tails.py WORDS.csv POSITIONS.csv [--width 640]
       [--height 480] [--cell 64] [--overhead 20] [--pair 0.8] [--steps 3]
       [--rounds 4000] [--seed 1] [--last-singly]
"""

import argparse
import csv
import random
import statistics


def cells_of(words_csv, positions_csv, width, height, cell, capacity):
    gw, gh = (width + cell - 1) // cell, (height + cell - 1) // cell
    steps = []
    with open(words_csv, newline="") as fw, open(positions_csv, newline="") as fp:
        for lw, lp in zip(csv.reader(fw), csv.reader(fp)):
            xy = [int(float(v)) for v in lp[1:]]
            count = [0] * (gw * gh)
            for i in range(len(lw) - 1):
                count[(xy[2 * i + 1] // cell) * gw + xy[2 * i] // cell] += 1
            steps.append([min(c, capacity) for c in count])
    return steps, gw


def round_end(tasks, cells, overhead, pair, last_singly=False):
    """Two workers of equal speed: the time the round's last task ends
    (last_singly: an owner takes its last two cells one at a time)."""
    owned = [[], []]
    for c, w in sorted(tasks, key=lambda t: min(t[1], 63)):
        owned[c * 2 // cells].append(w)
    front, end, t = [0, 0], [len(owned[0]), len(owned[1])], [0.0, 0.0]
    while True:
        k = 0 if t[0] <= t[1] else 1
        if end[k] - front[k] >= (3 if last_singly else 2):
            t[k] += overhead + pair * (owned[k][front[k]] + owned[k][front[k] + 1])
            front[k] += 2
        elif end[k] - front[k] >= 1:
            t[k] += overhead + owned[k][front[k]]
            front[k] += 1
        elif end[1 - k] > front[1 - k]:
            end[1 - k] -= 1
            t[k] += overhead + owned[1 - k][end[1 - k]]
        else:
            return max(t)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("words")
    ap.add_argument("positions")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--cell", type=int, default=64)
    ap.add_argument("--capacity", type=int, default=256)
    ap.add_argument("--overhead", type=float, default=20.0)
    ap.add_argument("--pair", type=float, default=0.8)
    ap.add_argument("--steps", type=int, default=3)
    ap.add_argument("--rounds", type=int, default=4000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--last-singly", action="store_true", help="an owner takes its last two cells one at a time")
    a = ap.parse_args()
    steps, gw = cells_of(a.words, a.positions, a.width, a.height, a.cell, a.capacity)
    cells = len(steps[0])
    sizes = sorted(c for s in steps for c in s if c)
    print(f"{len(steps)} steps, {len(sizes) / len(steps):.1f} cells a step with words; words a cell: "
          f"mean {statistics.mean(sizes):.1f}, median {statistics.median(sizes)}, "
          f"90th percentile {sizes[int(0.9 * len(sizes))]}, most {sizes[-1]}")
    rng = random.Random(a.seed)
    work = ends = 0.0
    tails = []
    for r in range(a.rounds):
        colour = r % 2
        tasks = [(c, w) for s in rng.sample(range(len(steps)), a.steps) for c, w in enumerate(steps[s])
                 if w and (s + c % gw + c // gw) % 2 == colour]
        # One thread's time for the round: pairs throughout.
        one = sum(a.overhead / 2 + a.pair * w for _, w in tasks)
        end = round_end(tasks, cells, a.overhead, a.pair, a.last_singly)
        tails.append(end - one / 2)
        work += one
        ends += end
    print(f"rounds {a.rounds} of {a.steps} steps' cells of one colour; overhead {a.overhead:g} token updates "
          f"a task, a pair {a.pair:g} of its cells' cost")
    print(f"tail past an even split: mean {statistics.mean(tails):.1f} token updates a round, "
          f"{sum(tails) / ends:.1%} of the two-thread rounds' time; rounds on two equal threads at "
          f"{work / ends:.3f}x one")


if __name__ == "__main__":
    main()
