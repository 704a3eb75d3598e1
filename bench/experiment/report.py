#!/usr/bin/env python3
"""Tables, plots and the RESULTS.md section of the paper experiment (bench/experiment/README.md).

  report.py paper --results DIR --figures DIR --fig-link PREFIX --summary CSV --markdown OUT
      Reads DIR/*.runs.csv (one row per online run), DIR/*.steps.csv (per time
      step), DIR/calibration.txt and DIR/run.txt; writes the mean over seeds of
      each configuration to CSV, per-time-step ratio plots (paper Figures 3-5),
      and markdown: tables laid out like the paper's Tables II and III with the
      paper's numbers beside ours, the bar check, and the time-budget
      cross-check.
  report.py sweep --results DIR --figures DIR --fig-link PREFIX --summary CSV --markdown OUT
      The eta / q tuning sweep: plot, table and the recommended defaults.
  report.py budget --results DIR ...
      Ratios of every strategy against the budget per observation (one dataset).
"""
import argparse
import csv
import glob
import math
import os
import statistics
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ORDER = ["uniform", "agep", "exp", "now", "uni+now", "agep+now", "uni+exp", "agep+exp"]
LABEL = {"uniform": "Uniform", "agep": "AgeP.", "exp": "Exp.", "now": "Now", "uni+now": "Uni+Now",
         "agep+now": "AgeP+Now", "uni+exp": "Uni+Exp", "agep+exp": "AgeP+Exp"}
COLOR = {"uniform": "#1f77b4", "agep": "#17becf", "exp": "#d62728", "now": "#ff7f0e", "uni+now": "#2ca02c",
         "agep+now": "#9467bd", "uni+exp": "#8c564b", "agep+exp": "#e377c2"}

# The paper's Tables II (final) and III (instantaneous): datasets 2objects,
# aerial, underwater; T_R = 40 and 160 ms; mean ratio to batch perplexity.
PAPER_DATASETS = ["2objects", "aerial", "underwater"]
PAPER_FINAL = {
    "uniform": [1.215, 1.155, 0.881, 1.141, 0.993, 1.133],
    "agep": [1.207, 1.269, 0.832, 1.120, 0.969, 1.147],
    "exp": [1.799, 2.272, 1.065, 1.548, 1.005, 1.488],
    "now": [1.791, 2.270, 1.056, 1.662, 0.998, 1.491],
    "uni+now": [1.555, 1.420, 0.842, 1.109, 0.885, 1.152],
    "agep+now": [1.599, 1.575, 0.893, 1.134, 0.894, 1.193],
    "uni+exp": [1.480, 1.398, 0.808, 1.1082, 0.887, 1.163],
    "agep+exp": [1.609, 1.576, 0.874, 1.137, 0.906, 1.185],
}
PAPER_INST = {
    "uniform": [3.500, 4.826, 1.665, 2.798, 1.907, 3.140],
    "agep": [3.714, 5.091, 1.715, 2.855, 1.997, 3.135],
    "exp": [1.859, 2.310, 1.170, 1.598, 1.073, 1.490],
    "now": [1.829, 2.312, 1.089, 1.711, 1.006, 1.502],
    "uni+now": [1.756, 1.770, 0.994, 1.226, 0.988, 1.242],
    "agep+now": [1.739, 1.883, 1.028, 1.247, 0.996, 1.270],
    "uni+exp": [2.267, 1.784, 1.279, 1.217, 1.357, 1.249],
    "agep+exp": [2.320, 1.873, 1.339, 1.238, 1.375, 1.256],
}


# The plug-in perplexity of the 2013 ROST code (Model::stepPluginPerplexity), beside ours.
PLUGIN_FIELDS = ("inst_ratio_plugin", "final_ratio_plugin", "inst_plugin", "final_plugin", "batch_plugin")


