"""rost.Engine: the realtime engine from Python."""

import time

import numpy as np
import pytest

import rost
from conftest import random_observation, small_config


def test_snapshot_is_none_before_the_first_then_the_newest():
    rng = np.random.default_rng(0)
    engine = rost.Engine(small_config(budget_refines=2))
    assert engine.snapshot() is None
    with engine:
        assert engine.running
        for t in range(5):
            assert engine.push(100 + t, *random_observation(rng))
            time.sleep(0.01)
    assert not engine.running
    s = engine.snapshot()
    assert s.timestamp == 104 and s.step == 4 and s.observation == 4
    assert s.labels.dtype == np.int32 and s.labels.shape == (200,) and s.labels.max() < 4
    assert s.words.shape == (200,) and s.positions.shape == (200, 2)
    assert s.cell_surprise.shape == (4, 4) and s.cell_surprise.dtype == np.float32
    assert s.histograms.shape == (16, 4) and s.histograms.sum() == 200
    assert isinstance(s.perplexity, float) and s.perplexity > 1
    assert isinstance(s.surprise, float) and s.surprise > 1
    assert s.counters["ingested"] == 5 and s.counters["refinements"] == 10


def test_snapshot_grid_is_rows_by_columns():
    rng = np.random.default_rng(3)
    engine = rost.Engine(small_config(frame_width=128, frame_height=64, budget_refines=1))
    with engine:
        assert engine.push(0, *random_observation(rng, width=128, height=64))
    s = engine.snapshot()
    assert s.cell_surprise.shape == (2, 4)  # 64 / 32 rows, 128 / 32 columns
    assert s.histograms.shape == (8, 4)


def test_push_never_blocks_and_counts_drops():
    rng = np.random.default_rng(1)
    engine = rost.Engine(small_config(budget_refines=2000, queue_slots=2, drop="newest"))
    data = [random_observation(rng) for _ in range(50)]
    with engine:
        t0 = time.perf_counter()
        accepted = [engine.push(t, w, p) for t, (w, p) in enumerate(data)]
        elapsed = time.perf_counter() - t0
    assert elapsed < 5.0  # 50 pushes while the refiner is busy: none waits (loose: a loaded machine; a
    # push that waited for a slot would let every observation in, which the next line refuses)
    assert not all(accepted)
    c = engine.counters()
    assert c["pushed"] == 50
    assert c["dropped_newest"] == accepted.count(False)
    assert c["ingested"] == accepted.count(True)


def test_a_full_queue_under_drop_oldest_counts_the_oldest_dropped():
    """drop="oldest" (the default): a full queue discards its oldest observation, counted as
    dropped_oldest, never as dropped_newest (each counter is its own, from the engine's). Pushed
    before start(), so no refiner's claim is outstanding and every drop is of the oldest."""
    rng = np.random.default_rng(2)
    engine = rost.Engine(small_config(queue_slots=2, drop="oldest"))
    assert all(engine.push(t, *random_observation(rng)) for t in range(50))
    c = engine.counters()
    assert (c["pushed"], c["dropped_oldest"], c["dropped_newest"]) == (50, 48, 0), c
    with engine:
        pass  # drains the two left
    c = engine.counters()
    assert (c["ingested"], c["dropped_oldest"], c["dropped_newest"]) == (2, 48, 0), c


def test_push_checks_its_arrays_like_add_observation():
    engine = rost.Engine(small_config())
    with pytest.raises(TypeError, match="int32"):
        engine.push(0, np.zeros(3, np.int64))
    with pytest.raises(ValueError, match=r"words\[0\] = 40"):
        engine.push(0, np.array([40], np.int32))
    with pytest.raises(ValueError, match=r"positions\[0\]"):
        engine.push(0, np.array([1], np.int32), np.array([[500, 0]], np.int32))
    # The frame's edges: x = width and y = height are outside it, width - 1 and height - 1 inside.
    for x, y in ((128, 0), (0, 128)):
        with pytest.raises(ValueError, match=r"positions\[0\] = \(%d, %d\)" % (x, y)):
            engine.push(0, np.array([1], np.int32), np.array([[x, y]], np.int32))
    assert engine.counters()["pushed"] == 0
    assert engine.push(0, np.array([1], np.int32), np.array([[127, 127]], np.int32))


def test_start_twice_is_an_error_and_stop_is_idempotent():
    engine = rost.Engine(small_config())
    engine.start()
    with pytest.raises(RuntimeError, match="already running"):
        engine.start()
    engine.stop()
    engine.stop()
    assert engine.config.K == 4
    assert engine.memory_bytes > 0
