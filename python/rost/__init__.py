"""rost: realtime online spatiotemporal topic models (docs/python.md).

    import numpy as np, rost
    model = rost.Model(rost.Config(V=100, K=8, frame_width=640, frame_height=480))
    model.add_observation(0, words, positions)   # int32 (N,) and int32 (N, 2), taken without a copy
    model.refine(steps=40)                        # releases the interpreter lock
    model.topics(0), model.perplexity(0), model.surprise(0)

rost.Engine is the realtime engine (a refiner thread, push() that never blocks,
snapshot()); rost.Mission plays a word stream (words.csv, positions.csv) by the
library's mission session, as `rost refine` does, resuming a checkpoint when asked;
rost.vision turns cv2 frames into words; rost.io reads and writes the rost tool's files;
rost.rostpy runs scripts written for rostpy (`import rost.rostpy as rostpy`); rost.fleet runs a
season of missions (here or on Dask), merges their topics and lifts their labels (docs/fleet.md).
"""

from ._rost import Config, Engine, MergedTopics, Mission, Model, Snapshot, __version__, merge_topic_models, version_string
from . import io

__all__ = ["Config", "Engine", "MergedTopics", "Mission", "Model", "Snapshot", "fleet", "io", "merge_topic_models",
           "parallel_refine", "vision", "__version__", "version_string"]


def parallel_refine(model, threads, sweeps=1):
    """rostpy's name: `sweeps` batch sweeps of `model` on `threads` threads.

    Deterministic: the same seed, input and sweeps give the same model for any
    number of threads (refinement in windows of `refine_window` cell picks).
    Returns the tokens refined."""
    return model.parallel_refine(threads, sweeps)


def __getattr__(name):
    # rost.vision on first use (it needs the library built with OpenCV); rost.fleet too.
    if name in ("vision", "fleet"):
        import importlib

        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'rost' has no attribute '{name}'")
