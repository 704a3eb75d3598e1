"""rost.Config: every setting of the one schema by keyword; errors name the setting."""

import pickle
import re

import pytest

import rost
from conftest import SOURCE_DIR


def schema_keys():
    """The keys of ROST_SETTINGS, read from the header itself (not through the bindings)."""
    text = (SOURCE_DIR / "include/rost/settings_schema.hpp").read_text()
    return re.findall(r'^\s*X\("([^"]+)"', text, re.M)


def test_every_schema_key_is_a_keyword_with_its_default():
    keys = schema_keys()
    assert len(keys) > 30
    described = {d["key"]: d for d in rost.Config.describe()}
    assert sorted(described) == sorted(keys)
    cfg = rost.Config()
    for key in keys:
        name = re.sub(r"[.-]", "_", key)
        assert described[key]["name"] == name
        assert getattr(cfg, name) == described[key]["default"]


def test_values_are_typed_and_round_trip():
    cfg = rost.Config(K=32, alpha=0.25, cell_space=48, sampler="agep+exp", thread_fifo=True, budget_tokens=500,
                      seed=2**64 - 1)
    d = cfg.to_dict()
    assert d["K"] == 32 and isinstance(d["K"], int)
    assert d["alpha"] == 0.25 and isinstance(d["alpha"], float)
    assert d["sampler"] == "agep+exp"
    assert d["thread_fifo"] is True
    assert d["budget_tokens"] == 500 and "budget_refines" not in d  # one budget in force
    assert d["seed"] == 2**64 - 1
    assert rost.Config(**d) == cfg
    assert pickle.loads(pickle.dumps(cfg)) == cfg
    assert cfg.replace(K=8).K == 8 and cfg.K == 32
    assert "K=32" in repr(cfg) and "V=" not in repr(cfg)


def test_keys_with_dots_are_accepted():
    assert rost.Config(**{"cell.space": 16, "g.time": 2}).cell_space == 16


@pytest.mark.parametrize("kwargs, names", [
    (dict(cel_space=3), ["cel_space", "cell_space"]),
    (dict(K=0), ["K = 0", "[1, 1024]"]),
    (dict(alpha=0.0), ["alpha"]),
    (dict(alpha=float("nan")), ["alpha"]),
    (dict(K="many"), ["K", "many"]),
    (dict(K=1.5), ["K", "1.5"]),
    (dict(K=True), ["K", "True"]),
    (dict(sampler="fastest"), ["sampler", "fastest"]),
    (dict(eta=2.0), ["eta"]),
    (dict(seed=-1), ["seed"]),
    (dict(budget_refines=4, budget_ms=3.0), ["budget_refines", "budget_ms"]),
    (dict(K=[1]), ["K", "list"]),
])
def test_bad_settings_raise_value_error_naming_them(kwargs, names):
    with pytest.raises(ValueError) as e:
        rost.Config(**kwargs)
    for n in names:
        assert n in str(e.value)


# One structured error from the schema's check, spelled as Python spells the
# settings: the keyword, never the library's key (strategy.eta, cell.space).
@pytest.mark.parametrize("kwargs, message", [
    (dict(eta=2), "rost.Config: eta = 2, allowed [0, 1]"),
    (dict(queue_slots=0), "rost.Config: queue_slots = 0, allowed [1, 65536]"),
    (dict(budget_ms=0.0), "rost.Config: budget_ms = 0, allowed (0, 3600000]"),
    (dict(thumb_cell=0), "rost.Config: thumb_cell = 0, allowed [1, 256]"),
    (dict(alpha="x"), "rost.Config: alpha: expected a finite number, found 'x'"),
    (dict(g_time=9, ring_steps=4), "rost.Config: g_time = 9, allowed [0, 3]; below ring_steps = 4"),
    (dict(etta=0.5), "rost.Config: unknown setting 'etta' (did you mean 'eta'?)"),
])
def test_errors_name_the_keyword(kwargs, message):
    with pytest.raises(ValueError) as e:
        rost.Config(**kwargs)
    assert str(e.value) == message


def test_numpy_scalars_are_numbers():
    import numpy as np
    assert rost.Config(alpha=np.float32(0.25), K=np.int64(8)).alpha == 0.25
    assert rost.Config(beta=np.float64(0.3)).beta == 0.3


def test_unknown_attribute():
    with pytest.raises(AttributeError, match="no setting 'colour'"):
        rost.Config().colour


def test_equality_with_another_type_is_false_not_an_error():
    cfg = rost.Config(K=8)
    assert cfg == rost.Config(K=8) and cfg != rost.Config(K=9)
    assert not (cfg == None) and cfg != 3  # noqa: E711 (the comparison itself is what is tested)
    assert cfg in [1, "K", cfg] and None not in [cfg]
