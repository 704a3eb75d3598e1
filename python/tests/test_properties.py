"""Property tests (hypothesis): bad arrays and settings raise TypeError or ValueError, never crash."""

import itertools

import numpy as np
from hypothesis import example, given, settings, strategies as st
from hypothesis.extra import numpy as hnp

import rost
from conftest import small_config

DTYPES = st.sampled_from([np.int32, np.int64, np.uint32, np.int16, np.uint8, np.float32, np.float64, np.bool_,
                          np.dtype(">i4"), np.complex64])
SHAPES = hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=6)
ARRAYS = DTYPES.flatmap(lambda d: hnp.arrays(d, SHAPES, elements=None if d != np.int32 else
                                             st.integers(-2**31, 2**31 - 1)))
ANYTHING = st.one_of(st.none(), ARRAYS, st.integers(), st.text(max_size=3), st.lists(st.integers(), max_size=4))

MODEL = rost.Model(small_config(ring_steps=8))
STAMPS = itertools.count()
ENGINE = rost.Engine(small_config(queue_slots=4))
TOPICS = rost.Model(small_config())


def accepted(words, positions):
    """What the library must accept: int32 words in [0, V), int32 (N, 2) positions inside the frame."""
    if not (isinstance(words, np.ndarray) and words.dtype == np.int32 and words.ndim == 1
            and words.flags.c_contiguous):
        return False
    if words.size and (words.min() < 0 or words.max() >= 40):
        return False
    if positions is None:
        return True
    return (isinstance(positions, np.ndarray) and positions.dtype == np.int32 and positions.ndim == 2
            and positions.flags.c_contiguous and positions.shape == (len(words), 2)
            and (positions.size == 0 or (positions.min() >= 0 and positions.max() < 128)))


@settings(max_examples=200, deadline=None)
@given(words=ANYTHING, positions=ANYTHING)
def test_add_observation_raises_or_adds(words, positions):
    before = MODEL.observations
    try:
        MODEL.add_observation(next(STAMPS), words, positions)  # each its own: a time stamp in the window is refused
        ok = True
    except (TypeError, ValueError):
        ok = False
    assert ok == accepted(words, positions)
    assert MODEL.observations == before + ok


@settings(max_examples=100, deadline=None)
@given(words=ANYTHING, positions=ANYTHING)
def test_push_raises_or_queues(words, positions):
    try:
        ENGINE.push(1, words, positions)
        ok = True
    except (TypeError, ValueError):
        ok = False
    assert ok == accepted(words, positions)


@settings(max_examples=200, deadline=None)
@given(name=st.sampled_from([d["name"] for d in rost.Config.describe()] + ["nope", ""]),
       value=st.one_of(st.integers(), st.floats(), st.booleans(), st.text(max_size=6), st.none(),
                       st.lists(st.integers(), max_size=2)))
@example(name="cell_space", value=1)  # valid alone; the ring it gives is too large for memory
def test_config_raises_value_error_or_accepts(name, value):
    try:
        cfg = rost.Config(**{name: value})
    except ValueError as e:
        assert name in str(e)
        return
    assert rost.Config(**cfg.to_dict()) == cfg


@settings(max_examples=100, deadline=None)
@given(counts=ARRAYS)
def test_set_topic_model_raises_or_adds(counts):
    before = TOPICS.topic_model().astype(np.int64)
    try:
        TOPICS.set_topic_model(counts)
    except (TypeError, ValueError):
        assert (TOPICS.topic_model() == before).all()
        return
    assert counts.shape == (4, 40)
    assert (TOPICS.topic_model() == before + counts).all()
