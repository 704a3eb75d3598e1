"""rost.io: the rost tool's files as numpy arrays, both ways."""

import os
import subprocess

import numpy as np
import pytest

import rost
from conftest import random_observation, small_config


def test_rows_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    ts = np.array([0, 5, 9])
    words = [rng.integers(0, 40, n, dtype=np.int32) for n in (3, 0, 7)]
    positions = [rng.integers(0, 128, (len(w), 2), dtype=np.int32) for w in words]
    rost.io.write_words(tmp_path / "words.csv", ts, words)
    rost.io.write_positions(tmp_path / "positions.csv", ts, positions)
    assert (tmp_path / "words.csv").read_text().splitlines()[1] == "5"
    rts, rwords = rost.io.read_words(tmp_path / "words.csv")
    _, rpos = rost.io.read_positions(tmp_path / "positions.csv")
    assert rts.dtype == np.int64 and list(rts) == [0, 5, 9]
    for a, b, p, q in zip(words, rwords, positions, rpos):
        assert b.dtype == np.int32 and (a == b).all()
        assert q.shape == p.shape and (p == q).all()
    assert not [f for f in os.listdir(tmp_path) if f.startswith(".rost-io-")]  # no temporary file left


def test_errors_name_file_and_line(tmp_path):
    f = tmp_path / "words.csv"
    f.write_text("# comment\n0,1,2\n\n1,3,x\n")
    with pytest.raises(ValueError, match=r"words.csv:4: expected an integer, found 'x'"):
        rost.io.read_words(f)
    f.write_text("0,1,2,3\n")
    with pytest.raises(ValueError, match=r"positions.csv:1: 3 coordinates"):
        g = tmp_path / "positions.csv"
        g.write_text("0,1,2,3\n")
        rost.io.read_positions(g)
    t = tmp_path / "perplexity.csv"
    t.write_text("frame,instantaneous\n")
    with pytest.raises(ValueError, match="perplexity.csv:1: expected the header"):
        rost.io.read_perplexity(t)
    with pytest.raises(ValueError, match="negative"):
        rost.io.write_topicmodel(tmp_path / "tm.csv", -np.ones((2, 2), np.int32))
    with pytest.raises(ValueError, match=r"shape \(N, 2\)"):
        rost.io.write_positions(tmp_path / "p.csv", [0], [np.zeros(3, np.int32)])


def test_topic_model_round_trip_into_a_model(tmp_path):
    rng = np.random.default_rng(1)
    model = rost.Model(small_config())
    for t in range(5):
        model.add_observation(t, *random_observation(rng))
    model.refine(sweeps=3)
    rost.io.write_topicmodel(tmp_path / "topicmodel.csv", model.topic_model())
    counts = rost.io.read_topicmodel(tmp_path / "topicmodel.csv")
    assert (counts == model.topic_model()).all()
    fresh = rost.Model(small_config())
    fresh.set_topic_model(counts)
    assert (fresh.topic_model() == counts).all()


def test_reads_what_rost_refine_writes_from_what_it_wrote(tmp_path):
    tool = os.environ.get("ROST_TOOL")
    if not tool or not os.path.exists(tool):
        pytest.skip("the rost tool was not built (ROST_VISION)")
    rng = np.random.default_rng(2)
    data = [random_observation(rng, n=50 + 10 * t) for t in range(8)]
    ts = np.arange(8) * 3
    rost.io.write_words(tmp_path / "words.csv", ts, [w for w, _ in data])
    rost.io.write_positions(tmp_path / "positions.csv", ts, [p for _, p in data])
    out = tmp_path / "out"
    subprocess.run([tool, "refine", str(tmp_path / "words.csv"), "--positions", str(tmp_path / "positions.csv"),
                    "--width", "128", "--height", "128", "-V", "40", "-K", "4", "--cell.space", "32",
                    "--out", str(out), "--checkpoint", str(tmp_path / "r.ckpt")], check=True, capture_output=True)
    tts, topics = rost.io.read_topics(out / "topics.csv")
    assert list(tts) == list(ts)
    assert [len(z) for z in topics] == [len(w) for w, _ in data]
    assert all(z.max() < 4 for z in topics)
    ppx = rost.io.read_perplexity(out / "perplexity.csv")
    assert list(ppx["frame"]) == list(ts) and (ppx["final"] > 1).all()
    s = rost.io.read_surprise(out / "surprise.csv")
    assert list(s["frame"]) == list(ts) and np.isfinite(s["surprise"]).all()
    frames, cells = rost.io.read_surprise_cells(out / "surprise_cells.csv")
    assert cells.shape == (8, 16)
    tm = rost.io.read_topicmodel(out / "topicmodel.csv")
    assert tm.shape == (4, 40) and tm.sum() == sum(len(w) for w, _ in data)
    # The same stream through rost.Model with the tool's settings gives its topic model.
    model = rost.Model(small_config(ring_steps=8, seed=1))
    for t, (w, p) in zip(ts, data):
        model.add_observation(int(t), w, p)
        model.refine()
    assert (model.topic_model() == tm).all()
    # Its checkpoint is a Model.
    loaded = rost.Model.load(str(tmp_path / "r.ckpt"))
    assert (loaded.topic_model() == tm).all()
    assert list(loaded.timestamps()) == list(ts)
    assert loaded.config.K == 4 and loaded.config.budget_refines == 40
