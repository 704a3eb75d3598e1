"""rost.rostpy: rostpy's classes and functions over rost (docs/python.md)."""

import importlib.util
import subprocess
import sys

import numpy as np
import pytest

import rost.rostpy as rostpy
from conftest import SOURCE_DIR

EXAMPLE = SOURCE_DIR / "examples/python/rostpy_planted.py"


def example():
    spec = importlib.util.spec_from_file_location("rostpy_planted", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def strong_prior(K, V, weight=1000):
    """A topic model where word v belongs to topic v % K, heavily."""
    tm = [[0] * V for _ in range(K)]
    for v in range(V):
        tm[v % K][v] = weight
    return tm


def test_a_rostpy_script_recovers_planted_topics_whatever_the_threads():
    ex = example()
    stream = ex.planted_stream(7)
    labels = ex.learn(stream, threads=2)
    assert [len(z) for z in labels] == [len(w) for w, _ in stream]
    assert ex.purity(labels, [t for _, t in stream]) >= 0.8
    assert ex.learn(stream, threads=1) == labels  # seeded, and independent of the threads


def test_the_example_script_prints_its_purity():
    r = subprocess.run([sys.executable, str(EXAMPLE), "--seed", "3"], check=True, capture_output=True, text=True)
    assert r.stdout.startswith("purity ") and float(r.stdout.split()[1]) >= 0.8


def test_labels_come_one_a_word_in_the_order_added():
    m = rostpy.ROST_txy(V=12, K=3, alpha=0.1, beta=0.5, gamma=0)
    m.set_topic_model(strong_prior(3, 12))
    added = {(4, 0, 0): [0, 1, 2, 5], (4, 1, 0): [7, 3], (9, 0, 1): [11, 10, 4]}
    m.add_observation([4, 0, 0], [0, 1])
    m.add_observation((4, 1, 0), np.array([7, 3], dtype=np.uint16))
    m.add_observation(np.array([4, 0, 0]), [2, 5])  # the same pose again: its words go on
    m.add_observation([9, 0, 1], np.array([11, 10, 4]))
    for _ in range(5):
        rostpy.parallel_refine(m, 1)
    for pose, words in added.items():
        assert m.get_ml_topics_for_pose(list(pose)) == [w % 3 for w in words]
        assert len(m.get_topics_for_pose(list(pose))) == len(words)
    assert m.num_cells() == 3 and m.estimate_cell(1) == [1, 0]
    assert m.get_poses_by_time() == {4: [[4, 0, 0], [4, 1, 0]], 9: [[9, 0, 1]]}
    assert m.model.steps == 2  # a time's poses are one rost time step


def test_rost_t_takes_any_increasing_timestamps_and_refuses_what_rost_cannot_serve():
    m = rostpy.ROST_t(V=10, K=2, alpha=0.1, beta=0.5, gamma=0)
    m.add_observation([100], [1, 2])
    m.add_observation([100], [3])  # not yet handed to rost: the step grows
    m.add_observation([250], [4, 5])
    with pytest.raises(ValueError, match=r"t = 7 goes back in time \(the latest is t = 250"):
        m.add_observation([7], [1])
    rostpy.parallel_refine(m, 1)
    assert [len(m.get_ml_topics_for_pose([t])) for t in (100, 250)] == [3, 2]
    with pytest.raises(ValueError, match=r"t = 250 repeats the time of a step rost already holds"):
        m.add_observation([250], [1])
    m.add_observation([251], [1])
    assert len(m.get_topics_for_pose([251])) == 1 and m.model.steps == 3
    with pytest.raises(KeyError, match="no words at pose"):
        m.get_topics_for_pose([252])
    with pytest.raises(ValueError, match=r"a pose has 1 coordinates \(\[t\]\)"):
        m.add_observation([1, 2, 3], [1])
    with pytest.raises(ValueError, match=r"words\[1\] = 10 is outside \[0, V = 10\)"):
        m.add_observation([300], [1, 10])


def test_gamma_zero_fixes_K_and_gamma_above_lets_topics_grow():
    fixed = rostpy.ROST_t(V=10, K=4, alpha=0.1, beta=0.5, gamma=0)
    grow = rostpy.ROST_t(V=10, K=4, alpha=0.1, beta=0.5, gamma=0.5)
    for m in (fixed, grow):
        m.add_observation([0], [1, 2, 3])
    assert not fixed.model.config.topics_grow and fixed.active_K == 4
    assert grow.model.config.topics_grow and grow.model.config.gamma == 0.5 and grow.active_K < 4
    assert (grow.alpha, grow.beta, grow.gamma, grow.betaV) == (0.1, 0.5, 0.5, 5.0)
    for bad in (-1.0, float("nan")):  # NaN is neither: refused, as rost.Config and --gamma refuse it
        with pytest.raises(ValueError, match=r"rost\.rostpy: gamma = %s: expected 0 \(a fixed K\) or more" % bad):
            rostpy.ROST_t(V=10, K=4, alpha=0.1, beta=0.5, gamma=bad)


def test_topic_model_as_lists_of_lists():
    m = rostpy.ROST_t(V=6, K=2, alpha=0.1, beta=0.5, gamma=0)
    assert m.get_topic_model() == [[0] * 6, [0] * 6]
    m.add_observation([0], [1, 1, 5])
    tm = m.get_topic_model()
    assert len(tm) == 2 and all(len(row) == 6 for row in tm)
    assert [tm[0][v] + tm[1][v] for v in range(6)] == [0, 2, 0, 0, 0, 1]
    assert sum(m.get_topic_weights()) == 3
    with pytest.raises(ValueError, match="already holds observations"):
        m.set_topic_model(tm)


def test_update_model_false_labels_with_the_topic_model_it_was_given():
    # Needs rost's Config setting topicmodel.fixed (rost.Config(topicmodel_fixed=True)).
    m = rostpy.ROST_t(V=12, K=3, alpha=0.1, beta=0.5, gamma=0)
    prior = strong_prior(3, 12, weight=200)
    m.set_topic_model(prior)
    m.add_observation([0], [0, 4, 8, 1], update_model=False)
    m.add_observation([1], [2, 5, 11], update_model=False)
    for _ in range(3):
        rostpy.parallel_refine(m, 1)
    assert m.get_topic_model() == prior  # the words' labels change, n_k^v does not
    assert m.get_ml_topics_for_pose([0]) == [0, 1, 2, 1] and m.get_ml_topics_for_pose([1]) == [2, 2, 2]
    assert not m.update_global_model


def test_a_model_either_learns_or_is_fixed():
    m = rostpy.ROST_t(V=10, K=2, alpha=0.1, beta=0.5, gamma=0)
    m.add_observation([0], [1, 2])
    with pytest.raises(ValueError, match=r"update_model=False, but this model is learning .*either learns"):
        m.add_observation([1], [3], update_model=False)
    m.add_observation([1], [3], True)  # rostpy's positional update_model


def test_rost_xy_ignores_time_and_returns_a_cells_words_across_steps():
    m = rostpy.ROST_xy(V=12, K=3, alpha=0.1, beta=0.5, gamma=0)
    m.set_topic_model(strong_prior(3, 12))
    m.add_observation([0, 1, 1], [0, 1])
    m.add_observation([5, 1, 1], [2])  # t ignored: the same cell
    m.add_observation([2, 0], [4])
    rostpy.parallel_refine(m, 1)
    m.add_observation([9, 1, 1], [5, 9])  # after a refinement: a new rost time step
    rostpy.parallel_refine(m, 1)
    assert m.get_ml_topics_for_pose([1, 1]) == [0, 1, 2, 2, 0]
    assert m.get_ml_topics_for_pose([77, 2, 0]) == [1]
    assert m.num_cells() == 2 and m.model.steps == 2
    with pytest.raises(NotImplementedError, match="ROST_xy.time_perplexity is not served: ROST_xy ignores time"):
        m.time_perplexity(0)


def test_what_rost_cannot_serve_says_so():
    m = rostpy.ROST_txy(V=10, K=2, alpha=0.1, beta=0.5, gamma=0)
    m.add_observation([0, 0, 0], [1, 2])
    with pytest.raises(NotImplementedError, match="refine_pose is not served: rost refines whole time steps"):
        m.refine_pose([0, 0, 0])
    with pytest.raises(NotImplementedError, match="forget is not served: .*ring_steps"):
        m.forget()
    with pytest.warns(RuntimeWarning, match="g_sigma is kept but not used"):
        m.g_sigma = 0.5
    assert m.g_sigma == 0.5, "a script that reads it back sees its value"
    with pytest.raises(NotImplementedError, match=r"perplexity\(pose\) is not served: rost measures perplexity per"):
        m.perplexity([0, 0, 0])
    with pytest.raises(NotImplementedError, match="add_observation with topics"):
        m.add_observation([0, 1, 0], [1], [0])
    with pytest.raises(ValueError, match=r"tau = 2 \(Beta\(tau, 1\) over cells\) has no rost counterpart"):
        rostpy.parallel_refine_tau(m, 1, 2, 4)


def test_parallel_refine_tau_refines_steps_drawn_by_the_sampler():
    m = rostpy.ROST_t(V=10, K=2, alpha=0.1, beta=0.5, gamma=0)
    for t in range(4):
        m.add_observation([t], [1, 2, 3])
    rostpy.parallel_refine_tau(m, 1, 1.0, 8)
    assert m.get_refine_count() == 8 and m.get_word_refine_count() == 24
    rostpy.parallel_refine(m, 2)
    assert m.get_refine_count() == 12 and m.get_word_refine_count() == 36


def test_perplexities_and_refine_ext():
    m = rostpy.ROST_t(V=12, K=3, alpha=0.1, beta=0.5, gamma=0, seed=3)
    m.set_topic_model(strong_prior(3, 12, weight=200))
    m.add_observation([5], [0, 3, 6])
    m.add_observation([8], [1, 4, 7, 10])
    rostpy.parallel_refine(m, 1)
    assert m.time_perplexity(8) == m.perplexity([8]) == m.model.perplexity(1) > 1
    assert m.perplexity(False) == m.model.perplexity()
    wp = m.word_perplexity([8])
    assert len(wp) == 4 and all(1 < p < 12 for p in wp)  # a word of its pose's topic: far likelier than 1 / V
    z, ll = m.get_ml_topics_and_ppx_for_pose([5])
    assert z == [0, 0, 0] and ll < 0
    assert m.refine_ext([2, 5, 8, 11, 1], 5) == [2, 2, 2, 2, 1]
    assert m.refine_ext([2, 5], 5) == m.refine_ext([2, 5], 5)
    # A word outside [0, V) or topic counts of another length than K are refused by name, never
    # read from the topic model's end (-1 as word V - 1) or cut and broadcast to K.
    with pytest.raises(ValueError, match=r"^rost\.rostpy\.cell_perplexity_word: words\[1\] = -1 out of range \[0, 12\)$"):
        m.cell_perplexity_word([3, -1], [1, 1, 1])
    with pytest.raises(ValueError, match=r"^rost\.rostpy\.refine_ext: words\[0\] = 12 out of range \[0, 12\)$"):
        m.refine_ext([12])
    with pytest.raises(ValueError, match=r"^rost\.rostpy\.nZ: expected K = 3 topic counts, found shape \(2,\)$"):
        m.cell_perplexity_word([3], [1, 1])
    with pytest.raises(ValueError, match=r"^rost\.rostpy\.refine_ext: nZg: expected K = 3 topic counts, found shape \(1,\)$"):
        m.refine_ext([3], 2, nZg=[5])


def test_the_type_stubs_name_every_public_member():
    import ast
    import pathlib

    tree = ast.parse((pathlib.Path(rostpy.__file__).with_suffix(".pyi")).read_text())
    stubbed = {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    base = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "_ROST")
    members = {n.name for n in base.body if isinstance(n, ast.FunctionDef) and not n.name.startswith("_")}
    members |= {n.target.id for n in base.body if isinstance(n, ast.AnnAssign)}
    assert set(rostpy.__all__) <= stubbed
    for cls in (rostpy.ROST_t, rostpy.ROST_txy, rostpy.ROST_xy):
        public = {n for n in dir(cls(V=4, K=2, alpha=0.1, beta=0.5, gamma=0)) if not n.startswith("_")}
        assert public == members, (cls.__name__, sorted(public ^ members))


def test_a_refused_add_leaves_no_empty_time_step():
    """An observation refused once the model is made (a pose off its grid) adds nothing: no empty
    time step is handed to the model, which would stand between its neighbours in time."""
    x = rostpy.ROST_txy(V=20, K=3, alpha=0.1, beta=0.5, gamma=0)
    x.add_observation([0, 0, 0], [1, 2])
    rostpy.parallel_refine(x, 1)
    for t in (1, 2):
        with pytest.raises(ValueError, match="lies outside the grid"):
            x.add_observation([t, 100, 0], [1])
    x.add_observation([3, 0, 0], [5])
    rostpy.parallel_refine(x, 1)
    assert list(x.model.timestamps()) == [0, 1], "two time steps: t = 0 and t = 3, nothing between"
    assert list(x.model.words(1)) == [5]


def test_a_step_or_cell_past_the_models_sizes_is_refused_naming_both():
    """Once the model is made (max_words and cell_capacity sized from what came before), a time step
    of more than max_words words, or a cell of more than cell_capacity, is refused with ValueError
    naming both sizes; up to them is taken."""
    x = rostpy.ROST_txy(V=20, K=3, alpha=0.1, beta=0.5, gamma=0)
    x.add_observation([0, 0, 0], [1, 2])
    x.add_observation([0, 4, 4], [1, 2])  # a 5 x 5 grid
    rostpy.parallel_refine(x, 1)
    c = x.model.config
    assert (c.max_words, c.cell_capacity) == (256, 64), "the test's premise"
    refused = r"a time step of more than max_words = 256 words or a cell of more than cell_capacity = 64"
    for cx in range(4):  # 4 cells of 60 words: 240 in the step
        x.add_observation([1, cx, 0], list(range(20)) * 3)
    with pytest.raises(ValueError, match=refused):  # a fifth: 300 words in the step, each cell under 64
        x.add_observation([1, 4, 0], list(range(20)) * 3)
    x.add_observation([1, 4, 0], list(range(16)))  # 256 words: taken
    with pytest.raises(ValueError, match=refused):  # 65 words in one cell
        x.add_observation([2, 0, 0], list(range(13)) * 5)
    x.add_observation([2, 0, 0], list(range(16)) * 4)  # 64: taken
    rostpy.parallel_refine(x, 1)
    assert [len(x.model.words(t)) for t in range(3)] == [4, 256, 64]
