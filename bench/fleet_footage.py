#!/usr/bin/env python3
"""A fleet of real footage (issue 29, item 6; docs/fleet.md): the footage of docs/vision.md's list,
each cut in two halves (the first and the second half of its frames: two missions of one scene),
each half a mission of `rost run -K 8`, merged into one topic set by rost.fleet.run. Prints, for
each mission, its words, the global topics holding >= 2 % of them and how many of those its other
half and the other scenes hold too; writes a picture of every global topic's share in each mission.
The halves of a video are cut losslessly (ffmpeg, FFV1), an image folder's by links.

  scripts/fetch-footage.sh pd-extendedview visp-images-data opencv-doc
  PYTHONPATH=build/python ROST_TOOL=build/rost python3 bench/fleet_footage.py --out /tmp/fleet-footage
"""

import argparse
import os
import subprocess

import numpy as np

import rost
import rost.fleet

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data")
MISSIONS = {
    "diver": "pd-extendedview/usr/share/doc/pd-extendedview/media/diver.mov",
    "mire-2": "visp-images-data/usr/share/visp-images-data/ViSP-images/mire-2",
    "vtest": "opencv-doc/usr/share/doc/opencv-doc/examples/data/vtest.avi",
}


def halves(name, path, work):
    """Two missions of one piece of footage: its first and its second half."""
    os.makedirs(work, exist_ok=True)
    if os.path.isdir(path):
        files = sorted(f for f in os.listdir(path) if not f.startswith("."))
        out = {}
        for h, part in enumerate((files[:len(files) // 2], files[len(files) // 2:])):
            d = os.path.join(work, f"{name}-{h + 1}")
            os.makedirs(d, exist_ok=True)
            for f in part:
                if not os.path.exists(os.path.join(d, f)):
                    os.symlink(os.path.join(path, f), os.path.join(d, f))
            out[f"{name}-{h + 1}"] = d
        return out
    frames = int(subprocess.run(["ffprobe", "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
                                 "stream=nb_read_frames", "-of", "csv=p=0", path], check=True, capture_output=True,
                                text=True).stdout.strip())
    out = {}
    for h, (a, b) in enumerate(((0, frames // 2 - 1), (frames // 2, frames - 1))):
        dst = os.path.join(work, f"{name}-{h + 1}.mkv")
        if not os.path.exists(dst):
            subprocess.run(["ffmpeg", "-v", "error", "-y", "-i", path, "-vf", f"select=between(n\\,{a}\\,{b}),setpts=N/TB",
                            "-an", "-c:v", "ffv1", dst], check=True)
        out[f"{name}-{h + 1}"] = dst
    return out


def shares(topics_global, G):
    """Words of each global topic in a mission's topics.global.csv (first column: the frame)."""
    n = np.zeros(G, dtype=np.int64)
    with open(topics_global) as f:
        for line in f:
            labels = np.array(line.strip().split(",")[1:], dtype=np.int64)
            n += np.bincount(labels[labels >= 0], minlength=G)[:G]
    return n


def picture(path, names, table):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(8, 0.6 + 0.5 * len(names)))
    left = np.zeros(len(names))
    colours = plt.get_cmap("tab20")
    for g in range(table.shape[1]):
        share = table[:, g] / table.sum(axis=1)
        ax.barh(names, share, left=left, color=colours(g % 20), edgecolor="white", linewidth=0.5)
        for i, s in enumerate(share):
            if s >= 0.06:
                ax.text(left[i] + s / 2, i, str(g), ha="center", va="center", fontsize=8)
        left += share
    ax.set_xlim(0, 1)
    ax.set_xlabel("share of the mission's words (labels lifted to the global topics; numbers: global topic)")
    ax.invert_yaxis()
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("-K", type=int, default=8)
    ap.add_argument("--threshold", type=float, default=0.6)
    ap.add_argument("--picture", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "fleet_footage.png"))
    a = ap.parse_args()
    missions = {}
    for n, p in MISSIONS.items():
        missions.update(halves(n, os.path.join(DATA, p), os.path.join(a.out, "halves")))
    r = rost.fleet.run(missions, a.out, K=a.K, threshold=a.threshold)
    G = r["global_counts"].shape[0]
    names = list(missions)
    table = np.array([shares(r["topics_global"][n], G) for n in names])
    big = table >= 0.02 * table.sum(axis=1, keepdims=True)
    print(f"K = {a.K} a mission, threshold {a.threshold}: {G} global topics, "
          f"{int(big.any(axis=0).sum())} holding >= 2 % of some mission's words, "
          f"{int((big.sum(axis=0) >= 2).sum())} of those in two missions or more\n")
    print("| mission | words | global topics >= 2 % | of those in its other half | in another scene | largest shares |")
    print("|---|---:|---:|---:|---:|---|")
    for i, n in enumerate(names):
        top = np.argsort(-table[i])[:3]
        largest = ", ".join(f"{g}: {table[i, g] / table[i].sum():.0%}" for g in top)
        scene = n.rsplit("-", 1)[0]
        twin = [j for j, m in enumerate(names) if m != n and m.rsplit("-", 1)[0] == scene]
        other = [j for j, m in enumerate(names) if m.rsplit("-", 1)[0] != scene]
        in_twin = int((big[i] & big[twin].any(axis=0)).sum())
        in_other = int((big[i] & big[other].any(axis=0)).sum())
        print(f"| {n} | {table[i].sum()} | {int(big[i].sum())} | {in_twin} | {in_other} | {largest} |")
    picture(a.picture, names, table)
    print(f"\npicture: {a.picture}")


if __name__ == "__main__":
    main()
