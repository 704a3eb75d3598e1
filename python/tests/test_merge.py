"""rost.merge_topic_models (docs/fleet.md): models given as paths or arrays
meet in one global set whatever their topic numbers, the result is rost
merge's bytes, and bad input is named."""

import os
import pathlib
import subprocess

import numpy as np
import pytest

import rost


def planted(topics, V=60, seed=0, words=400):
    """K x V counts: topic k's words drawn from block topics[k] (10 words each)."""
    rng = np.random.default_rng(seed)
    counts = np.zeros((len(topics), V), dtype=np.int64)
    for k, t in enumerate(topics):
        np.add.at(counts[k], t * 10 + rng.integers(0, 10, words), 1)
    return counts


def test_topics_of_the_same_words_meet_and_counts_add_up(tmp_path):
    a, b = planted([0, 1, 2], seed=1), planted([2, 0, 1, 3], seed=2)
    path = tmp_path / "a.csv"
    path.write_text("\n".join(",".join(map(str, row)) for row in a) + "\n")
    m = rost.merge_topic_models([path, b])
    assert m.global_counts.shape == (4, 60)
    assert m.global_counts.sum() == a.sum() + b.sum()
    assert list(m.lifting[0]) == [0, 1, 2]
    assert list(m.lifting[1]) == [2, 0, 1, 3], "b's topics are a's in another order, and one of its own"
    assert m.distance[1][3] == 0.0 and 0.0 < m.distance[1][0] < 0.2
    assert m.lifting_csv(["a", "b"]).splitlines()[:2] == ["model,local,global", "a,0,0"]


def test_counts_of_any_integer_dtype_are_taken():
    """Counts as numpy keeps them: signed or unsigned, 8 to 64 bits, give the same merge."""
    a, b = planted([0, 1, 2], seed=1), planted([2, 0, 1, 3], seed=2)
    want = rost.merge_topic_models([a, b])
    for dtype in (np.uint32, np.uint16, np.int32, np.uint64):
        m = rost.merge_topic_models([a.astype(dtype), b.astype(dtype)])
        assert (m.global_counts == want.global_counts).all(), dtype
        assert [list(l) for l in m.lifting] == [list(l) for l in want.lifting], dtype


def test_the_same_bytes_as_rost_merge(tmp_path):
    tool = os.environ.get("ROST_TOOL")
    if not tool:
        pytest.skip("ROST_TOOL is not set")
    paths = []
    for i, topics in enumerate([[0, 1, 2], [1, 2, 4], [4, 0]]):
        p = tmp_path / f"m{i}.csv"
        p.write_text("\n".join(",".join(map(str, row)) for row in planted(topics, seed=i)) + "\n")
        paths.append(p)
    subprocess.run([tool, "merge", *map(str, paths), "--out", str(tmp_path / "out"), "-q"], check=True)
    m = rost.merge_topic_models(paths)
    assert (tmp_path / "out" / "topicmodel.csv").read_text() == m.topicmodel_csv()
    assert (tmp_path / "out" / "lifting.csv").read_text() == m.lifting_csv()


def test_bad_input_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="missing.csv"):
        rost.merge_topic_models([tmp_path / "missing.csv"])
    with pytest.raises(TypeError, match=r"models\[0\]: expected a path or a 2-D integer numpy array"):
        rost.merge_topic_models([np.zeros(3)])
    # One path where a list is due: refused as such, not read as one-letter paths.
    for one in (str(tmp_path / "a.csv"), b"a.csv"):
        with pytest.raises(TypeError, match=r"models is a list of paths or arrays, not one path \(write \[path\]\)"):
            rost.merge_topic_models(one)
    with pytest.raises(ValueError, match=r"merge threshold 2 out of range \[0, 1\]"):
        rost.merge_topic_models([planted([0])], threshold=2.0)
    with pytest.raises(ValueError, match="model 0: count of topic 0, word 3 is negative"):
        bad = planted([0])
        bad[0, 3] = -1
        rost.merge_topic_models([bad])
    # Counts past what a topicmodel.csv holds are named as given: uint64 ones were cast to
    # negative int64, and int64 sums near 2^63 wrapped.
    with pytest.raises(ValueError, match=r"model 0: count of topic 0, word 0 is 18446744073709551615, more than"):
        rost.merge_topic_models([np.array([[2**64 - 1, 2, 3]], dtype=np.uint64)])
    with pytest.raises(ValueError, match=r"model 1: count of topic 0, word 0 is 4611686018427387904, more than"):
        rost.merge_topic_models([np.array([[1, 1]]), np.array([[2**62, 1]])])
    assert rost.merge_topic_models([np.array([[2**31 - 1, 1]], dtype=np.uint64)]).global_counts[0, 0] == 2**31 - 1
    # A checkpoint of a growing model that holds no word has no open topic: named as the file.
    empty = tmp_path / "empty.ckpt"
    rost.Model(rost.Config(K=4, V=3, topics_grow=True)).save(str(empty))
    with pytest.raises(ValueError, match=r"empty\.ckpt: a model with topics\.grow that holds no word"):
        rost.merge_topic_models([planted([0]), empty])
    with pytest.raises(ValueError, match="names: 1 names for 2 models"):
        rost.merge_topic_models([planted([0]), planted([1])]).lifting_csv(["x"])