def num(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")


def read_kv(path):
    out = {}
    if os.path.exists(path):
        for line in open(path, encoding="utf-8"):
            line = line.rstrip("\n")
            if line and not line.startswith("#") and "=" in line:
                k, v = line.split("=", 1)
                out[k.strip()] = v.strip()
    return out


def read_runs(d):
    rows = []
    for p in sorted(glob.glob(os.path.join(d, "*.runs.csv"))):
        rows += list(csv.DictReader(open(p, encoding="utf-8")))
    if not rows:
        raise SystemExit(f"report: no *.runs.csv in {d}")
    return rows


def config_key(r):
    return (r["dataset"], r["strategy"], r["eta"], r["q"], num(r["tr_ms"]), r["budget_kind"])


def mean_sd(xs):
    xs = [x for x in xs if math.isfinite(x)]
    if not xs:
        return float("nan"), float("nan")
    return statistics.fmean(xs), (statistics.stdev(xs) if len(xs) > 1 else 0.0)


def aggregate(rows):
    groups = defaultdict(list)
    for r in rows:
        groups[config_key(r)].append(r)
    out = {}
    for k, rs in groups.items():
        a = {"n": len(rs), "frames": rs[0]["frames"]}
        for f in ("inst_ratio", "final_ratio", "inst_ppx", "final_ppx", "batch_ppx", "tokens_per_obs_mean",
                  "online_s", "batch_sweeps", "overruns") + PLUGIN_FIELDS:
            a[f], a[f + "_sd"] = mean_sd([num(r.get(f)) for r in rs])
        a["tokens_per_obs_min"] = min(num(r["tokens_per_obs_min"]) for r in rs)
        a["tokens_per_obs_max"] = max(num(r["tokens_per_obs_max"]) for r in rs)
        a["budget_tokens"] = rs[0]["budget_tokens"]
        out[k] = a
    return out


def write_summary(agg, path):
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    cols = ["dataset", "frames", "strategy", "eta", "q", "tr_ms", "budget_kind", "budget_tokens", "seeds",
            "inst_ratio", "inst_ratio_sd", "final_ratio", "final_ratio_sd", "inst_ppx", "final_ppx", "batch_ppx",
            "tokens_per_obs_mean", "tokens_per_obs_min", "tokens_per_obs_max", "batch_sweeps", "online_s",
            "overruns", "inst_ratio_plugin", "inst_ratio_plugin_sd", "final_ratio_plugin", "final_ratio_plugin_sd",
            "inst_plugin", "final_plugin", "batch_plugin"]
    tmp = path + ".tmp"
    with open(tmp, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for k in sorted(agg, key=lambda k: (k[0], k[5], k[4], ORDER.index(k[1]) if k[1] in ORDER else 99, k[2], k[3])):
            a = agg[k]
            row = [k[0], a["frames"], k[1], k[2], k[3], f"{k[4]:g}", k[5], a["budget_tokens"], a["n"]]
            for c in cols[9:]:
                v = a[c]
                row.append(f"{v:.5g}" if isinstance(v, float) else v)
            w.writerow(row)
    os.replace(tmp, path)


def per_step(results):
    """(dataset, tr, kind, strategy, eta, q) -> step -> [inst ratio per seed], [final ratio per seed]."""
    inst = defaultdict(lambda: defaultdict(list))
    fin = defaultdict(lambda: defaultdict(list))
    for p in sorted(glob.glob(os.path.join(results, "*.steps.csv"))):
        for r in csv.DictReader(open(p, encoding="utf-8")):
            b = num(r["batch_ppx"])
            if not (b > 0):
                continue
            k = (r["dataset"], num(r["tr_ms"]), r["budget_kind"], r["strategy"], r["eta"], r["q"])
            s = int(r["step"])
            inst[k][s].append(num(r["inst_ppx"]) / b)
            fin[k][s].append(num(r["final_ppx"]) / b)
    return inst, fin


def plot_steps(inst, fin, dataset, tr, path):
    keys = sorted({k for k in inst if k[0] == dataset and k[1] == tr and k[2] == "tokens"},
                  key=lambda k: ORDER.index(k[3]) if k[3] in ORDER else 99)
    if not keys:
        return False
    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True, dpi=80)
    for ax, data, title in ((axes[0], inst, "instantaneous / batch"), (axes[1], fin, "final / batch")):
        top = 0.0
        for k in keys:
            steps = sorted(data[k])
            ys = [statistics.fmean(data[k][s]) for s in steps]
            ax.plot(steps, ys, lw=0.9, color=COLOR.get(k[3]), label=LABEL.get(k[3], k[3]))
            finite = sorted(y for y in ys if math.isfinite(y))
            if finite:
                top = max(top, finite[int(0.98 * (len(finite) - 1))])
        ax.axhline(1.0, color="k", lw=0.6, ls=":")
        ax.set_ylabel(title)
        ax.set_ylim(bottom=min(0.9, ax.get_ylim()[0]), top=max(1.1, top * 1.05))
        ax.grid(alpha=0.3)
    axes[0].legend(ncol=4, fontsize=8, loc="upper right")
    axes[1].set_xlabel("time step")
    fig.suptitle(f"{dataset}: perplexity ratio to batch per time step, T_R = {tr:g} ms (mean over seeds)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return True


def fmt3(x):
    return f"{x:.3f}" if math.isfinite(x) else "–"


def paper_table(agg, datasets, trs, metric, paper, title):
    # Each (dataset, T_R) twice: our perplexity (word left out), then the plug-in one (the 2013 code's).
    cols = [(d, t, m) for d in datasets for t in trs for m in (metric, metric + "_plugin")]
    best = {}
    for c in cols:
        vals = [agg[k][c[2]] for k in agg if k[0] == c[0] and k[4] == c[1] and k[5] == "tokens"]
        best[c] = min((v for v in vals if math.isfinite(v)), default=float("nan"))
    pbest = [min(paper[s][i] for s in ORDER) for i in range(6)]
    lines = [f"**{title}** (mean over time steps of online / batch perplexity, mean over seeds; each dataset and "
             "T_R twice: our perplexity, the word left out of its own counts, then the plug-in perplexity of the "
             "2013 ROST code, the word kept and the cell's own topic mix; bold: best in the column; paper's Table "
             "values on the right)", ""]
    head = ["Alg. ↓, T_R (ms) →"] + [f"{d} {t:g}" + (" plug-in" if m.endswith("_plugin") else "")
                                     for d, t, m in cols] + \
           [f"paper {d} {t}" for d in PAPER_DATASETS for t in (40, 160)]
    lines.append("| " + " | ".join(head) + " |")
    lines.append("|---|" + "---:|" * (len(head) - 1))
    for s in ORDER:
        cells = [LABEL[s]]
        for c in cols:
            ks = [k for k in agg if k[0] == c[0] and k[1] == s and k[4] == c[1] and k[5] == "tokens"]
            v = agg[ks[0]][c[2]] if ks else float("nan")
            cells.append(f"**{fmt3(v)}**" if math.isfinite(v) and abs(v - best[c]) < 5e-4 else fmt3(v))
        for i, v in enumerate(paper[s]):
            cells.append(f"**{v:.3f}**" if v == pbest[i] else f"{v:.3f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def bar_check(agg, datasets):
    """Ours at the smallest T_R against the paper's best at 160 ms."""
    trs = sorted({k[4] for k in agg if k[5] == "tokens"})
    if not trs:
        return ""
    tr = trs[0]
    p160f = [min(PAPER_FINAL[s][i] for s in ORDER) for i in (1, 3, 5)]
    p160i = [min(PAPER_INST[s][i] for s in ORDER) for i in (1, 3, 5)]

    def mark(x, ref):
        if not math.isfinite(x):
            return "–"
        if x <= min(ref):
            return f"{x:.3f} ✓"
        if x <= max(ref):
            return f"{x:.3f} ~"
        return f"{x:.3f} ✗"

    lines = [f"**Bar: ours at T_R = {tr:g} ms against the paper's best at 160 ms.** The paper's best ratio at 160 ms "
             f"is {', '.join(f'{x:.3f}' for x in p160f)} (final) and {', '.join(f'{x:.3f}' for x in p160i)} "
             "(instantaneous) on 2objects, aerial, underwater. ✓: at or below the paper's best at 160 ms on all three "
             "of its datasets; ~: at or below it on at least one; ✗: above it on all.", ""]
    lines.append("| strategy | " + " | ".join(f"{d} final" for d in datasets) + " | " +
                 " | ".join(f"{d} inst." for d in datasets) + " |")
    lines.append("|---|" + "---:|" * (2 * len(datasets)))
    for s in ORDER:
        f, i = [], []
        for d in datasets:
            ks = [k for k in agg if k[0] == d and k[1] == s and k[4] == tr and k[5] == "tokens"]
            f.append(agg[ks[0]]["final_ratio"] if ks else float("nan"))
            i.append(agg[ks[0]]["inst_ratio"] if ks else float("nan"))
        lines.append(f"| {LABEL[s]} | " + " | ".join(mark(x, p160f) for x in f) + " | " +
                     " | ".join(mark(x, p160i) for x in i) + " |")
    return "\n".join(lines) + "\n"


def consistency(agg, datasets):
    """How far each strategy is from the best of its column, worst case over the columns."""
    cols = sorted({(k[0], k[4]) for k in agg if k[5] == "tokens"})
    best = {}
    for m in ("final_ratio", "inst_ratio"):
        for c in cols:
            best[(m, c)] = min(v[m] for k, v in agg.items() if (k[0], k[4]) == c and k[5] == "tokens")
    lines = ["**Consistency**: each strategy's ratio against the best strategy of the same column (dataset, T_R): "
             "the worst and the mean excess over the columns of the tables above.", "",
             "| strategy | final: worst excess | final: mean excess | inst.: worst excess | inst.: mean excess |",
             "|---|---:|---:|---:|---:|"]
    for s in ORDER:
        row = []
        for m in ("final_ratio", "inst_ratio"):
            ex = []
            for c in cols:
                ks = [k for k in agg if (k[0], k[4]) == c and k[1] == s and k[5] == "tokens"]
                if ks:
                    ex.append(agg[ks[0]][m] / best[(m, c)] - 1.0)
            row += [f"{100 * max(ex):.1f}%", f"{100 * statistics.fmean(ex):.1f}%"] if ex else ["–", "–"]
        lines.append(f"| {LABEL[s]} | " + " | ".join(row) + " |")
    return "\n".join(lines) + "\n"


def floor_table(results, agg):
    """The instantaneous floor (rost_experiment floor) beside the best instantaneous ratios."""
    rows = []
    for p in sorted(glob.glob(os.path.join(results, "*.floor.csv"))):
        rows += list(csv.DictReader(open(p, encoding="utf-8")))
    if not rows:
        return ""
    by = defaultdict(list)
    for r in rows:
        by[(r["dataset"], r["sweeps"])].append(num(r["ratio"]))
    lines = ["**Instantaneous floor**: the lowest instantaneous / batch ratio any online strategy can reach. For "
             "sampled steps t, batch Gibbs on the prefix 0..t (as many sweeps as the full batch reference at the "
             "smallest T_R) gives the perplexity of step t with everything up to t known and converged; divided by "
             "the full batch's perplexity of step t. What remains above 1 is what the data after t is worth (step "
             "t+1 in t's temporal neighbourhood, a topic model trained on the whole stream), which no online "
             "strategy can have one step after t.", "",
             "| dataset | batch sweeps | floor: mean (min–max over steps and seeds) | best instantaneous ratio "
             "(strategy, T_R) |", "|---|---:|---|---|"]
    for (d, sw), xs in sorted(by.items()):
        xs = [x for x in xs if math.isfinite(x)]
        cands = [(v["inst_ratio"], k[1], k[4]) for k, v in agg.items() if k[0] == d and k[5] == "tokens"]
        best = min(cands) if cands else None
        bt = f"{best[0]:.3f} ({LABEL.get(best[1], best[1])}, {best[2]:g} ms)" if best else "–"
        lines.append(f"| {d} | {sw} | {statistics.fmean(xs):.3f} ({min(xs):.3f}–{max(xs):.3f}) | {bt} |")
    return "\n".join(lines) + "\n"


def modes_table(results):
    """rost_experiment modes: the online final state against batch (perplexity, effective topics)."""
    rows = []
    for p in sorted(glob.glob(os.path.join(results, "*.modes.csv"))):
        rows += list(csv.DictReader(open(p, encoding="utf-8")))
    if not rows:
        return ""
    by = defaultdict(list)
    for r in rows:
        by[(r["dataset"], r["strategy"], r["tr_ms"], r["batch_sweeps"], r["extra_sweeps"])].append(r)
    lines = ["**Where the online runs end up** (`rost_experiment modes`): mean perplexity over the steps and the "
             "effective number of topics (exp of the entropy of n_k; K = 16) of the online run's final state, "
             "then after more global sweeps of that state (`Engine::finalPass`), against batch Gibbs with the same "
             "total refinement and with the same extra sweeps. Mean over seeds.", "",
             "| dataset | strategy | T_R ms | online: ppx (topics) | online + extra sweeps | batch | batch + extra "
             "sweeps |", "|---|---|---:|---|---|---|---|"]

    def cell(rs, p, t):
        return f"{statistics.fmean(num(r[p]) for r in rs):.1f} ({statistics.fmean(num(r[t]) for r in rs):.1f})"

    for (d, st, tr, sw, ex), rs in sorted(by.items()):
        lines.append(f"| {d} | {LABEL.get(st, st)} | {tr} | {cell(rs, 'online_ppx', 'online_topics')} | "
                     f"+{ex}: {cell(rs, 'online_extra_ppx', 'online_extra_topics')} | {sw} sweeps: "
                     f"{cell(rs, 'batch_ppx', 'batch_topics')} | +{ex}: {cell(rs, 'batch_extra_ppx', 'batch_extra_topics')} |")
    return "\n".join(lines) + "\n"


def timed_table(rows):
    timed = [r for r in rows if r["budget_kind"] == "time"]
    if not timed:
        return ""
    counted = {(r["dataset"], r["strategy"], r["eta"], r["q"], num(r["tr_ms"]), r["seed"]): r
               for r in rows if r["budget_kind"] == "tokens"}
    lines = ["**Count budget against real time budget** (threaded engine, `Budget::time(T_R)`, every observation "
             "pushed with `pushWait` so none is dropped; the count run has the same seed; each compared with its own "
             "batch reference of equal total refinement)", "",
             "| dataset | strategy | T_R ms | seed | tokens/obs count | tokens/obs timed: mean (min–max) | "
             "inst. ratio count / timed | final ratio count / timed | deadlines missed (worst ms) |",
             "|---|---|---:|---:|---:|---|---|---|---|"]
    for r in timed:
        c = counted.get((r["dataset"], r["strategy"], r["eta"], r["q"], num(r["tr_ms"]), r["seed"]))
        ct = c["budget_tokens"] if c else "–"
        ci = fmt3(num(c["inst_ratio"])) if c else "–"
        cf = fmt3(num(c["final_ratio"])) if c else "–"
        lines.append(f"| {r['dataset']} | {LABEL.get(r['strategy'], r['strategy'])} | {num(r['tr_ms']):g} | "
                     f"{r['seed']} | {ct} | {num(r['tokens_per_obs_mean']):.0f} ({r['tokens_per_obs_min']}–"
                     f"{r['tokens_per_obs_max']}) | {ci} / {fmt3(num(r['inst_ratio']))} | {cf} / "
                     f"{fmt3(num(r['final_ratio']))} | {r['overruns']} ({num(r['max_overrun_ms']):.2f}) |")
    return "\n".join(lines) + "\n"


def header(results):
    run = read_kv(os.path.join(results, "run.txt"))
    cal = read_kv(os.path.join(results, "calibration.txt"))
    out = []
    if run:
        out.append(f"- command: `{run.get('command', '?')}`")
        out.append(f"- commit: `{run.get('commit', '?')}`; machine: {run.get('machine', '?')}")
        out.append(f"- started {run.get('started', '?')}, wall time {run.get('duration', '?')}")
        if run.get("note"):
            out.append(f"- {run['note']}")
    if cal:
        trs = sorted((k for k in cal if k.startswith("tokens_") and k.endswith("ms")),
                     key=lambda k: float(k[7:-2]))
        conv = "; ".join(f"T_R = {k[7:-2]} ms → **{int(cal[k]):,}** tokens per observation" for k in trs)
        wpf = float(cal.get("words_per_frame", "nan"))
        rate = float(cal.get("tokens_per_second", "nan"))
        steps = "; ".join(f"{int(cal[k]) / wpf:.0f} refinements of a whole {wpf:.0f}-word step" for k in trs)
        out.append(f"- conversion (measured by `rost_experiment calibrate` on {cal.get('dataset', '?')}, "
                   f"{cal.get('frames', '?')} frames, through the engine's own path): refinement rate "
                   f"**{rate / 1e6:.2f} M tokens/s**, overhead {float(cal.get('overhead_ms', 'nan')):.2f} ms per "
                   f"observation (ingest, instantaneous perplexity, publication); tokens per observation = "
                   f"rate × (T_R − overhead): {conv} (≈ {steps}). Batch `refineAll` rate on the same stream: "
                   f"{float(cal.get('batch_tokens_per_second', 'nan')) / 1e6:.2f} M tokens/s.")
    return "\n".join(out) + "\n"


def cmd_paper(a):
    rows = read_runs(a.results)
    agg = aggregate(rows)
    write_summary(agg, a.summary)
    datasets = []
    for r in rows:
        if r["dataset"] not in datasets:
            datasets.append(r["dataset"])
    trs = sorted({k[4] for k in agg if k[5] == "tokens"})
    os.makedirs(a.figures, exist_ok=True)
    inst, fin = per_step(a.results)
    figs = []
    for d in datasets:
        for t in trs:
            name = f"{a.fig_stem}{d}-{t:g}ms.png"
            if plot_steps(inst, fin, d, t, os.path.join(a.figures, name)):
                figs.append((d, t, name))
    seeds = sorted({r["seed"] for r in rows})
    frames = {d: next(r["frames"] for r in rows if r["dataset"] == d) for d in datasets}
    md = [header(a.results)]
    md.append(f"Datasets (frames used): {', '.join(f'{d} ({frames[d]})' for d in datasets)}; "
              f"{len(seeds)} seeds; strategies with the paper's η = 0.5 (mixed) and q = "
              f"{next((r['q'] for r in rows if r['q']), '?')} (exponential parts); K = 16, α = 0.1, β = 0.5, "
              f"64 px cells one step wide. Every run's batch reference is Algorithm 1 with the same total "
              f"refinement, same seed. Raw per-run CSV: `{a.summary_link}` (mean and sd over seeds).\n")
    md.append(paper_table(agg, datasets, trs, "final_ratio", PAPER_FINAL, "Table II — mean final perplexity ratio"))
    md.append(paper_table(agg, datasets, trs, "inst_ratio", PAPER_INST,
                          "Table III — mean instantaneous perplexity ratio"))
    sds = [agg[k][m + "_sd"] for k in agg for m in ("inst_ratio", "final_ratio") if math.isfinite(agg[k][m + "_sd"])]
    if sds:
        md.append(f"Largest standard deviation over seeds of any cell above: {max(sds):.3f}.\n")
    md.append(consistency(agg, datasets))
    md.append(bar_check(agg, datasets))
    md.append(floor_table(a.results, agg))
    md.append(modes_table(a.results))
    md.append(timed_table(rows))
    if figs:
        md.append("Per-time-step ratios (like the paper's Figures 3–5; mean over seeds):\n")
        for d, t, name in figs:
            md.append(f"![{d}, T_R = {t:g} ms]({a.fig_link}{name})")
        md.append("")
    with open(a.markdown, "w", encoding="utf-8") as f:
        f.write("\n".join(md))


def cmd_sweep(a):
    """Mixed strategies against eta and q, at one or more budgets; defaults chosen across budgets."""
    rows = [r for r in read_runs(a.results) if r["budget_kind"] == "tokens"]
    agg = aggregate(rows)
    write_summary(agg, a.summary)
    dataset = rows[0]["dataset"]
    wpf = float(rows[0]["words"]) / float(rows[0]["frames"])
    trs = sorted({num(r["tr_ms"]) for r in rows}, reverse=True)
    tokens = {num(r["tr_ms"]): float(r["budget_tokens"]) for r in rows}
    # (tr, strategy, q) -> [(eta, inst, final, inst_sd, final_sd)]
    series = defaultdict(list)
    for k, v in agg.items():
        series[(k[4], k[1], k[3])].append((num(k[2]), v["inst_ratio"], v["final_ratio"], v["inst_ratio_sd"],
                                           v["final_ratio_sd"]))
    for pts in series.values():
        pts.sort()

    def budget_name(tr):
        return f"{tokens[tr]:,.0f} tokens/obs (≈ {tokens[tr] / wpf:.0f} step refinements; T_R = {tr:g} ms)"

    os.makedirs(a.figures, exist_ok=True)
    fig, axes = plt.subplots(len(trs), 2, figsize=(10, 3.6 * len(trs)), dpi=80, squeeze=False)
    styles = ["-", "--", ":", "-."]
    qs = sorted({k[2] for k in series if k[2]}, key=float)
    for row, tr in enumerate(trs):
        for (t, st, q), pts in sorted(series.items(), key=lambda kv: (ORDER.index(kv[0][1]), kv[0][2])):
            if t != tr:
                continue
            ls = styles[qs.index(q) % len(styles)] if q else "-"
            lab = LABEL[st] + (f" q={q}" if q else "")
            for ax, i in ((axes[row][0], 1), (axes[row][1], 2)):
                ax.errorbar([p[0] for p in pts], [p[i] for p in pts], yerr=[p[i + 2] for p in pts], ls=ls,
                            marker="o", ms=3, lw=1, capsize=2, color=COLOR[st], label=lab)
        for ax, t in ((axes[row][0], "instantaneous / batch"), (axes[row][1], "final / batch")):
            ax.set_xlabel("η (weight of the local part)")
            ax.set_ylabel(t)
            ax.set_title(budget_name(tr), fontsize=9)
            ax.axhline(1.0, color="k", lw=0.6, ls=":")
            ax.grid(alpha=0.3)
    axes[0][1].legend(fontsize=7, ncol=2)
    fig.suptitle(f"{dataset}: mixed strategies against η and q (mean ± sd over seeds)", fontsize=10)
    fig.tight_layout()
    name = f"{a.fig_stem}sweep-{dataset}.png"
    fig.savefig(os.path.join(a.figures, name))
    plt.close(fig)

    lines = [header(a.results),
             f"Dataset {dataset} ({rows[0]['frames']} frames), {len({r['seed'] for r in rows})} seeds, count "
             f"budgets. Cells: instantaneous / final ratio to batch (mean over seeds). Score of a setting: the mean "
             f"of its two ratios, averaged over the budgets.", ""]
    etas = sorted({num(k[2]) for k in agg})
    for tr in trs:
        lines.append(f"Budget {budget_name(tr)}:")
        lines.append("")
        lines.append("| strategy | q | " + " | ".join(f"η = {e:g}" for e in etas) + " |")
        lines.append("|---|---|" + "---|" * len(etas))
        for (t, st, q), pts in sorted(series.items(), key=lambda kv: (ORDER.index(kv[0][1]), kv[0][2])):
            if t != tr:
                continue
            byeta = {p[0]: p for p in pts}
            cells = [f"{byeta[e][1]:.3f} / {byeta[e][2]:.3f}" if e in byeta else "–" for e in etas]
            lines.append(f"| {LABEL[st]} | {q or '–'} | " + " | ".join(cells) + " |")
        lines.append("")
    # Score per (strategy, q, eta), averaged over the budgets that have it.
    score = defaultdict(list)
    for (t, st, q), pts in series.items():
        for p in pts:
            score[(st, q, p[0])].append(0.5 * (p[1] + p[2]))
    mean_score = {k: statistics.fmean(v) for k, v in score.items() if len(v) == len(trs)}
    lines.append("Best setting of each mixed strategy (score averaged over the budgets):")
    lines.append("")
    for st in ("uni+now", "agep+now", "uni+exp", "agep+exp"):
        cand = sorted((v, k) for k, v in mean_score.items() if k[0] == st)
        if cand:
            v, k = cand[0]
            at05 = [vv for kk, vv in mean_score.items() if kk[0] == st and kk[2] == 0.5 and (not kk[1] or kk[1] == k[1])]
            lines.append(f"- {LABEL[st]}: η = {k[2]:g}" + (f", q = {k[1]}" if k[1] else "") +
                         f": score {v:.3f}" + (f" (η = 0.5 with the same q: {at05[0]:.3f})" if at05 else ""))
    # The q that is best on average for the exponential mixtures, and eta per q.
    lines.append("")
    lines.append(f"![η / q sweep]({a.fig_link}{name})")
    with open(a.markdown, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")


def cmd_budget(a):
    """Ratios against the budget per observation (whole-step refinements), one dataset."""
    rows = [r for r in read_runs(a.results) if r["budget_kind"] == "tokens"]
    agg = aggregate(rows)
    write_summary(agg, a.summary)
    dataset = rows[0]["dataset"]
    wpf = float(rows[0]["words"]) / float(rows[0]["frames"])
    cal = read_kv(os.path.join(a.results, "calibration.txt"))
    rate = float(cal.get("tokens_per_second", "nan"))
    series = defaultdict(list)
    for k, v in agg.items():
        series[k[1]].append((float(v["budget_tokens"]) / wpf, v["inst_ratio"], v["final_ratio"],
                             float(v["budget_tokens"]), v["inst_ratio_plugin"], v["final_ratio_plugin"],
                             v["batch_sweeps"]))
    os.makedirs(a.figures, exist_ok=True)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), dpi=80)
    for s in ORDER:
        pts = sorted(series.get(s, []))
        if not pts:
            continue
        for ax, i in ((axes[0], 1), (axes[1], 2)):
            ax.plot([p[0] for p in pts], [p[i] for p in pts], marker="o", ms=3, lw=1, color=COLOR[s], label=LABEL[s])
    for ax, t in ((axes[0], "instantaneous / batch"), (axes[1], "final / batch")):
        ax.set_xscale("log")
        ax.set_xlabel("budget per observation (refinements of a whole step)")
        ax.set_ylabel(t)
        ax.axhline(1.0, color="k", lw=0.6, ls=":")
        ax.grid(alpha=0.3, which="both")
    axes[1].legend(fontsize=7, ncol=2)
    fig.suptitle(f"{dataset} ({rows[0]['frames']} frames): ratio to batch against the budget (mean over seeds)",
                 fontsize=10)
    fig.tight_layout()
    name = f"{a.fig_stem}budget-{dataset}.png"
    fig.savefig(os.path.join(a.figures, name))
    plt.close(fig)
    budgets = sorted({p[3] for pts in series.values() for p in pts})
    sweeps = {p[3]: p[6] for pts in series.values() for p in pts}
    lines = [header(a.results),
             f"Dataset {dataset} ({rows[0]['frames']} frames, {wpf:.0f} words a frame), "
             f"{len({r['seed'] for r in rows})} seeds. Cells: instantaneous / final ratio (mean over seeds), each "
             "against batch Gibbs with the same total refinement (its sweeps in the header). Budget in whole-step "
             "refinements per observation (tokens / words per frame) and its T_R on this "
             f"machine (tokens / {rate / 1e6:.1f} M tokens/s).", ""]
    for title, i, j in (("our perplexity (word left out)", 1, 2),
                        ("the plug-in perplexity (the 2013 ROST code's: word kept, the cell's own topic mix)", 4, 5)):
        lines.append(f"Ratios of {title}:")
        lines.append("")
        lines.append("| strategy | " + " | ".join(f"{b / wpf:.0f} ({b / rate * 1e3:.2g} ms; batch {sweeps[b]:.0f} "
                                                   "sweeps)" for b in budgets) + " |")
        lines.append("|---|" + "---|" * len(budgets))
        for s in ORDER:
            by = {p[3]: p for p in series.get(s, [])}
            lines.append(f"| {LABEL[s]} | " + " | ".join(
                f"{by[b][i]:.3f} / {by[b][j]:.3f}" if b in by else "–" for b in budgets) + " |")
        lines.append("")
    lines.append(f"![ratio against budget]({a.fig_link}{name})")
    with open(a.markdown, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("mode", choices=["paper", "sweep", "budget"])
    p.add_argument("--results", required=True)
    p.add_argument("--figures", required=True)
    p.add_argument("--fig-link", default="", help="prefix of figure links in the markdown")
    p.add_argument("--fig-stem", default="", help="prefix of figure file names")
    p.add_argument("--summary", required=True, help="summary CSV to write (mean and sd over seeds)")
    p.add_argument("--summary-link", default="", help="how the markdown names the summary CSV")
    p.add_argument("--markdown", required=True)
    a = p.parse_args()
    if not a.summary_link:
        a.summary_link = a.summary
    {"paper": cmd_paper, "sweep": cmd_sweep, "budget": cmd_budget}[a.mode](a)


if __name__ == "__main__":
    main()
