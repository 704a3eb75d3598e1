"""Python habits: pickle and deepcopy, pathlib paths, numpy scalars, integers named by their value,
a stopped engine, perplexity without words, and a Config that dir() and help() describe."""

import copy
import math
import pathlib
import pickle

import numpy as np
import pytest

import rost
import rost.io
from conftest import random_observation, small_config


def _fed_model(rng, observations=6, **overrides):
    model = rost.Model(small_config(**overrides))
    for t in range(observations):
        model.add_observation(t, *random_observation(rng))
    model.refine(steps=20)
    return model


def _state(model):
    """Everything a user reads of a model: labels, samples, words, counts, perplexities, surprises."""
    ts = [int(t) for t in model.timestamps()]
    return dict(
        timestamps=ts,
        topics=[model.topics(t).tolist() for t in ts],
        ml_topics=[model.ml_topics(t).tolist() for t in ts],
        words=[model.words(t).tolist() for t in ts],
        positions=[model.positions(t).tolist() for t in ts],
        perplexity=[model.perplexity(t) for t in ts] + [model.perplexity()],
        surprise=[model.surprise(t) for t in ts],
        topic_model=model.topic_model().tolist(),
        topic_weights=model.topic_weights().tolist(),
        observations=model.observations,
        steps=model.steps,
    )


@pytest.mark.parametrize("how", ["pickle", "deepcopy", "copy"])
def test_a_model_copy_continues_bit_for_bit(how):
    rng = np.random.default_rng(11)
    model = _fed_model(rng, budget_refines=3)
    clone = {"pickle": lambda m: pickle.loads(pickle.dumps(m)), "deepcopy": copy.deepcopy, "copy": copy.copy}[how](model)
    assert clone is not model and isinstance(clone, rost.Model)
    assert clone.config == model.config
    assert _state(clone) == _state(model)
    # The same observations and the same refinement to both: the same numbers, to the bit.
    for t in range(6, 12):
        words, positions = random_observation(rng)
        for m in (model, clone):
            m.add_observation(t, words, positions)
            m.refine(steps=5)
    for m in (model, clone):
        m.refine()          # the Config's budget
        m.refine(sweeps=2)
    assert _state(clone) == _state(model)
    # Independent: refining the copy leaves the original as it was.
    before = _state(model)
    clone.refine(sweeps=1)
    assert _state(model) == before and _state(clone) != before


def test_a_pickled_model_with_growth_and_a_loaded_one_pickle_too(tmp_path):
    rng = np.random.default_rng(3)
    model = _fed_model(rng, K=8, topics_grow=True)
    model.save(tmp_path / "m.ckpt")
    loaded = rost.Model.load(tmp_path / "m.ckpt")
    for m in (model, loaded):
        clone = pickle.loads(pickle.dumps(m, protocol=pickle.HIGHEST_PROTOCOL))
        assert clone.active_topics == m.active_topics
        m.refine(sweeps=1)
        clone.refine(sweeps=1)
        assert _state(clone) == _state(m)


def test_a_snapshot_pickles_and_a_config_deep_copies():
    rng = np.random.default_rng(0)
    with rost.Engine(small_config(budget_refines=2)) as engine:
        assert engine.push(5, *random_observation(rng))
    snap = engine.snapshot()
    for clone in (pickle.loads(pickle.dumps(snap)), copy.deepcopy(snap)):
        assert isinstance(clone, rost.Snapshot)
        for name in ("version", "observation", "sequence", "timestamp", "step", "perplexity", "surprise", "counters"):
            assert getattr(clone, name) == getattr(snap, name), name
        for name in ("labels", "words", "positions", "cell_surprise", "histograms"):
            a, b = getattr(clone, name), getattr(snap, name)
            assert a.dtype == b.dtype and np.array_equal(a, b), name
    config = small_config(sampler="uni+now", budget_ms=5.0)
    for clone in (copy.deepcopy(config), copy.copy(config)):
        assert clone == config and clone is not config and repr(clone) == repr(config)


def test_what_cannot_be_pickled_says_what_to_do_instead(tmp_path):
    engine = rost.Engine(small_config())
    for attempt in (pickle.dumps, copy.deepcopy, copy.copy):
        with pytest.raises(TypeError, match=r"rost\.Engine cannot be pickled.*engine\.config.*rost\.Model"):
            attempt(engine)
    rost.io.write_words(tmp_path / "words.csv", [0, 1], [[1, 2, 3], [4, 5]])
    mission = rost.Mission(tmp_path / "words.csv")
    with pytest.raises(TypeError, match=r"rost\.Mission cannot be pickled.*mission\.save\(path\)"):
        pickle.dumps(mission)


