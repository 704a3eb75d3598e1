#!/usr/bin/env python3
"""Renders bench_scaling's Google Benchmark JSON as the "Scaling (issue 6)" section of bench/RESULTS.md.

  scaling_report.py JSON [--command TEXT] [--commit TEXT] [--machine TEXT] > section.md
"""
import argparse
import json
import re
from collections import defaultdict


def main():
    p = argparse.ArgumentParser()
    p.add_argument("json")
    p.add_argument("--command", default="build/bench/bench_scaling --benchmark_repetitions=3")
    p.add_argument("--commit", default="?")
    p.add_argument("--machine", default="?")
    a = p.parse_args()
    data = json.load(open(a.json, encoding="utf-8"))
    rows = data["benchmarks"]
    med = [r for r in rows if r.get("aggregate_name") == "median"] or \
          [r for r in rows if r.get("run_type", "iteration") == "iteration"]
    scale = {"ns": 1e-6, "us": 1e-3, "ms": 1.0, "s": 1e3}

    def ms(r):  # CPU time of the refining thread
        return r["cpu_time"] * scale[r.get("time_unit", "ns")]

    def wall(r):
        return r["real_time"] * scale[r.get("time_unit", "ns")]

    def arg(r, name):
        m = re.search(name + r":(\d+)", r.get("run_name", r["name"]))
        return int(m.group(1)) if m else None

    out = []
    ctx = data.get("context", {})
    reps = med[0].get("repetitions", 1) if med else 1
    out.append(f"- command: `{a.command}`; commit `{a.commit}`; machine: {a.machine}; "
               f"{'median of %d repetitions' % reps if reps > 1 else 'one run'}; load average at start "
               f"{', '.join('%.2f' % x for x in ctx.get('load_avg', []))}.")
    out.append("- cost per observation = `Engine::processNow` (ingest, instantaneous perplexity, refinement under "
               "the count budget, perplexity, publication of labels and histograms) on one pinned core; rate = "
               "tokens refined per CPU second of that. Times are CPU time of the (pinned) thread, because the "
               "machine is shared and wall time measures the neighbours; wall-clock medians are in the JSON, and "
               "'worst ms' is the worst wall-clock observation (preemption included).\n")

    k = sorted((r for r in med if r["name"].startswith("BM_TopicsK")), key=lambda r: arg(r, "K"))
    if k:
        out.append("**Topics K** (2,000 words a frame, 40,000 tokens an observation, Uni+Now, 64-step window)\n")
        out.append("| K | ms / observation (CPU) | wall ms | M tokens/s | ns / token | worst ms |")
        out.append("|---:|---:|---:|---:|---:|---:|")
        for r in k:
            ips = r.get("items_per_second", 0)
            out.append(f"| {arg(r, 'K')} | {ms(r):.2f} | {wall(r):.2f} | {ips / 1e6:.1f} | {1e9 / ips:.1f} | "
                       f"{r.get('worst_ms', float('nan')):.2f} |")
        out.append("")
    w = sorted((r for r in med if r["name"].startswith("BM_WordsPerFrame")), key=lambda r: arg(r, "words"))
    if w:
        out.append("**Words per frame** (K = 16, 10 time-step refinements an observation, so tokens grow with the "
                   "frame)\n")
        out.append("| words / frame | ms / observation (CPU) | tokens / observation | M tokens/s | ns / token | worst ms |")
        out.append("|---:|---:|---:|---:|---:|---:|")
        for r in w:
            ips = r.get("items_per_second", 0)
            out.append(f"| {arg(r, 'words'):,} | {ms(r):.2f} | {r.get('tokens_per_obs', 0):,.0f} | {ips / 1e6:.1f} | "
                       f"{1e9 / ips:.1f} | {r.get('worst_ms', float('nan')):.2f} |")
        out.append("")
    s = [r for r in med if r["name"].startswith("BM_StreamLength")]
    if s:
        by = defaultdict(dict)
        for r in s:
            by[arg(r, "uniform")][arg(r, "observations")] = r
        out.append("**Stream length** (K = 16, 500 words a frame, 2,000 tokens an observation, fixed 256-step "
                   "window; the engine is advanced to N observations untimed, then 2,000 more are timed)\n")
        out.append("| observations N | strategy | µs / observation (CPU) | relative to N = 1,000 | worst ms | memory MB |")
        out.append("|---:|---|---:|---:|---:|---:|")
        for u in sorted(by):
            base = by[u].get(min(by[u]))
            for n in sorted(by[u]):
                r = by[u][n]
                out.append(f"| {n:,} | {'Uniform' if u else 'Uni+Now'} | {ms(r) * 1e3:.1f} | "
                           f"{ms(r) / ms(base):.2f} | {r.get('worst_ms', float('nan')):.2f} | "
                           f"{r.get('memory_MB', float('nan')):.1f} |")
        out.append("")
    print("\n".join(out))


if __name__ == "__main__":
    main()
