"""rost.io: the rost tool's files as numpy arrays, both ways."""

import os
import subprocess
import sys

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
    assert sorted(os.listdir(tmp_path)) == ["positions.csv", "words.csv"]  # no temporary file left


def test_errors_name_file_and_line(tmp_path):
    f = tmp_path / "words.csv"
    f.write_text("# comment\n0,1,2\n\n1,3,x\n")
    with pytest.raises(ValueError, match=r"words.csv:4:5: expected an integer, found 'x'"):
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


def test_writers_write_every_value_exactly_or_refuse_it(tmp_path):
    """A value the file cannot hold as given is refused naming it, never rounded, wrapped or flattened."""
    f = tmp_path / "w.csv"
    with pytest.raises(ValueError, match=r"^timestamps\[1\] = 1\.7 is not a whole number in int64's range$"):
        rost.io.write_words(f, [0.0, 1.7], [[1, 2], [3]])
    with pytest.raises(ValueError, match=r"^row 0\[0\] = 18446744073709551615 exceeds 2\^63 - 1$"):
        rost.io.write_words(f, [0], [np.array([2**64 - 1], np.uint64)])
    with pytest.raises(ValueError, match=r"^counts\[0\] = 18446744073709551615 exceeds 2\^63 - 1$"):
        rost.io.write_topicmodel(f, np.array([[2**64 - 1, 1]], np.uint64))
    with pytest.raises(ValueError, match=r"^row 0: expected a 1-D array, found shape \(2, 2\)$"):
        rost.io.write_words(f, [0], [np.ones((2, 2), np.int32)])
    # The tables' frame and topics columns, as the word stream's time stamps: never truncated.
    rows = {"timestamp": [0.0, 1.2], "instantaneous": [1.0, 2.0], "final": [1.0, 2.0], "plugin": [1.0, 2.0],
            "topics": [3, 4], "surprise": [5.0, 6.0]}
    with pytest.raises(ValueError, match=r"^timestamp\[1\] = 1\.2 is not a whole number in int64's range$"):
        rost.io.write_perplexity(f, rows)
    with pytest.raises(ValueError, match=r"^timestamp\[1\] = 1\.2 is not a whole number in int64's range$"):
        rost.io.write_surprise(f, rows)
    # The edge of int64: 2^63 as a float is one past its largest value (it would wrap to -2^63),
    # -2^63 is its smallest and is written as itself.
    with pytest.raises(ValueError, match=r"^timestamps\[0\] = 9\.223372036854776e\+18 is not a whole number in int64's range$"):
        rost.io.write_words(f, [2.0**63], [[1]])
    for bad in (float("nan"), 1e300):
        with pytest.raises(ValueError, match=r"^topics\[1\] = .* is not a whole number in int64's range$"):
            rost.io.write_perplexity(f, dict(rows, timestamp=[0, 1], topics=[4.0, bad]))
    assert not f.exists()
    # Whole-number floats and uint64 values within int64 are written as the integers they are.
    rost.io.write_words(f, np.array([0.0, 2.0]), [np.array([7, 2**40], np.uint64), np.array([], np.int32)])
    assert f.read_text() == "0,7,1099511627776\n2\n"
    rost.io.write_words(f, [-(2.0**63)], [[1]])
    assert f.read_text() == "-9223372036854775808,1\n"


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


ERRORS = {  # reader, file, its text, the error
    "overflow": ("read_words", "words.csv", "0,1\n1, 2,99999999999999999999\n",
                 r"words.csv:2:6: number '99999999999999999999' out of range"),
    "empty field": ("read_words", "words.csv", "# c\r\n\r\n0,1\r\n7,,3\r\n", r"words.csv:4:3: expected an integer, found ''"),
    "not a number": ("read_surprise", "surprise.csv", "frame,surprise\n0,1.5\n1,x\n",
                     r"surprise.csv:3:3: expected a number, found 'x'"),
    "too many fields": ("read_surprise", "surprise.csv", "frame,surprise\n0,1.5,2\n", r"surprise.csv:2: 3 fields, expected 2"),
    "too few cells": ("read_surprise_cells", "surprise_cells.csv", "frame,cell0,cell1\n# c\n4,0.5,nan\n5,1\n",
                      r"surprise_cells.csv:4: 1 cell, expected 2"),
    "a count too large": ("read_topicmodel", "topicmodel.csv", "1,2\n3,9223372036854775808\n",
                          r"topicmodel.csv:2:3: number '9223372036854775808' out of range"),
}


