"""rost.Mission: a word stream's mission by the library's one policy, the session `rost refine`
drives too: the same stream, seed and settings give the same results on both faces; a checkpoint
resumed skips its own observations; a model keyword that differs from the checkpoint's is refused
naming the keyword; bad streams raise ValueError naming the file."""

import contextlib
import os
import signal
import subprocess
import time

import numpy as np
import pytest

import rost

TOOL = os.environ.get("ROST_TOOL")


@contextlib.contextmanager
def ctrl_c_after(seconds):
    """KeyboardInterrupt raised in the main thread after `seconds`, as a Ctrl-C would; the timer and
    the SIGALRM handler before it restored on the way out."""

    def interrupt(*_):
        raise KeyboardInterrupt()

    previous = signal.signal(signal.SIGALRM, interrupt)
    try:
        signal.setitimer(signal.ITIMER_REAL, seconds)
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


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
    with pytest.raises(RuntimeError, match="already played"):
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
    np.testing.assert_array_equal(ppx["plugin"], r["plugin"])
    np.testing.assert_array_equal(ppx["topics"], r["topics"])
    np.testing.assert_array_equal(rost.io.read_surprise(out / "surprise.csv")["surprise"], r["surprise"])
    frames, cells = rost.io.read_surprise_cells(out / "surprise_cells.csv")
    assert r["surprise_cells"].shape == cells.shape == (len(ts), 4)  # a 64x64 frame, cells of 32
    np.testing.assert_array_equal(cells.astype(np.float32), r["surprise_cells"])
    # rost.io writes them back as the tool's own bytes.
    rost.io.write_perplexity(tmp_path / "p.csv", r)
    rost.io.write_surprise(tmp_path / "s.csv", r)
    assert (tmp_path / "p.csv").read_bytes() == (out / "perplexity.csv").read_bytes()
    assert (tmp_path / "s.csv").read_bytes() == (out / "surprise.csv").read_bytes()


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
    # A dotted key is named as the keyword on both sides, never as the library's key.
    with pytest.raises(ValueError, match=r"cell_space=16 differs from .*m\.ckpt's cell_space = 32 .*leave cell_space out"):
        rost.Mission(words, positions=positions, resume=tmp_path / "m.ckpt", cell_space=16)
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
    with pytest.raises(IsADirectoryError, match=r"is a directory, not a file"):
        rost.Mission(tmp_path)


def test_one_user_at_a_time_and_ctrl_c_stops_between_observations(tmp_path):
    """save() from another thread while run() plays is refused (it would copy a state being changed);
    a signal handler that raises (Ctrl-C) stops run() between two observations, and what was played
    can be saved and resumed."""
    import threading

    rng = np.random.default_rng(8)
    n = 3000
    ts = list(range(n))
    words = [rng.integers(0, 50, 300, dtype=np.int32) for _ in ts]
    rost.io.write_words(tmp_path / "long.csv", ts, words)
    m = rost.Mission(tmp_path / "long.csv", K=8)
    errors = []
    finished = threading.Event()

    def save_while_running():  # once run() plays (len 0: nothing left to play), a save is refused
        while len(m) != 0 and not finished.is_set():
            time.sleep(0.001)
        try:
            m.save(tmp_path / "race.ckpt")
        except RuntimeError as e:
            errors.append(str(e))

    t = threading.Thread(target=save_while_running)
    try:
        t.start()
        with ctrl_c_after(0.5), pytest.raises(KeyboardInterrupt):
            m.run()
    finally:
        finished.set()
        t.join()
    assert errors and "rost.Mission is in use by another thread" in errors[0], errors
    assert len(m) == 0
    m.save(tmp_path / "part.ckpt")
    rest = rost.Mission(tmp_path / "long.csv", resume=tmp_path / "part.ckpt")
    assert 0 < rest.skipped < n and len(rest) == n - rest.skipped


def test_arguments_are_checked_as_a_user_gives_them(tmp_path):
    words, positions = planted_stream(tmp_path)
    with pytest.raises(TypeError, match=r"rost\.Mission: words: expected a path \(str or os\.PathLike\), found NoneType"):
        rost.Mission(None)
    m = rost.Mission(words, positions=positions, frame_width=80, frame_height=70)
    assert (m.config.frame_width, m.config.frame_height) == (80, 70), "frame_width/frame_height are the frame"
    with pytest.raises(ValueError, match=r"positions\.csv:1:\d+: .*outside"):
        rost.Mission(words, positions=positions, frame_width=20, frame_height=20)
    for side in ("width", "height"):  # as the tool's --width -5: refused, not taken as "from the data"
        with pytest.raises(ValueError, match=r"rost\.Mission: %s = -5, allowed at least 0" % side):
            rost.Mission(words, positions=positions, **{side: -5})
    with pytest.raises(FileNotFoundError, match=r"rost\.Mission\.save: .*nodir"):  # as open() raises it
        m.save(tmp_path / "nodir" / "m.ckpt")
    # The mission's own inputs would be replaced: refused by name, the file kept.
    before = open(positions, "rb").read()
    with pytest.raises(RuntimeError, match=r"rost\.Mission\.save: .*positions\.csv is an input of this run"):
        m.save(positions)
    with pytest.raises(RuntimeError, match=r"is the same file as the input .*words\.csv"):
        m.save(os.path.join(os.path.dirname(words), "..", os.path.basename(os.path.dirname(words)), "words.csv"))
    assert open(positions, "rb").read() == before
    # Whatever the current directory is by then: the inputs are the files the mission read.
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "words.csv").write_text("not the mission's\n")
    here = os.getcwd()
    try:
        os.chdir(elsewhere)
        with pytest.raises(RuntimeError, match=r"is the same file as the input"):
            m.save(os.path.relpath(words))
        m.save("words.csv")  # another file of that name: not an input
    finally:
        os.chdir(here)
    assert open(positions, "rb").read() == before
    with pytest.raises(ValueError, match=r"rost\.Mission\.save: path: no file given \(an empty path\)"):
        m.save("")
    # "-", standard output to the command lines, is refused as they refuse it, not written as a file "-".
    try:
        os.chdir(elsewhere)
        with pytest.raises(RuntimeError, match=r"^rost\.Mission\.save: '-' names no file: this output is written to a "
                           r"named file, not to standard output \(\./- for a file of that name\)$"):
            m.save("-")
        assert not os.path.exists("-")
    finally:
        os.chdir(here)


def test_ctrl_c_during_the_final_sweeps_stops_them(tmp_path):
    """A million final sweeps (minutes) stop at Ctrl-C within a round: KeyboardInterrupt, soon."""
    words, positions = planted_stream(tmp_path)
    m = rost.Mission(words, positions=positions, K=4, cell_space=32, final_sweeps=1000000)
    start = time.monotonic()
    with ctrl_c_after(0.5), pytest.raises(KeyboardInterrupt):
        m.run()
    assert time.monotonic() - start < 30, "the sweeps went on after Ctrl-C"
    m.save(tmp_path / "part.ckpt")  # the model is whole
