"""Shared helpers of the rost Python tests (run by ctest: PYTHONPATH=build/python)."""

import os
import pathlib

import numpy as np
import pytest

SOURCE_DIR = pathlib.Path(os.environ.get("ROST_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
DIVER = SOURCE_DIR / "data/pd-extendedview/usr/share/doc/pd-extendedview/media/diver.mov"


def small_config(**overrides):
    import rost

    settings = dict(K=4, V=40, frame_width=128, frame_height=128, cell_space=32, ring_steps=64, seed=7)
    settings.update(overrides)
    return rost.Config(**settings)


def random_observation(rng, n=200, V=40, width=128, height=128):
    words = rng.integers(0, V, n, dtype=np.int32)
    positions = np.stack([rng.integers(0, width, n), rng.integers(0, height, n)], axis=1).astype(np.int32)
    return words, positions


def two_topic_observation(rng, n=200, half=64):
    """Words 0..9 on the left half of a 128 x 128 frame, 10..19 on the right: two topics to recover."""
    x = rng.integers(0, 128, n).astype(np.int32)
    y = rng.integers(0, 128, n).astype(np.int32)
    words = np.where(x < half, rng.integers(0, 10, n), rng.integers(10, 20, n)).astype(np.int32)
    return words, np.stack([x, y], axis=1)


def footage_or_skip():
    """diver.mov (scripts/fetch-footage.sh pd-extendedview); under CI its absence is a failure."""
    if DIVER.exists():
        return DIVER
    if os.environ.get("CI") == "true":
        pytest.fail(f"{DIVER} is missing (scripts/fetch-footage.sh pd-extendedview)")
    pytest.skip(f"real footage missing: run scripts/fetch-footage.sh pd-extendedview ({DIVER})")


def read_frames(path, count, step=1):
    cv2 = pytest.importorskip("cv2")
    cap = cv2.VideoCapture(str(path))
    frames = []
    index = 0
    while len(frames) < count:
        ok, frame = cap.read()
        if not ok:
            break
        if index % step == 0:
            frames.append(frame)
        index += 1
    cap.release()
    assert frames, f"cv2 could not read {path}"
    return frames