def test_vision_objects_cannot_be_pickled_and_take_paths(tmp_path):
    vision = pytest.importorskip("rost.vision")
    if not hasattr(vision, "Vocabulary"):
        pytest.skip("rost built without rost::vision")
    vocabulary = vision.Vocabulary.default()
    with pytest.raises(TypeError, match=r"rost\.vision\.Vocabulary cannot be pickled.*Vocabulary\.load\(path\)"):
        pickle.dumps(vocabulary)
    with pytest.raises(TypeError, match=r"rost\.vision\.WordExtractor cannot be pickled"):
        copy.deepcopy(vision.WordExtractor(vocabulary))
    vocabulary.save(tmp_path / "v.rostvoc")
    assert len(vision.Vocabulary.load(tmp_path / "v.rostvoc")) == len(vocabulary)
    assert vision.WordExtractor(tmp_path / "v.rostvoc").vocabulary_size == vision.WordExtractor().vocabulary_size
    for call in (lambda: vision.Vocabulary.load(7), lambda: vocabulary.save(7), lambda: vision.WordExtractor(7)):
        with pytest.raises(TypeError, match="expected a path"):
            call()


def test_every_path_argument_takes_pathlib(tmp_path):
    rng = np.random.default_rng(1)
    model = _fed_model(rng)
    model.save(tmp_path / "m.ckpt")
    assert _state(rost.Model.load(tmp_path / "m.ckpt")) == _state(model)
    assert _state(rost.Model.load(str(tmp_path / "m.ckpt"))) == _state(model)
    with pytest.raises(TypeError, match=r"rost\.Model\.save: path: expected a path \(str or os\.PathLike\), found int"):
        model.save(3)
    with pytest.raises(TypeError, match=r"rost\.Model\.load: path: expected a path"):
        rost.Model.load(b"m.ckpt")
    with pytest.raises(FileNotFoundError):
        rost.Model.load(tmp_path / "missing.ckpt")
    # The text layer under rost.io takes them as well (rost.io converts, its callers need not).
    from rost._rost import text

    text.write_matrix(tmp_path / "tm.csv", np.arange(6, dtype=np.int64).reshape(2, 3))
    assert text.TextFile(tmp_path / "tm.csv").header() == ["0", "1", "2"]
    with pytest.raises(TypeError, match="expected a path"):
        text.TextFile(1.5)
    # Missions: the stream, the checkpoint they resume and the one they save.
    rost.io.write_words(tmp_path / "words.csv", list(range(4)), [[1, 2, 3]] * 4)
    mission = rost.Mission(tmp_path / "words.csv", K=4, seed=3)
    mission.run()
    mission.save(tmp_path / "mission.ckpt")
    rost.io.write_words(tmp_path / "longer.csv", list(range(6)), [[1, 2, 3]] * 6)
    resumed = rost.Mission(tmp_path / "longer.csv", resume=tmp_path / "mission.ckpt")
    assert resumed.resuming and resumed.skipped == 4 and len(resumed) == 2


def test_numpy_scalars_are_numbers():
    config = rost.Config(alpha=np.float32(0.1), K=np.int64(8), V=np.uint16(40), topics_grow=np.bool_(True),
                         budget_ms=np.float64(2.5))
    assert config.K == 8 and type(config.K) is int
    assert config.alpha == float(np.float32(0.1)) and config.topics_grow is True and config.budget_ms == 2.5
    assert config.replace(topics_grow=np.False_).topics_grow is False
    with pytest.raises(ValueError, match=r"^rost\.Config: K: expected a number, found (np\.)?True_?$"):
        rost.Config(K=np.True_)
    with pytest.raises(ValueError, match=r"^rost\.Config: alpha: expected a number, found True$"):
        rost.Config(alpha=True)
    rng = np.random.default_rng(2)
    model = rost.Model(small_config(seed=np.int32(7)))
    model.add_observation(np.int64(4), *random_observation(rng))
    assert model.refine(steps=np.int64(3)) > 0 and model.refine(sweeps=np.uint8(1)) > 0
    assert math.isfinite(model.perplexity(np.int64(4))) and model.topics(np.int16(4)).shape == (200,)
    assert rost.parallel_refine(model, np.int64(2), np.int64(1)) > 0
    engine = rost.Engine(small_config())
    assert engine.push(np.int64(1), *random_observation(rng))


