"""rost.Mission: a word stream's mission by the library's one policy, the session `rost refine`
drives too: the same stream, seed and settings give the same results on both faces; a checkpoint
resumed skips its own observations; a model keyword that differs from the checkpoint's is refused
naming the keyword; bad streams raise ValueError naming the file."""

import os
import subprocess

import numpy as np
import pytest

import rost

TOOL = os.environ.get("ROST_TOOL")


def planted_stream(tmp_path, n=60, seed=3):
    """Two topics on words 0..9 and 10..19, in halves of a 64 x 64 frame, regimes of 10 observations."""
    rng = np.random.default_rng(seed)
    ts, words, positions = [], [], []
    for t in range(n):
        x = rng.integers(0, 64, 40).astype(np.int32)
        y = rng.integers(0, 64, 40).astype(np.int32)
        w = np.where(x < 32, rng.integers(0, 10, 40), rng.integers(10, 20, 40)).astype(np.int32)
        ts.append(t)
        words.append(w)
        positions.append(np.stack([x, y], axis=1))
    rost.io.write_words(tmp_path / "words.csv", ts, words)
    rost.io.write_positions(tmp_path / "positions.csv", ts, positions)
    return tmp_path / "words.csv", tmp_path / "positions.csv"


def test_a_new_mission_is_planned_from_its_stream_and_plays_it(tmp_path):
    words, positions = planted_stream(tmp_path)
    m = rost.Mission(words, positions=positions, K=4, cell_space=32, seed=11)
    assert len(m) == 60 and not m.resuming and m.skipped == 0
    c = m.config
    assert (c.V, c.frame_width, c.frame_height, c.max_words) == (20, 64, 64, 40)
    assert c.ring_steps == 61, "the whole stream stays refinable"
    r = m.run()
    assert r["timestamp"].tolist() == list(range(60))
    assert all(len(z) == 40 for z in r["labels"])
    assert np.isfinite(r["instantaneous"]).all() and np.isfinite(r["final"]).all()
    # The planted halves: each half's words mostly share one label, and the two labels differ.
    _, pos = rost.io.read_positions(positions)
    left = np.concatenate([z[p[:, 0] < 32] for z, p in zip(r["labels"], pos)])
    right = np.concatenate([z[p[:, 0] >= 32] for z, p in zip(r["labels"], pos)])
    lmode, rmode = np.bincount(left).argmax(), np.bincount(right).argmax()
    assert lmode != rmode
    assert (left == lmode).mean() > 0.8 and (right == rmode).mean() > 0.8
    with pytest.raises(ValueError, match="already played"):
        m.run()


@pytest.mark.parametrize("ring", [None, 20])  # 20: observations leave the window before the end
def test_the_same_stream_gives_rost_refines_results(tmp_path, ring):
    if not TOOL:
        pytest.skip("the rost tool is not built")
    words, positions = planted_stream(tmp_path)
    out = tmp_path / "out"
    p = subprocess.run([TOOL, "refine", str(words), "--positions", str(positions), "-K", "4", "--cell.space", "32",
                        "--seed", "11", "--final.sweeps", "5", "--out", str(out), "--no-summary", "-q"]
                       + (["--ring.steps", str(ring)] if ring else []),
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, timeout=120)
    assert p.returncode == 0, p.stderr.decode()
    extra = {"ring_steps": ring} if ring else {}
    r = rost.Mission(words, positions=positions, K=4, cell_space=32, seed=11, final_sweeps=5, **extra).run()
    ts, topics = rost.io.read_topics(out / "topics.csv")
    assert ts.tolist() == r["timestamp"].tolist()
    assert all(np.array_equal(a, b) for a, b in zip(topics, r["labels"]))
    ppx = rost.io.read_perplexity(out / "perplexity.csv")
    np.testing.assert_array_equal(ppx["instantaneous"], r["instantaneous"])
    np.testing.assert_array_equal(ppx["final"], r["final"])


def test_a_resumed_mission_skips_the_checkpoints_observations(tmp_path):
    words, positions = planted_stream(tmp_path)
    ts, w = rost.io.read_words(words)
    _, p = rost.io.read_positions(positions)
    rost.io.write_words(tmp_path / "first.csv", ts[:30], w[:30])
    rost.io.write_positions(tmp_path / "first_pos.csv", ts[:30], p[:30])
    first = rost.Mission(tmp_path / "first.csv", positions=tmp_path / "first_pos.csv", K=4, cell_space=32,
                         width=64, height=64, V=20, ring_steps=61, max_words=40)
    first.run()
    first.save(tmp_path / "m.ckpt")
    resumed = rost.Mission(words, positions=positions, resume=tmp_path / "m.ckpt")
    assert resumed.resuming and resumed.skipped == 30 and len(resumed) == 30
    assert resumed.run()["timestamp"].tolist() == list(range(30, 60))
    with pytest.raises(ValueError, match=r"K=8 differs from .*m\.ckpt's K = 4 .*leave K out"):
        rost.Mission(words, positions=positions, resume=tmp_path / "m.ckpt", K=8)
    with pytest.raises(ValueError, match=r"no positions, but .*m\.ckpt models 64x64 frames"):
        rost.Mission(words, resume=tmp_path / "m.ckpt")


def test_bad_streams_and_settings_are_refused_naming_them(tmp_path):
    (tmp_path / "empty.csv").write_text("\n\n")
    with pytest.raises(ValueError, match=r"empty\.csv: no observations"):
        rost.Mission(tmp_path / "empty.csv")
    (tmp_path / "wordless.csv").write_text("0\n1\n")
    with pytest.raises(ValueError, match=r"wordless\.csv: no words in its 2 observations"):
        rost.Mission(tmp_path / "wordless.csv")
    (tmp_path / "bad.csv").write_text("0,1,2\n1,3,x\n")
    with pytest.raises(ValueError, match=r"bad\.csv:2:5: "):
        rost.Mission(tmp_path / "bad.csv")
    with pytest.raises(ValueError, match=r"eta"):
        rost.Mission(tmp_path / "bad.csv", eta=2)
    with pytest.raises(ValueError, match=r"is a directory"):
        rost.Mission(tmp_path)
