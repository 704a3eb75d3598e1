#!/usr/bin/python3
"""Curiosity on a video from Python: surprise per frame, plotted to a PNG.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/curiosity.py data/.../diver.mov --frames 60 --out surprise.png

Reads the video with cv2, turns each frame into visual words (rost.vision.WordExtractor:
the shipped ORB vocabulary, intensity and hue words), adds them to a rost.Model and
refines it with the same budget as `rost run` (budget.refines steps per frame), so
the surprise it prints is the one `rost run` writes to surprise.csv. Frames whose
surprise jumps (at least twice the median of the 10 frames before) are marked.
"""

import argparse
import sys

import cv2
import matplotlib

matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import rost  # noqa: E402
import rost.vision  # noqa: E402


def frames(path, limit):
    cap = cv2.VideoCapture(path)
    if not cap.isOpened():
        sys.exit(f"curiosity.py: cannot open {path}")
    n = 0
    while limit == 0 or n < limit:
        ok, frame = cap.read()  # H x W x 3 uint8 BGR
        if not ok:
            break
        yield frame
        n += 1
    cap.release()


def surprise_per_frame(path, limit, settings):
    extractor = rost.vision.WordExtractor()
    model = None
    out = []
    for t, frame in enumerate(frames(path, limit)):
        if model is None:
            height, width = frame.shape[:2]
            config = rost.Config(V=extractor.vocabulary_size, frame_width=width, frame_height=height,
                                 ring_steps=max(limit, 1) if limit else 2048, **settings)
            model = rost.Model(config)
        words, positions = extractor(frame)  # int32 (N,), int32 (N, 2): no copy of the frame
        model.add_observation(t, words, positions)
        out.append(model.surprise(t))  # computed as the words arrived, before they touch the model
        model.refine()  # the Config's budget: budget.refines time steps drawn by its sampler
    if model is None:
        sys.exit(f"curiosity.py: no frame could be read from {path}")
    return np.asarray(out)


def jumps(surprise, window=10, factor=2.0):
    return [t for t in range(window, len(surprise))
            if surprise[t] >= factor * np.median(surprise[t - window:t])]


def plot(surprise, marked, title, path):
    fig, ax = plt.subplots(figsize=(9, 3.2), dpi=100)
    ax.plot(np.arange(len(surprise)), surprise, color="tab:red", lw=1.2, label="surprise")
    if marked:
        ax.scatter(marked, surprise[marked], color="black", zorder=3, s=18, label="jump (>= 2x median of 10 before)")
    ax.set_yscale("log")  # the first frame, seen by an empty model, has surprise V
    ax.set_xlabel("frame")
    ax.set_ylabel("surprise (perplexity of new words)")
    ax.set_title(title)
    ax.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("video")
    p.add_argument("--frames", type=int, default=0, help="frames to read (0: all)")
    p.add_argument("--out", default="surprise.png", help="the plot (PNG)")
    p.add_argument("--csv", help="also write frame,surprise (as rost run's surprise.csv)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="a setting of rost.Config, e.g. --set K=32 --set budget_refines=8")
    a = p.parse_args()
    settings = {}
    for kv in a.set:
        key, _, value = kv.partition("=")
        settings[key] = value  # rost.Config parses the text as a configuration file does
    s = surprise_per_frame(a.video, a.frames, settings)
    marked = jumps(s)
    plot(s, marked, f"rost curiosity: {a.video.rsplit('/', 1)[-1]}, {len(s)} frames", a.out)
    if a.csv:
        with open(a.csv, "w") as f:
            f.write("frame,surprise\n")
            f.writelines(f"{t},{v!r}\n" for t, v in enumerate(s))
    print(f"{len(s)} frames, surprise median {np.median(s):.1f}, max {s.max():.1f} at frame {int(s.argmax())}, "
          f"jumps at {marked}; wrote {a.out}")


if __name__ == "__main__":
    main()