def test_an_integer_out_of_range_is_named_by_its_value():
    model = rost.Model(small_config())
    counts = np.zeros((4, 40), dtype=np.uint64)
    counts[1, 2] = 2**63
    with pytest.raises(ValueError, match=r"counts\[1, 2\] = 9223372036854775808 exceeds 2\^31 - 1"):
        model.set_topic_model(counts)
    counts[1, 2] = 2**64 - 1
    with pytest.raises(ValueError, match=r"counts\[1, 2\] = 18446744073709551615 exceeds"):
        model.set_topic_model(counts)
    counts[1, 2] = 2**31
    with pytest.raises(ValueError, match=r"counts\[1, 2\] = 2147483648 exceeds"):
        model.set_topic_model(counts.astype(np.int64))
    with pytest.raises(ValueError, match=r"counts\[1, 2\] = -5 is negative"):
        model.set_topic_model(np.where(counts > 0, -5, 0).astype(np.int8))
    counts[1, 2] = 7
    model.set_topic_model(counts)
    assert model.topic_model()[1, 2] == 7 and model.topic_weights()[1] == 7
    # Counts add to the model's own: a row named by its number where the total passes 2^31 - 1.
    counts[1, 2] = 2**31 - 1
    with pytest.raises(ValueError, match=r"counts: topic 1 would hold more than 2\^31 - 1 words"):
        model.set_topic_model(counts)
    # A total of 2^31 - 1 leaves n_k no room for the window's words: the library's bound, a ValueError too.
    counts[1, 2] = 2**31 - 1 - 7
    with pytest.raises(ValueError, match=r"counts: topic 1 would hold 2147483647 words with the model's own counts"):
        model.set_topic_model(counts)
    assert model.topic_weights()[1] == 7


def test_push_after_stop_raises_until_started_again():
    rng = np.random.default_rng(4)
    engine = rost.Engine(small_config())
    assert engine.push(0, *random_observation(rng))  # before start(): queued
    engine.start()
    assert engine.push(1, *random_observation(rng))
    engine.stop()
    with pytest.raises(RuntimeError, match=r"rost\.Engine\.push: the engine is stopped"):
        engine.push(2, *random_observation(rng))
    with rost.Engine(small_config()) as e:
        pass
    with pytest.raises(RuntimeError, match="stopped"):
        e.push(3, *random_observation(rng))
    engine.start()
    assert engine.push(3, *random_observation(rng))
    engine.stop()
    assert engine.counters()["ingested"] == 3


def test_an_observation_without_words_has_nan_perplexity():
    model = rost.Model(small_config())
    assert math.isnan(model.perplexity())  # an empty window
    model.add_observation(0, np.zeros(0, dtype=np.int32))
    model.refine(sweeps=1)
    assert math.isnan(model.perplexity(0)) and math.isnan(model.perplexity())
    assert model.topics(0).shape == (0,)
    model.add_observation(1, *random_observation(np.random.default_rng(5)))
    assert math.isnan(model.perplexity(0)) and math.isfinite(model.perplexity(1)) and math.isfinite(model.perplexity())
    assert "NaN" in rost.Model.perplexity.__doc__


def test_config_settings_are_documented_properties_dir_lists():
    config = small_config()
    names = dir(config)
    described = rost.Config.describe()
    assert len(described) > 20
    for d in described:
        prop = getattr(rost.Config, d["name"])
        assert isinstance(prop, property), d["name"]
        assert prop.__doc__ and d["doc"] in prop.__doc__ and d["type"] in prop.__doc__, d["name"]
        assert d["name"] in names
        assert getattr(config, d["name"]) == config.to_dict().get(d["name"])
    assert config.K == 4 and config.cell_space == 32
    assert getattr(config, "cell.space") == 32  # a key still reads
    with pytest.raises(AttributeError, match="no setting 'kk'"):
        config.kk
    with pytest.raises(AttributeError):
        config.K = 5


def _stub_classes(path):
    """{class name: {member name: the return annotation's text}} of a .pyi file."""
    import ast

    tree = ast.parse(path.read_text(), filename=str(path))
    return {node.name: {f.name: ast.unparse(f.returns) if f.returns else "" for f in node.body
                        if isinstance(f, ast.FunctionDef)}
            for node in tree.body if isinstance(node, ast.ClassDef)}


def test_type_stubs_beside_the_package_name_every_public_member():
    package = pathlib.Path(rost.__file__).parent
    assert (package / "py.typed").exists()
    stubs = _stub_classes(package / "_rost.pyi")
    classes = [rost.Config, rost.Model, rost.Engine, rost.Snapshot, rost.Mission, rost.MergedTopics]
    vision = getattr(rost._rost, "vision", None)
    if vision is not None:
        vision_stubs = _stub_classes(package / "vision.pyi")
        stubs.update({"vision." + k: v for k, v in vision_stubs.items()})
        classes += [vision.Vocabulary, vision.WordExtractor, vision.Mission]
    for cls in classes:
        key = ("vision." if cls.__module__.endswith("vision") else "") + cls.__name__
        public = {n for n in vars(cls) if not n.startswith("_")}
        assert public <= set(stubs[key]), (key, sorted(public - set(stubs[key])))
        assert set(stubs[key]) - {n for n in stubs[key] if n.startswith("__")} <= public | set(dir(cls)), key
    for d in rost.Config.describe():
        assert stubs["Config"][d["name"]].split(" |")[0] == d["type"], d["name"]
