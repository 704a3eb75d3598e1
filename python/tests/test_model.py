"""rost.Model: rostpy's add_observation / refine / topics over the library."""

import threading
import time

import numpy as np
import pytest

import rost
from conftest import random_observation, small_config, two_topic_observation


def fill(model, rng, count, make=random_observation, start=0):
    for t in range(start, start + count):
        model.add_observation(t, *make(rng))


def test_recovers_two_spatially_separated_topics():
    rng = np.random.default_rng(3)
    model = rost.Model(small_config(K=2, V=20, g_space=0, g_time=0, cell_space=64))
    fill(model, rng, 30, two_topic_observation)
    before = model.perplexity()
    model.refine(sweeps=30)
    assert model.perplexity() < before
    agree = 0
    total = 0
    for t in range(30):
        words, z = model.words(t), model.ml_topics(t)
        left = z[words < 10]
        right = z[words >= 10]
        # each half is one topic, and the two halves differ
        a, b = np.bincount(left, minlength=2).argmax(), np.bincount(right, minlength=2).argmax()
        assert a != b
        agree += np.sum(left == a) + np.sum(right == b)
        total += len(z)
    assert agree / total > 0.95


def test_refine_counts_tokens_and_follows_the_strategy():
    rng = np.random.default_rng(1)
    model = rost.Model(small_config(ring_steps=8, sampler="now"))
    fill(model, rng, 12)
    assert model.observations == 12 and model.steps == 12
    assert model.refine(steps=5) == 5 * 200          # "now": the newest step, 200 words each time
    assert model.refine(sweeps=2) == 2 * 8 * 200     # the window holds 8 steps
    assert model.refine() == 40 * 200                # the Config's budget: budget.refines = 40
    assert model.refine(steps=0) == 0
    with pytest.raises(ValueError, match="not both"):
        model.refine(steps=1, sweeps=1)
    with pytest.raises(ValueError, match="negative"):
        model.refine(steps=-1)
    with pytest.raises(TypeError):
        model.refine(3)  # keywords only


def test_outputs_shapes_and_window():
    rng = np.random.default_rng(2)
    model = rost.Model(small_config(ring_steps=4))
    fill(model, rng, 6)
    model.refine(steps=10)
    assert list(model.timestamps()) == [2, 3, 4, 5]
    z = model.topics(5)
    assert z.dtype == np.int32 and z.shape == (200,) and z.min() >= 0 and z.max() < 4
    assert model.ml_topics(5).shape == (200,)
    assert model.positions(5).shape == (200, 2)
    assert np.isfinite(model.perplexity(5)) and model.perplexity(5) > 1
    assert isinstance(model.surprise(5), float)
    cs = model.cell_surprise(5)
    assert cs.shape == (4, 4) and cs.dtype == np.float32 and (cs > 0).all()
    tm = model.topic_model()
    assert tm.shape == (4, 40) and tm.dtype == np.int32
    assert tm.sum() == 6 * 200  # eviction keep: every word ever added
    assert (model.topic_weights() == tm.sum(axis=1)).all()
    with pytest.raises(KeyError, match="t = 1 in the window"):
        model.topics(1)
    with pytest.raises(KeyError, match="t = 99"):
        model.surprise(99)


def test_same_seed_same_topics_other_seed_others():
    def run(seed):
        rng = np.random.default_rng(5)
        model = rost.Model(small_config(seed=seed))
        for t in range(10):
            model.add_observation(t, *random_observation(rng))
            model.refine(steps=4)
        return np.concatenate([model.topics(t) for t in range(10)])

    assert (run(1) == run(1)).all()
    assert (run(1) != run(2)).any()


def test_model_refine_steps_is_the_engines_budget_refines():
    """add_observation + refine(steps=N) per observation == the engine with budget.refines = N."""
    rng = np.random.default_rng(8)
    data = [random_observation(rng) for _ in range(12)]
    model = rost.Model(small_config())
    for t, (w, p) in enumerate(data):
        model.add_observation(t, w, p)
        model.refine(steps=6)
    engine = rost.Engine(small_config(budget_refines=6, queue_slots=16))
    for t, (w, p) in enumerate(data):
        assert engine.push(t, w, p)
    engine.start()
    engine.stop(drain=True)
    snap = engine.snapshot()
    assert snap.timestamp == 11
    assert (snap.labels == model.ml_topics(11)).all()
    assert snap.perplexity == pytest.approx(model.perplexity(11), rel=1e-12)


