#!/usr/bin/env python3
"""Rewrites one bench's delimited section of bench/RESULTS.md, leaving the rest alone.

Every bench owns the text between its markers

    <!-- begin:NAME -->
    ...generated...
    <!-- end:NAME -->

and nothing else: hand-written text around the markers (findings, notes) and
other benches' sections are kept byte for byte. The file is rewritten through
a temporary file and a rename, so a crash never leaves a torn RESULTS.md.

  results-section.py replace FILE NAME CONTENT [--heading "## Title"]
      Puts CONTENT (a file, or - for stdin) between NAME's markers. When the
      markers are missing, the block is inserted at the end of the section
      under HEADING (created at the end of the file if absent), or appended.
  results-section.py gbench JSON [--title TEXT]
      Prints a markdown table of a Google Benchmark JSON report (medians when
      repetitions were run): the generic rendering bench-all.sh uses for
      benches that do not render their own section.
"""
import argparse
import json
import os
import re
import sys
import tempfile


def replace(path, name, content, heading=None):
    begin, end = f"<!-- begin:{name} -->", f"<!-- end:{name} -->"
    text = open(path, encoding="utf-8").read() if os.path.exists(path) else "# Benchmark results\n"
    content = content.rstrip("\n") + "\n"
    block = f"{begin}\n{content}{end}\n"
    b, e = text.find(begin), text.find(end)
    if b >= 0 and e > b:
        eol = text.find("\n", e)
        text = text[:b] + block + (text[eol + 1:] if eol >= 0 else "")
    elif b >= 0 or e >= 0:
        sys.exit(f"results-section: {path}: markers for '{name}' are unbalanced; fix them by hand")
    elif heading:
        m = re.search(r"^" + re.escape(heading) + r"[ \t]*$", text, re.M)
        if m:
            nxt = re.search(r"^## ", text[m.end():], re.M)
            at = m.end() + nxt.start() if nxt else len(text)
            before = text[:at].rstrip("\n") + "\n\n"
            text = before + block + ("\n" + text[at:] if nxt else "")
        else:
            text = text.rstrip("\n") + f"\n\n{heading}\n\n{block}"
    else:
        text = text.rstrip("\n") + f"\n\n{block}"
    d = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=d, prefix=".RESULTS.", suffix=".tmp")
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.chmod(tmp, 0o644)
    os.replace(tmp, path)


def fmt_time(ns):
    for unit, scale in (("s", 1e9), ("ms", 1e6), ("us", 1e3)):
        if ns >= scale:
            return f"{ns / scale:.3g} {unit}"
    return f"{ns:.3g} ns"


def gbench(path, title=None):
    data = json.load(open(path, encoding="utf-8"))
    rows = data.get("benchmarks", [])
    medians = [r for r in rows if r.get("aggregate_name") == "median"]
    use = medians if medians else [r for r in rows if r.get("run_type", "iteration") == "iteration"]
    scale = {"ns": 1, "us": 1e3, "ms": 1e6, "s": 1e9}
    skip = {"name", "run_name", "run_type", "repetitions", "repetition_index", "threads", "iterations", "real_time",
            "cpu_time", "time_unit", "aggregate_name", "aggregate_unit", "family_index", "per_family_instance_index",
            "bytes_per_second", "items_per_second", "label", "error_occurred", "error_message"}
    counters = []
    for r in use:
        for k in r:
            if k not in skip and k not in counters and isinstance(r[k], (int, float)):
                counters.append(k)
    out = []
    if title:
        out.append(title + "\n")
    ctx = data.get("context", {})
    stat = "median of %d repetitions" % use[0].get("repetitions", 1) if medians and use else "one run"
    out.append(f"{ctx.get('num_cpus', '?')} CPUs @ {ctx.get('mhz_per_cpu', '?')} MHz, {stat}, "
               f"load average {', '.join('%.2f' % x for x in ctx.get('load_avg', []))}.\n")
    head = ["benchmark", "time", "items/s"] + counters
    out.append("| " + " | ".join(head) + " |")
    out.append("|" + "---|" * len(head))
    for r in use:
        name = r.get("run_name", r["name"])
        t = r["real_time"] * scale.get(r.get("time_unit", "ns"), 1)
        ips = r.get("items_per_second")
        cells = [name + (f" ({r['label']})" if r.get("label") else ""), fmt_time(t),
                 f"{ips:.4g}" if ips else ""]
        for c in counters:
            v = r.get(c)
            cells.append("" if v is None else f"{v:.4g}")
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("replace")
    r.add_argument("file")
    r.add_argument("name")
    r.add_argument("content")
    r.add_argument("--heading")
    g = sub.add_parser("gbench")
    g.add_argument("json")
    g.add_argument("--title")
    a = p.parse_args()
    if a.cmd == "replace":
        if not re.fullmatch(r"[A-Za-z0-9_.:-]+", a.name):
            sys.exit(f"results-section: bad section name '{a.name}' (letters, digits, _ . : -)")
        content = sys.stdin.read() if a.content == "-" else open(a.content, encoding="utf-8").read()
        replace(a.file, a.name, content, a.heading)
    else:
        sys.stdout.write(gbench(a.json, a.title))


if __name__ == "__main__":
    main()