@pytest.mark.parametrize("case", ERRORS)
def test_errors_name_file_line_and_column(tmp_path, case):
    reader, name, content, message = ERRORS[case]
    (tmp_path / name).write_text(content)
    with pytest.raises(ValueError, match=message):
        getattr(rost.io, reader)(tmp_path / name)


def test_comments_blank_lines_and_crlf_are_read_as_the_tool_reads_them(tmp_path):
    f = tmp_path / "words.csv"
    f.write_bytes(b"# made elsewhere\r\n0,3,4\r\n \t\r\n\r\n2\r\n5,1,\r\n")
    ts, words = rost.io.read_words(f)
    assert list(ts) == [0, 2, 5]
    assert [list(w) for w in words] == [[3, 4], [], [1]]
    c = tmp_path / "surprise_cells.csv"
    c.write_text("frame,cell0,cell1\n4,0.5,nan\n5,1e-3,inf\n")
    frames, cells = rost.io.read_surprise_cells(c)
    assert list(frames) == [4, 5] and cells[0, 0] == 0.5 and np.isnan(cells[0, 1]) and cells[1, 1] == np.inf


def test_a_directory_where_a_file_is_expected(tmp_path):
    d = tmp_path / "words.csv"
    d.mkdir()
    with pytest.raises(IsADirectoryError, match="words.csv: is a directory, not a file"):
        rost.io.read_words(d)
    with pytest.raises(IsADirectoryError, match="words.csv: rename failed"):
        rost.io.write_words(d, [0], [np.array([1], np.int32)])
    with pytest.raises(FileNotFoundError, match="missing.csv: cannot open"):
        rost.io.read_topicmodel(tmp_path / "missing.csv")
    with pytest.raises(FileNotFoundError):
        rost.io.write_topicmodel(tmp_path / "no" / "tm.csv", np.ones((2, 2), np.int32))
    assert sorted(os.listdir(tmp_path)) == ["words.csv"] and not os.listdir(d)


def test_values_past_int32_are_refused_not_wrapped(tmp_path):
    """read_words/read_positions return int32: 2^31 - 1 and -2^31 are read back exactly, one past
    either is refused naming the line (it would wrap to the other end)."""
    f = tmp_path / "w.csv"
    f.write_text("0,2147483647,0\n1,5\n")
    assert [list(w) for w in rost.io.read_words(f)[1]] == [[2147483647, 0], [5]]
    f.write_text("0,1\n1,2147483648\n")
    with pytest.raises(ValueError, match=r"w\.csv:2: a value does not fit in int32"):
        rost.io.read_words(f)
    p = tmp_path / "p.csv"
    p.write_text("0,-2147483648,1\n")
    assert rost.io.read_positions(p)[1][0].tolist() == [[-2147483648, 1]]
    p.write_text("0,-2147483649,1\n")
    with pytest.raises(ValueError, match=r"p\.csv:1: a value does not fit in int32"):
        rost.io.read_positions(p)


def test_a_failed_write_leaves_the_old_file(tmp_path):
    f = tmp_path / "words.csv"
    rost.io.write_words(f, [0], [np.array([1, 2], np.int32)])
    # A child whose files may not grow past 1 KiB: a write of ~200 KiB fails part-way.
    script = (
        "import resource, signal, sys, numpy as np, rost\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (1024, 1024))\n"
        "try:\n"
        "    rost.io.write_words(sys.argv[1], np.arange(20000), [np.arange(5, dtype=np.int32)] * 20000)\n"
        "except OSError as e:\n"
        "    print(e)\n"
        "    sys.exit(0)\n"
        "sys.exit(1)\n")
    r = subprocess.run([sys.executable, "-c", script, str(f)], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "words.csv: write failed" in r.stdout
    assert f.read_text() == "0,1,2\n"
    assert os.listdir(tmp_path) == ["words.csv"]  # no temporary file left