def test_words_are_not_copied():
    model = rost.Model(small_config())
    words, positions = random_observation(np.random.default_rng(0))
    model.add_observation(0, words, positions)
    assert model._last_input_address == words.ctypes.data
    assert model._last_positions_address == positions.ctypes.data
    view = words[50:]  # a view into the same buffer is taken as it is
    model.add_observation(1, view, positions[50:])
    assert model._last_input_address == view.ctypes.data
    assert model._last_positions_address == positions[50:].ctypes.data


def test_the_engine_takes_words_and_positions_without_a_copy():
    engine = rost.Engine(small_config())
    words, positions = random_observation(np.random.default_rng(1))
    assert engine.push(0, words, positions)
    assert engine._last_input_address == words.ctypes.data
    assert engine._last_positions_address == positions.ctypes.data


@pytest.mark.parametrize("words, positions, error, match", [
    ([1, 2], None, TypeError, "numpy.ndarray of int32, found list"),
    (np.array([1.0, 2.0]), None, TypeError, "dtype int32, found float64"),
    (np.array([1, 2], dtype=np.int64), None, TypeError, "int64"),
    (np.array([1, 2], dtype=np.uint32), None, TypeError, "uint32"),
    (np.array([1, 2], dtype=">i4"), None, TypeError, "int32"),
    (np.zeros((2, 2), np.int32), None, ValueError, r"shape \(N,\)"),
    (np.array([1, 2], np.int32), np.zeros((2, 3), np.int32), ValueError, r"shape \(2, 2\)"),
    (np.array([1, 2], np.int32), np.zeros((3, 2), np.int32), ValueError, r"shape \(2, 2\)"),
    (np.array([1, 2], np.int32), np.zeros(4, np.int32), ValueError, r"shape \(N, 2\)"),
    (np.array([1, 2], np.int32), np.zeros((2, 2), np.float32), TypeError, "float32"),
    (np.array([1, -3], np.int32), None, ValueError, r"words\[1\] = -3"),
    (np.array([1, 40], np.int32), None, ValueError, r"words\[1\] = 40: out of range .*V = 40"),
    (np.array([1, 2], np.int32), np.array([[0, 0], [128, 5]], np.int32), ValueError, r"positions\[1\] = \(128, 5\)"),
    (np.array([1, 2], np.int32), np.array([[0, -1], [1, 5]], np.int32), ValueError, r"positions\[0\]"),
    (np.arange(8, dtype=np.int32)[::2], None, ValueError, "C-contiguous"),
])
def test_bad_arrays_raise_and_change_nothing(words, positions, error, match):
    model = rost.Model(small_config())
    model.add_observation(0, *random_observation(np.random.default_rng(0)))
    before = model.topic_model()
    with pytest.raises(error, match=match):
        model.add_observation(1, words, positions)
    assert model.observations == 1
    assert (model.topic_model() == before).all()


def test_positions_none_puts_every_word_in_the_first_cell():
    model = rost.Model(small_config())
    model.add_observation(0, np.arange(10, dtype=np.int32))
    assert (model.positions(0) == 0).all()
    cs = model.cell_surprise(0)
    assert cs[0, 0] > 0 and (cs.reshape(-1)[1:] == 0).all()


def test_the_lock_is_released_while_refining_and_a_second_thread_is_refused():
    rng = np.random.default_rng(4)
    model = rost.Model(small_config(V=40, K=16))
    fill(model, rng, 64)
    # Calibrate: a refine that takes ~0.5 s on this machine.
    t0 = time.perf_counter()
    model.refine(steps=200)
    per_step = (time.perf_counter() - t0) / 200
    steps = max(200, int(0.5 / per_step))

    ticks = []
    errors = []
    started = threading.Event()

    def refine():
        started.set()
        model.refine(steps=steps)

    worker = threading.Thread(target=refine)
    worker.start()
    started.wait()
    while worker.is_alive():
        ticks.append(time.perf_counter())  # this thread runs while the other refines
        try:
            model.add_observation(1000, *random_observation(rng))
        except RuntimeError as e:
            errors.append(str(e))
        time.sleep(0.001)
    worker.join()
    assert len(ticks) > 20
    assert errors and "in use by another thread" in errors[0]
    assert model.observations == 64 + (len(ticks) - len(errors))  # nothing half-added


