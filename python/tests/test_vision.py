"""rost.vision: words of cv2 frames, vocabularies; on real footage (diver.mov)."""

import filecmp
import os
import shutil
import subprocess

import numpy as np
import pytest

import rost
import rost.vision
from conftest import footage_or_skip, read_frames


@pytest.fixture(scope="module")
def diver_frames():
    return read_frames(footage_or_skip(), 6)


def test_words_of_a_frame(diver_frames):
    ex = rost.vision.WordExtractor()
    frame = diver_frames[0]
    words, positions = ex(frame)
    assert words.dtype == np.int32 and positions.dtype == np.int32
    assert words.ndim == 1 and positions.shape == (len(words), 2)
    assert len(words) > 500
    assert words.min() >= 0 and words.max() < ex.vocabulary_size == 5436
    h, w = frame.shape[:2]
    assert (positions[:, 0] < w).all() and (positions[:, 1] < h).all() and (positions >= 0).all()
    assert ex._last_input_address == frame.ctypes.data  # the frame was not copied
    again, _ = ex(frame)
    assert (again == words).all()  # deterministic
    layout = ex.layout
    orb = words < layout["intensity"][0]
    assert orb.sum() > 100 and (~orb).sum() > 100


def test_words_match_the_rost_tool(diver_frames, tmp_path):
    tool = os.environ.get("ROST_TOOL")
    if not tool or not os.path.exists(tool):
        pytest.skip("the rost tool was not built (ROST_VISION)")
    out = tmp_path / "run"
    subprocess.run([tool, "run", str(footage_or_skip()), "--max-frames", "3", "--out", str(out)], check=True,
                   capture_output=True)
    ts, words = rost.io.read_words(out / "words.csv")
    _, positions = rost.io.read_positions(out / "positions.csv")
    ex = rost.vision.WordExtractor()
    for t, w, p in zip(ts, words, positions):
        mine_w, mine_p = ex(diver_frames[t])
        assert (mine_w == w).all() and (mine_p == p).all()