def test_save_and_load_continue_bit_for_bit(tmp_path):
    rng = np.random.default_rng(6)
    cfg = small_config(budget_refines=7, sampler="uni+exp", eta=0.3)
    model = rost.Model(cfg)
    fill(model, rng, 10)
    model.refine(steps=20)
    path = tmp_path / "m.ckpt"
    model.save(str(path))
    loaded = rost.Model.load(str(path))
    assert loaded.config == cfg  # the file holds the Config as given, budget included
    assert list(loaded.timestamps()) == list(range(10))
    assert (loaded.topic_model() == model.topic_model()).all()
    extra = random_observation(rng)
    for m in (model, loaded):
        m.add_observation(10, *extra)
        m.refine(steps=15)
    for t in range(11):
        assert (loaded.topics(t) == model.topics(t)).all()
    assert loaded.surprise(10) == model.surprise(10)


def test_load_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.ckpt"):
        rost.Model.load(str(tmp_path / "nope.ckpt"))
    bad = tmp_path / "bad.ckpt"
    bad.write_bytes(b"ROSTCKPT" + b"\0" * 100)
    with pytest.raises(ValueError, match="bad.ckpt"):
        rost.Model.load(str(bad))
    model = rost.Model(small_config())
    model.add_observation(0, *random_observation(np.random.default_rng(0)))
    good = tmp_path / "good.ckpt"
    model.save(str(good))
    data = bytearray(good.read_bytes())
    data[len(data) // 2] ^= 0xFF
    torn = tmp_path / "torn.ckpt"
    torn.write_bytes(bytes(data))
    with pytest.raises(ValueError, match="torn.ckpt.*(corrupt|checksum)"):
        rost.Model.load(str(torn))


def test_set_topic_model_adds_a_prior():
    model = rost.Model(small_config())
    counts = np.random.default_rng(0).integers(0, 5, (4, 40))
    model.set_topic_model(counts)
    assert (model.topic_model() == counts).all()
    with pytest.raises(ValueError, match=r"shape \(K, V\) = \(4, 40\)"):
        model.set_topic_model(np.zeros((4, 39), np.int32))
    with pytest.raises(ValueError, match=r"counts\[1, 2\] = -1"):
        c = np.zeros((4, 40), np.int64)
        c[1, 2] = -1
        model.set_topic_model(c)
    with pytest.raises(ValueError, match="2\\^31"):
        model.set_topic_model(np.full((4, 40), 2**30, np.int64))
    with pytest.raises(TypeError, match="integer dtype"):
        model.set_topic_model(np.zeros((4, 40)))
    assert (model.topic_model() == counts).all()  # refused calls changed nothing


def test_parallel_refine_gives_the_same_model_for_any_number_of_threads():
    def run(threads):
        rng = np.random.default_rng(11)
        model = rost.Model(small_config(refine_window=64))
        fill(model, rng, 12)
        tokens = rost.parallel_refine(model, threads, sweeps=3)
        return tokens, model.topic_model(), np.concatenate([model.topics(t) for t in range(12)])

    one = run(1)
    assert one[0] > 0
    for threads in (2, 3):
        other = run(threads)
        assert other[0] == one[0]
        assert (other[1] == one[1]).all() and (other[2] == one[2]).all()
    with pytest.raises(ValueError, match="threads"):
        rost.parallel_refine(rost.Model(small_config()), 0)


def test_topics_grow_from_one_to_the_two_planted_and_labels_stay_compact():
    rng = np.random.default_rng(4)
    model = rost.Model(small_config(K=8, V=20, g_space=0, g_time=0, cell_space=64, topics_grow=True, gamma=1e-3))
    assert model.active_topics == 0
    fill(model, rng, 30, two_topic_observation)
    assert model.active_topics == 1
    model.refine(sweeps=60)
    assert 2 <= model.active_topics <= 4
    labels = np.concatenate([model.ml_topics(t) for t in range(30)])
    assert labels.max() < model.active_topics
    # the two planted halves are told apart by their majority topics
    words = np.concatenate([model.words(t) for t in range(30)])
    a = np.bincount(labels[words < 10]).argmax()
    b = np.bincount(labels[words >= 10]).argmax()
    assert a != b


def test_load_takes_settings_by_the_missions_one_policy(tmp_path):
    model = rost.Model(small_config(budget_refines=7, sampler="uni+exp"))
    fill(model, np.random.default_rng(7), 5)
    path = tmp_path / "m.ckpt"
    model.save(str(path))
    # A model setting must repeat the checkpoint's: it is named by its keyword.
    with pytest.raises(ValueError) as e:
        rost.Model.load(str(path), K=8)
    assert str(e.value) == ("K=8 differs from %s's K = 4 (a resumed mission keeps its model; leave K out)" % path)
    assert rost.Model.load(str(path), K=4).config.K == 4
    # Refinement settings given replace the checkpoint's; the others stay.
    loaded = rost.Model.load(str(path), sampler="now")
    assert loaded.config.sampler == "now" and loaded.config.budget_refines == 7
    assert (loaded.topic_model() == model.topic_model()).all()
    with pytest.raises(ValueError, match=r"unknown setting 'samplr' \(did you mean 'sampler'\?\)"):
        rost.Model.load(str(path), samplr="now")


def test_sampled_labels_are_numbered_as_the_ml_labels_when_a_closed_topic_lies_below_an_open_one():
    """With growth, open topics are numbered 0..A-1 in label order: topics 0 and 2 open (1 closed)
    are 0 and 1 in every output. The Gibbs sample (topics(), topics.csv) must be renumbered as the
    maximum-likelihood labels are: here every word belongs to raw topic 2, which is output 1."""
    model = rost.Model(small_config(K=4, V=10, topics_grow=True, gamma=1e-6, g_space=0, g_time=0, cell_space=64))
    counts = np.zeros((4, 10), dtype=np.int32)
    counts[0, :5] = 5000  # topic 0: words 0..4
    counts[2, 5:] = 5000  # topic 2: words 5..9; topics 1 and 3 stay closed
    model.set_topic_model(counts)
    assert model.active_topics == 2
    words = np.arange(5, 10, dtype=np.int32).repeat(20)
    model.add_observation(0, words, np.zeros((len(words), 2), np.int32))
    model.refine(sweeps=5)
    A = model.active_topics
    sampled, ml = model.topics(0), model.ml_topics(0)
    assert ml.max() < A and sampled.max() < A, (A, sampled.max())
    assert (ml == 1).all(), "words of raw topic 2 are output topic 1"
    assert (sampled == ml).mean() > 0.9


def test_topic_model_rows_follow_the_labels_when_topics_grow():
    """With growth the labels number the open topics 0..A-1; topic_model()'s row i and
    topic_weights()[i] are label i's, as topicmodel.csv's rows are, with the closed slots' zero
    rows after them. Here raw topics 0 and 2 are open (1 and 3 closed), so label 1 is raw topic 2."""
    model = rost.Model(small_config(K=4, V=10, topics_grow=True, gamma=1e-6, g_space=0, g_time=0, cell_space=64))
    counts = np.zeros((4, 10), dtype=np.int32)
    counts[0, :5] = 5000
    counts[2, 5:] = 5000
    model.set_topic_model(counts)
    words = np.arange(5, 10, dtype=np.int32).repeat(20)
    model.add_observation(0, words, np.zeros((len(words), 2), np.int32))
    model.refine(sweeps=5)
    assert model.active_topics == 2 and (model.ml_topics(0) == 1).all()
    tm, nk = model.topic_model(), model.topic_weights()
    assert (tm[0, :5] >= 5000).all() and (tm[0, 5:] == 0).all(), tm
    assert (tm[1, 5:] >= 5000).all() and (tm[1, :5] == 0).all(), tm
    assert (tm[1, 5:] > 5000).any(), "label 1's row holds the observation's words"
    assert (tm[2:] == 0).all() and (nk[2:] == 0).all()
    assert (nk == tm.sum(axis=1)).all()
    # The rows go back in as they came out: a fresh model given them holds the same topic model.
    again = rost.Model(small_config(K=4, V=10, topics_grow=True, gamma=1e-6, g_space=0, g_time=0, cell_space=64))
    again.set_topic_model(tm)
    assert (again.topic_model() == tm).all()