def test_settings_and_grey_and_strided_frames(diver_frames):
    frame = diver_frames[1]
    thumbs_only = rost.vision.WordExtractor(words_orb=False, thumb_cell=32)
    words, _ = thumbs_only(frame)
    assert thumbs_only.vocabulary_size == 256 + 180
    assert len(words) <= 2 * (frame.shape[0] // 32 + 1) * (frame.shape[1] // 32 + 1)
    grey = frame[:, :, 1].copy()
    w, p = rost.vision.WordExtractor(words_hue=False)(grey)
    assert len(w) > 0
    rows = frame[::2]  # every other row: rows strided, pixels packed: still viewed in place
    w, p = thumbs_only(rows)
    assert p[:, 1].max() < rows.shape[0]
    with pytest.raises(ValueError, match="not contiguous"):
        thumbs_only(frame[:, ::2])
    # Rows closer than a row's bytes (overlapping views) and rows upside down (a negative stride,
    # which a cv::Mat would take as a huge one) are refused too, not read.
    img = np.ascontiguousarray(frame[:64, :96])
    overlapping = np.lib.stride_tricks.as_strided(img, shape=(64, 96, 3), strides=(96, 3, 1))
    for bad in (overlapping, img[::-1]):
        with pytest.raises(ValueError, match="not contiguous within a row"):
            thumbs_only(bad)
    thumbs_only(np.lib.stride_tricks.as_strided(img, shape=(32, 96, 3), strides=(2 * 288, 3, 1)))  # a row's bytes apart or more: taken
    with pytest.raises(TypeError, match="uint8"):
        thumbs_only(frame.astype(np.float32))
    with pytest.raises(ValueError, match="shape"):
        thumbs_only(frame[:, :, :2].copy())
    with pytest.raises(ValueError, match="empty"):
        thumbs_only(frame[:0])
    with pytest.raises(TypeError, match="list"):
        thumbs_only([[1, 2]])
    with pytest.raises(ValueError, match="'K' is not a word setting"):
        rost.vision.WordExtractor(K=3)
    with pytest.raises(ValueError, match="orb_features"):
        rost.vision.WordExtractor(orb_features=0)


def test_vocabulary_train_save_load(diver_frames, tmp_path):
    v = rost.vision.Vocabulary.train(diver_frames, words=64, features=200, iterations=5, seed=3)
    assert len(v) == 64 and "6 frames" in v.note
    path = tmp_path / "v.rostvoc"
    v.save(str(path))
    loaded = rost.vision.Vocabulary.load(path)
    assert len(loaded) == 64
    ex = rost.vision.WordExtractor(loaded)
    assert ex.vocabulary_size == 64 + 256 + 180
    words, _ = ex(diver_frames[0])
    assert (words < 64).sum() > 50  # ORB words from the new vocabulary
    assert len(rost.vision.Vocabulary.default()) == 5000
    with pytest.raises(FileNotFoundError):
        rost.vision.Vocabulary.load(tmp_path / "none.rostvoc")
    (tmp_path / "bad.rostvoc").write_bytes(b"ROSTVOC\0" + b"\1" * 40)
    with pytest.raises(ValueError, match="bad.rostvoc"):
        rost.vision.Vocabulary.load(tmp_path / "bad.rostvoc")
    with pytest.raises(ValueError, match="10 descriptors cannot make 100000 words"):
        rost.vision.Vocabulary.train(diver_frames[:1], words=100000, features=10)


def test_a_frame_mission_refuses_to_save_over_its_vocabulary(diver_frames, tmp_path):
    diver = footage_or_skip()
    voc = tmp_path / "v.rostvoc"
    rost.vision.Vocabulary.train(diver_frames, words=64, features=200, iterations=5, seed=3).save(str(voc))
    before = voc.read_bytes()
    m = rost.vision.Mission(diver, vocabulary=voc, max_frames=2, K=8)
    with pytest.raises(RuntimeError, match=r"rost\.vision\.Mission\.save: .*v\.rostvoc is an input of this run"):
        m.save(voc)
    assert voc.read_bytes() == before


# rost::vision's frame size rule, as the tool and the node apply it: a frame
# with a side under 16 pixels is refused with ValueError naming its size.
@pytest.mark.parametrize("shape", [(1, 1, 3), (1, 300, 3), (300, 1, 3), (2, 2, 3), (15, 64), (64, 15, 3)])
def test_frames_too_small_raise_naming_the_size(shape):
    extractor = rost.vision.WordExtractor()
    with pytest.raises(ValueError) as e:
        extractor(np.zeros(shape, np.uint8))
    w, h = shape[1], shape[0]
    assert str(e.value) == ("frame: a %dx%d frame is too small to extract words from (each side at least 16 pixels)"
                            % (w, h))
    words, positions = extractor(np.full((16, 16, 3), 128, np.uint8))
    assert len(words) > 0 and positions.shape == (len(words), 2)


def test_a_frame_of_65535_pixels_a_side_is_taken_and_one_more_refused():
    extractor = rost.vision.WordExtractor()
    words, positions = extractor(np.full((16, 65535), 100, np.uint8))
    assert len(words) > 0 and positions[:, 0].max() < 65535
    with pytest.raises(ValueError, match=r"frame: \(16, 65536\) is empty or larger than 65535 pixels a side"):
        extractor(np.zeros((16, 65536), np.uint8))


def test_vocabulary_training_defaults_are_the_tools():
    # One set of defaults (the library's KMajorityOptions, which `rost vocab` uses): 40 iterations.
    doc = rost.vision.Vocabulary.train.__doc__
    for default in ("words: int = 5000", "features: int = 500", "iterations: int = 40", "seed: int = 1"):
        assert default in doc, doc


def test_a_frame_mission_gives_rost_runs_results_and_resumes(tmp_path):
    """rost.vision.Mission drives the session `rost run` drives: on the same frames, seed and settings it
    gives rost run's topics.csv and perplexity.csv; resumed from its checkpoint it skips its frames; a
    model keyword that differs from the checkpoint's is refused naming the keyword."""
    tool = os.environ.get("ROST_TOOL")
    if not tool or not os.path.exists(tool):
        pytest.skip("the rost tool was not built (ROST_VISION)")
    diver = footage_or_skip()
    out = tmp_path / "run"
    args = ["--max-frames", "12", "-K", "8", "--seed", "5", "--final.sweeps", "3", "--ring.steps", "8"]
    subprocess.run([tool, "run", str(diver), "--out", str(out), "-q", "--no-overlay", "--no-summary"] + args,
                   check=True, capture_output=True)
    m = rost.vision.Mission(diver, max_frames=12, K=8, seed=5, final_sweeps=3, ring_steps=8)
    assert m.config.V == rost.vision.WordExtractor().vocabulary_size and m.config.frame_width == 640
    r = m.run()
    ts, topics = rost.io.read_topics(out / "topics.csv")
    assert r["timestamp"].tolist() == ts.tolist() == list(range(12))
    assert all(np.array_equal(a, b) for a, b in zip(topics, r["labels"]))  # 4 frames left the window first
    ppx = rost.io.read_perplexity(out / "perplexity.csv")
    np.testing.assert_array_equal(ppx["instantaneous"], r["instantaneous"])
    np.testing.assert_array_equal(ppx["final"], r["final"])

    first = rost.vision.Mission(diver, max_frames=5, K=8, seed=5)
    first.run()
    first.save(tmp_path / "m.ckpt")
    # Its own input is refused (as rost.Mission's and the tool's --checkpoint): a copy, so a
    # failure here cannot touch the footage.
    clip = tmp_path / "clip.mov"
    shutil.copyfile(diver, clip)
    small = rost.vision.Mission(clip, max_frames=2, K=8)
    small.run()
    with pytest.raises(RuntimeError, match=r"rost\.vision\.Mission\.save: .*clip\.mov is an input of this run"):
        small.save(clip)
    assert filecmp.cmp(clip, diver, shallow=False)
    resumed = rost.vision.Mission(diver, resume=tmp_path / "m.ckpt", max_frames=8)
    assert resumed.resuming and resumed.frames == 3
    assert resumed.run()["timestamp"].tolist() == [5, 6, 7]
    with pytest.raises(ValueError, match=r"K=16 differs from .*m\.ckpt's K = 8 .*leave K out"):
        rost.vision.Mission(diver, resume=tmp_path / "m.ckpt", K=16)
    with pytest.raises(ValueError, match=r"nothing to resume with: .*m\.ckpt has every frame up to 4 \(max_frames 5"):
        rost.vision.Mission(diver, resume=tmp_path / "m.ckpt", max_frames=5)
    with pytest.raises(FileNotFoundError, match=r"rost\.vision\.Mission: .*nosuch\.mov: cannot open: No such file or directory"):
        rost.vision.Mission(tmp_path / "nosuch.mov")
    with pytest.raises(TypeError, match=r"inputs: expected a path or a list of paths, found int"):
        rost.vision.Mission(3)
    with pytest.raises(ValueError, match=r"max_frames = -3, allowed at least 0"):
        rost.vision.Mission(diver, max_frames=-3)
    with pytest.raises(ValueError, match=r"rost\.vision\.Mission: width = -3, allowed at least 0 \(0: as the input\)"):
        rost.vision.Mission(diver, width=-3)
    small = rost.vision.Mission(diver, max_frames=2, frame_width=320, frame_height=240)
    assert (small.config.frame_width, small.config.frame_height) == (320, 240), "frame_width sizes the frames"


def test_a_video_cut_short_is_refused_naming_the_keyword_that_models_its_frames(tmp_path):
    """A copy stopped half way: ValueError naming the frames decoded and max_frames (the tool's
    message names its --max-frames); with that many frames the mission plays."""
    cv2 = pytest.importorskip("cv2")
    writer = cv2.VideoWriter(str(tmp_path / "clip.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 12, (64, 48))
    if not writer.isOpened():
        pytest.skip("OpenCV cannot write MJPG here")
    rng = np.random.default_rng(1)
    for _ in range(120):
        writer.write(rng.integers(0, 255, (48, 64, 3), dtype=np.uint8))
    writer.release()
    whole = (tmp_path / "clip.avi").read_bytes()
    (tmp_path / "cut.avi").write_bytes(whole[: len(whole) // 2])
    with pytest.raises(ValueError, match=r"cut\.avi: only (\d+) of the 120 frames .*truncated or damaged "
                                         r"\(max_frames \1 models those\)$") as e:
        rost.vision.Mission(tmp_path / "cut.avi", K=4).run()
    decoded = int(str(e.value).split("only ")[1].split(" ")[0])
    assert len(rost.vision.Mission(tmp_path / "cut.avi", K=4, max_frames=decoded).run()["timestamp"]) == decoded
