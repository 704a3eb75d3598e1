"""The hostile-input battery: one table of bad inputs, each sent through
every face that can take it -- the rost tool (`rost run`, `rost refine`),
rost-cli's commands (`topics.refine.t`) and Python (`import rost`; word
streams through `rost.Mission`, as `rost refine` reads them) -- and
refused the same way by each: a message naming what and where, exit 2 (an
exception in Python, a logged skip for a frame in a stream), no crash, no
partial file, nothing already written lost.

rost_node's cases (two budgets, an unknown parameter, a bad value, an image
too small as the first frame) need a ROS master: tests/ros/test_node.py runs
them. The tool's and rost-cli's binaries come from ROST_TOOL and ROST_CLI_DIR
(ctest sets both); a face whose binary is not built is skipped.
"""

import os
import pathlib
import subprocess

import numpy as np
import pytest

import rost
import rost.io
import rost.vision

TOOL = os.environ.get("ROST_TOOL")
CLI_DIR = os.environ.get("ROST_CLI_DIR")


def cv2_or_skip():
    return pytest.importorskip("cv2")


def run(cmd, cwd):
    p = subprocess.run(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL,
                       timeout=120)
    return p.returncode, p.stderr.decode(errors="replace")


def tool(tmp, *args):
    if not TOOL:
        pytest.skip("the rost tool is not built")
    return run([TOOL] + [str(a) for a in args], tmp)


def refine_t(tmp, *args):
    if not CLI_DIR:
        pytest.skip("rost-cli's commands are not built")
    return run([os.path.join(CLI_DIR, "topics.refine.t")] + [str(a) for a in args], tmp)


def files_under(path):
    path = pathlib.Path(path)
    return sorted(str(p.relative_to(path)) for p in path.rglob("*")) if path.exists() else []


def refused(code, err, *needles, out=None):
    """Exit 2, one line naming what and where, and nothing left in `out`."""
    assert code == 2, "exit %d: %s" % (code, err)
    assert all(n in err for n in needles), "%r not all in: %s" % (needles, err)
    assert len(err.strip().splitlines()) == 1, "one line: " + err
    assert "terminate called" not in err and "Assertion" not in err
    if out is not None:
        assert files_under(out) == [], "left behind: %s" % files_under(out)


# ---- frames ----------------------------------------------------------------------------

FIRST_FRAMES = [(1, 1), (300, 1), (1, 300), (2, 2)]  # width x height


def image_dir(tmp, first, name="in"):
    """A first image of `first` (w, h) pixels, then three 96x64 ones."""
    cv2 = cv2_or_skip()
    d = tmp / name
    d.mkdir()
    rng = np.random.default_rng(1)
    w, h = first
    cv2.imwrite(str(d / "a0.png"), rng.integers(0, 255, (h, w, 3), dtype=np.uint8))
    for i in range(1, 4):
        cv2.imwrite(str(d / ("a%d.png" % i)), rng.integers(0, 255, (64, 96, 3), dtype=np.uint8))
    return d


@pytest.mark.parametrize("first", FIRST_FRAMES, ids=lambda s: "%dx%d" % s)
def test_first_frame_too_small_tool_skips_it_naming_it(tmp_path, first):
    d = image_dir(tmp_path, first)
    code, err = tool(tmp_path, "run", d, "--out", tmp_path / "o", "-q", "--no-overlay", "--no-summary")
    assert code == 0, err
    assert "%s: a %dx%d frame is too small to extract words from" % (d / "a0.png", first[0], first[1]) in err
    assert "96x64" in (tmp_path / "o/run.txt").read_text(), "the model is sized by the first usable image"
    assert len((tmp_path / "o/frames.csv").read_text().splitlines()) == 1 + 3


@pytest.mark.parametrize("first", FIRST_FRAMES + [(0, 0)], ids=lambda s: "%dx%d" % s)
def test_first_frame_too_small_python_raises_naming_it(first):
    w, h = first
    with pytest.raises(ValueError) as e:
        rost.vision.WordExtractor()(np.zeros((h, w, 3), np.uint8))
    assert "%dx%d" % (w, h) in str(e.value) or "empty" in str(e.value)


def test_empty_image_file_tool_names_it(tmp_path):
    d = image_dir(tmp_path, (40, 40))
    (d / "a0.png").write_bytes(b"")
    code, err = tool(tmp_path, "run", d, "--out", tmp_path / "o")
    refused(code, err, str(d / "a0.png"), "cannot decode image", out=tmp_path / "o")


def test_only_frames_too_small_tool_exits_2(tmp_path):
    cv2 = cv2_or_skip()
    d = tmp_path / "small"
    d.mkdir()
    for i in range(3):
        cv2.imwrite(str(d / ("a%d.png" % i)), np.zeros((2, 2, 3), np.uint8))
    code, err = tool(tmp_path, "run", d, "--out", tmp_path / "o")
    refused(code, err, str(d), "no image large enough to extract words from", out=tmp_path / "o")


def test_huge_first_frame_is_scaled_with_a_note(tmp_path):
    cv2 = cv2_or_skip()
    d = tmp_path / "big"
    d.mkdir()
    cv2.imwrite(str(d / "a.png"), np.random.default_rng(2).integers(0, 255, (6000, 8000, 3), dtype=np.uint8))
    code, err = tool(tmp_path, "run", d, "--out", tmp_path / "o", "-q", "--no-overlay", "--no-summary")
    assert code == 0, err
    assert "frames of 8000x6000 are scaled to 1920x1440" in err
    assert "1920x1440" in (tmp_path / "o/run.txt").read_text()


@pytest.mark.parametrize("kind", ["grey16", "bgra", "grey"])
def test_odd_encodings_are_read(tmp_path, kind):
    cv2 = cv2_or_skip()
    d = tmp_path / "in"
    d.mkdir()
    rng = np.random.default_rng(3)
    for i in range(3):
        if kind == "grey16":
            img = rng.integers(0, 65535, (64, 96), dtype=np.uint16)
        elif kind == "bgra":
            img = rng.integers(0, 255, (64, 96, 4), dtype=np.uint8)
        else:
            img = rng.integers(0, 255, (64, 96), dtype=np.uint8)
        cv2.imwrite(str(d / ("a%d.png" % i)), img)
    code, err = tool(tmp_path, "run", d, "--out", tmp_path / "o", "-q", "--no-overlay", "--no-summary")
    assert code == 0, err


@pytest.mark.parametrize("frame, error", [
    (np.zeros((64, 96, 3), np.uint16), TypeError),
    (np.zeros((64, 96, 3), np.float32), TypeError),
    (np.zeros((64, 96, 2), np.uint8), ValueError),
    (np.zeros((64,), np.uint8), ValueError),
])
def test_odd_encodings_python_raises(frame, error):
    with pytest.raises(error) as e:
        rost.vision.WordExtractor()(frame)
    assert str(e.value).startswith("frame: ")


# ---- word streams ------------------------------------------------------------------------

STREAMS = {
    "empty": ("", "no observations", "no documents"),
    "blank lines": ("\n\n\n", "no observations", "no documents"),
    "spaces": ("0 1 2 3\n1 4 5 6\n", "expected an integer, found '0 1 2 3'", "no ',' between the fields, but spaces"),
    "tabs": ("0\t1\t2\n", "expected an integer", "no ',' between the fields, but tabs"),
    "no words": ("0,\n1,\n", "no words in its 2 observations", "no words in its 2 documents"),
}


@pytest.mark.parametrize("case", STREAMS)
def test_bad_word_stream_tool_refine(tmp_path, case):
    (tmp_path / "docs.csv").write_text(STREAMS[case][0])
    code, err = tool(tmp_path, "refine", "docs.csv", "--out", tmp_path / "o")
    refused(code, err, "docs.csv", STREAMS[case][1], out=tmp_path / "o")


@pytest.mark.parametrize("case", STREAMS)
def test_bad_word_stream_rostcli(tmp_path, case):
    (tmp_path / "docs.csv").write_text(STREAMS[case][0])
    code, err = refine_t(tmp_path, "-i", "docs.csv", "-n", "2")
    refused(code, err, "docs.csv", STREAMS[case][2])
    if case in ("spaces", "tabs"):
        assert "docs.csv:1:" in err and "--in.words.delim" in err
    assert sorted(os.listdir(tmp_path)) == ["docs.csv"], "no output written"


@pytest.mark.parametrize("case", STREAMS)
def test_bad_word_stream_python_mission(tmp_path, case):
    """rost.Mission reads streams through the session rost refine uses: the same message."""
    (tmp_path / "docs.csv").write_text(STREAMS[case][0])
    with pytest.raises(ValueError) as e:
        rost.Mission(tmp_path / "docs.csv")
    assert "docs.csv" in str(e.value) and STREAMS[case][1] in str(e.value), str(e.value)


def test_a_directory_as_input_is_named(tmp_path):
    (tmp_path / "d").mkdir()
    code, err = tool(tmp_path, "refine", tmp_path / "d", "--out", tmp_path / "o")
    refused(code, err, str(tmp_path / "d") + ": is a directory, not a file", out=tmp_path / "o")
    code, err = refine_t(tmp_path, "-i", "d")
    refused(code, err, "d: is a directory, not a file")
    with pytest.raises(IsADirectoryError, match=r"d: is a directory, not a file"):  # as open() raises it
        rost.Mission(tmp_path / "d")


# ---- outputs -----------------------------------------------------------------------------

def planted(tmp_path, n=60):
    rng = np.random.default_rng(4)
    lines = ["%d,%s" % (i, ",".join(str(w) for w in rng.integers((i // 20) * 10, (i // 20) * 10 + 10, 30)))
             for i in range(n)]
    (tmp_path / "docs.csv").write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("flag", ["--out.topics", "--out.topicmodel", "--logfile", "--ppx.out"])
def test_unwritable_output_rostcli_fails_before_the_sweeps(tmp_path, flag):
    planted(tmp_path)
    (tmp_path / "taken").mkdir()
    for target, why in (("/proc/x/t.csv", "cannot write in /proc/x"),
                        ("taken", "taken: is a directory, not a file that can be written")):
        code, err = refine_t(tmp_path, "-i", "docs.csv", "-n", "1000000", "%s=%s" % (flag, target))
        refused(code, err, why)  # 10^6 sweeps would take minutes: the probe comes first
        assert sorted(os.listdir(tmp_path)) == ["docs.csv", "taken"], "nothing written"


def test_unwritable_output_tool_fails_before_the_work(tmp_path):
    planted(tmp_path)
    (tmp_path / "taken").mkdir()
    code, err = tool(tmp_path, "refine", "docs.csv", "--out", tmp_path / "o", "--checkpoint", "taken",
                     "--final.sweeps", "1000000")
    refused(code, err, "--checkpoint: taken: is a directory", out=tmp_path / "o")
    code, err = tool(tmp_path, "refine", "docs.csv", "--out", "/proc/x/o")
    refused(code, err, "/proc/x/o")
    (tmp_path / "o2/topics.csv").mkdir(parents=True)  # an output file's name taken by a directory
    code, err = tool(tmp_path, "refine", "docs.csv", "--out", "o2", "--final.sweeps", "1000000")
    refused(code, err, "o2/topics.csv: is a directory, not a file that can be written")
    assert files_under(tmp_path / "o2") == ["topics.csv"], "nothing written beside it"
    (tmp_path / "afile").write_text("kept")
    code, err = tool(tmp_path, "refine", "docs.csv", "--out", "afile")
    refused(code, err, "afile: exists and is not a directory")
    assert (tmp_path / "afile").read_text() == "kept", "nothing already written is lost"


def test_unwritable_vocabulary_fails_before_the_training(tmp_path):
    d = image_dir(tmp_path, (96, 64))
    (tmp_path / "taken").mkdir()
    for target, why in (("/proc/x/v.rostvoc", "--out: /proc/x/v.rostvoc: cannot write in /proc/x"),
                        ("taken", "--out: taken: is a directory, not a file that can be written")):
        code, err = tool(tmp_path, "vocab", d, "--out", target, "--words", "100", "-q")
        refused(code, err, why)  # before any frame is read
    assert sorted(os.listdir(tmp_path)) == ["in", "taken"]


def test_a_file_name_with_control_characters_is_escaped_in_the_message_on_every_face(tmp_path):
    """A newline, an escape or a C1 control in a path is written as the tool prints it
    (\\x0a, \\x1b, \\u009b): one line, that cannot drive a terminal when printed."""
    nope = str(tmp_path / "no\npe\x1b7\x9b")
    shown = str(tmp_path / "no\\x0ape\\x1b7\\u009b")
    gone = shown + ": cannot open: No such file or directory"
    cases = [
        (lambda: rost.Mission(nope), "rost.Mission: " + gone),
        (lambda: rost.Model.load(nope), "rost.Model.load: " + gone),
        (lambda: rost.io.read_words(nope), gone),
        (lambda: rost.vision.Vocabulary.load(nope), "vocabulary " + gone),
        (lambda: rost.merge_topic_models([nope]), gone),
        (lambda: rost.vision.Mission(nope + ".mov"), "rost.vision.Mission: " + shown + ".mov: cannot open: No such file or directory"),
    ]
    for make, message in cases:
        with pytest.raises(FileNotFoundError) as e:
            make()
        assert str(e.value) == message


def test_a_missing_input_file_is_file_not_found_error_on_every_face(tmp_path):
    """The one Python exception for a missing input, whichever face reads it: the library
    says what is missing where it opens the file (StatusKind), in the message the tool prints."""
    words = tmp_path / "w.csv"
    words.write_text("0,1,2\n1,3\n")
    (tmp_path / "frames").mkdir()
    cv2_or_skip().imwrite(str(tmp_path / "frames" / "a.png"), np.zeros((64, 64, 3), np.uint8))
    nope = str(tmp_path / "nope")
    gone = nope + ": cannot open: No such file or directory"
    cases = [
        (lambda: rost.Mission(nope), "rost.Mission: " + gone),
        (lambda: rost.Mission(words, positions=nope), "rost.Mission: positions: " + gone),
        (lambda: rost.Mission(words, resume=nope), "rost.Mission: resume: " + gone),
        (lambda: rost.Mission(words, topicmodel=nope), "rost.Mission: topicmodel: " + gone),
        (lambda: rost.vision.Mission(nope + ".mov"),
         "rost.vision.Mission: " + nope + ".mov: cannot open: No such file or directory"),
        (lambda: rost.vision.Mission(tmp_path / "frames", vocabulary=nope),
         "rost.vision.Mission: vocabulary " + gone),
        (lambda: rost.Model.load(nope), "rost.Model.load: " + gone),
        (lambda: rost.io.read_words(nope), gone),
        (lambda: rost.vision.Vocabulary.load(nope), "vocabulary " + gone),
        (lambda: rost.merge_topic_models([nope]), gone),
    ]
    for make, message in cases:
        with pytest.raises(FileNotFoundError) as e:
            make()
        assert str(e.value) == message
    # Not missing: a directory where a file belongs is IsADirectoryError, a bad file ValueError.
    with pytest.raises(IsADirectoryError, match=r"rost\.Mission: resume: .* is a directory, not a checkpoint file"):
        rost.Mission(words, resume=tmp_path)
    with pytest.raises(ValueError, match=r"rost\.Mission: resume: .*w\.csv"):
        rost.Mission(words, resume=words)
    # A file where a directory belongs is NotADirectoryError, another refusal of the system OSError.
    through = str(words) + "/x"
    for make in (lambda: rost.Mission(through), lambda: rost.Model.load(through), lambda: rost.io.read_words(through),
                 lambda: rost.vision.Vocabulary.load(through), lambda: rost.vision.Mission(through)):
        with pytest.raises(NotADirectoryError, match="Not a directory"):
            make()
    os.symlink(tmp_path / "loop", tmp_path / "loop")
    for make in (lambda: rost.Mission(tmp_path / "loop"), lambda: rost.merge_topic_models([tmp_path / "loop"]),
                 lambda: rost.vision.Vocabulary.load(tmp_path / "loop"), lambda: rost.vision.Mission(tmp_path / "loop")):
        with pytest.raises(OSError, match="Too many levels of symbolic links") as e:
            make()
        assert type(e.value) is OSError
    # A vocabulary nothing would use is named, not ignored.
    with pytest.raises(ValueError, match=r"vocabulary .*nope: given, but words\.orb is false"):
        rost.vision.Mission(tmp_path / "frames", vocabulary=nope, words_orb=False)
    with pytest.raises(ValueError, match=r"rost\.vision\.WordExtractor: vocabulary: given, but words\.orb is false"):
        rost.vision.WordExtractor(rost.vision.Vocabulary.default(), words_orb=False)
    with pytest.raises(ValueError, match=r"rost\.vision\.WordExtractor: vocabulary: given, but words\.orb is false"):
        rost.vision.WordExtractor(nope, words_orb=False)  # named before the path is read
    # An empty path (a script's unset variable) is refused, as the tool refuses `--resume ''`, not read as "none".
    for make, what in ((lambda: rost.Mission(words, resume=""), "rost.Mission: resume"),
                       (lambda: rost.Mission(words, topicmodel=""), "rost.Mission: topicmodel"),
                       (lambda: rost.Mission(words, positions=""), "rost.Mission: positions"),
                       (lambda: rost.vision.Mission(tmp_path / "frames", vocabulary=""), "rost.vision.Mission: vocabulary"),
                       (lambda: rost.Model.load(""), "rost.Model.load: path")):
        with pytest.raises(ValueError) as e:
            make()
        assert str(e.value) == what + ": no file given (an empty path)"


def test_a_save_into_a_missing_directory_is_file_not_found_error_on_every_face(tmp_path):
    words = tmp_path / "w.csv"
    words.write_text("0,1,2\n1,3\n")
    to = tmp_path / "nodir" / "x"
    mission = rost.Mission(words)
    model = rost.Model(rost.Config(V=4))
    vocabulary = rost.vision.Vocabulary.default()
    for save, prefix in ((mission.save, "rost.Mission.save: "), (model.save, "rost.Model.save: "), (vocabulary.save, "vocabulary "),
                         (lambda p: rost.io.write_words(p, [0], [np.array([1], np.int32)]), "")):
        with pytest.raises(FileNotFoundError) as e:
            save(to)
        assert str(e.value).startswith(prefix + str(to) + ": cannot "), str(e.value)
    assert not (tmp_path / "nodir").exists()


def test_a_checkpoint_save_is_refused_or_fails_as_the_tool_says_it_on_every_face(tmp_path):
    """Model.save and Mission.save: '-' (standard output to the command lines) and a directory are
    refused by name before anything is written; a write the system refuses part-way (a file size
    limit, as a full disk) is OSError, as rost.io's writers raise it, and leaves no file."""
    words = tmp_path / "w.csv"
    words.write_text("0,1,2\n1,3\n")
    mission = rost.Mission(words)
    model = rost.Model(rost.Config(V=4))
    here = os.getcwd()
    try:
        os.chdir(tmp_path)
        for save, name in ((mission.save, "rost.Mission.save"), (model.save, "rost.Model.save")):
            with pytest.raises(RuntimeError) as e:
                save("-")
            assert str(e.value) == name + ": '-' names no file: this output is written to a named file, not to " \
                                          "standard output (./- for a file of that name)"
            with pytest.raises(IsADirectoryError) as e:
                save(tmp_path)
            assert str(e.value) == name + ": " + str(tmp_path) + ": is a directory, not a file that can be written"
        assert sorted(os.listdir(tmp_path)) == ["w.csv"], "nothing written"
    finally:
        os.chdir(here)
    import sys
    script = (
        "import resource, signal, sys, rost\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (256, 256))\n"
        "for save in (rost.Mission(sys.argv[1]).save, rost.Model(rost.Config(V=4)).save):\n"
        "    try:\n"
        "        save(sys.argv[2])\n"
        "    except OSError as e:\n"
        "        print(type(e).__name__, e)\n")
    r = subprocess.run([sys.executable, "-c", script, str(words), str(tmp_path / "m.ckpt")], capture_output=True,
                       text=True, timeout=120, env=os.environ)
    lines = r.stdout.strip().splitlines()
    assert len(lines) == 2, r.stdout + r.stderr
    for line in lines:
        assert line.startswith("OSError ") and "m.ckpt: write failed: File too large" in line, line
    assert sorted(os.listdir(tmp_path)) == ["w.csv"], "no checkpoint, no temporary file left"


BOM = b"\xef\xbb\xbf"  # the UTF-8 byte order mark Windows editors and spreadsheets write first


def test_a_byte_order_mark_before_the_first_line_is_read_past_by_every_face(tmp_path):
    """A words, positions, topic model or settings file that starts with a UTF-8 byte order mark
    reads as the same file without it on every face (rost-cli's took it into the first timestamp,
    the others refused it); one in the middle of a file (`cat` of two such files) stays an error
    naming its line where timestamps are numbers."""
    (tmp_path / "w.csv").write_bytes(BOM + b"0,1,2\n1,3,4\n")
    (tmp_path / "p.csv").write_bytes(BOM + b"0,1,1,2,2\n1,3,3,4,4\n")
    (tmp_path / "plain.csv").write_bytes(b"0,1,2\n1,3,4\n")
    (tmp_path / "tm.csv").write_bytes(BOM + b"1,0,0,0,1\n0,1,1,1,0\n")
    (tmp_path / "k.conf").write_bytes(BOM + b"K = 2\n")
    stamps, words = rost.io.read_words(tmp_path / "w.csv")
    assert list(stamps) == [0, 1] and [list(w) for w in words] == [[1, 2], [3, 4]]
    m = rost.Mission(tmp_path / "w.csv", positions=tmp_path / "p.csv", topicmodel=tmp_path / "tm.csv")
    assert m.config.V == 5, "V from the topic model's columns"
    code, err = tool(tmp_path, "refine", "w.csv", "--positions", "p.csv", "--config", "k.conf", "--in.topicmodel",
                     "tm.csv", "--out", "o", "-q", "--no-summary")
    assert code == 0, err
    assert [l.split(",")[0] for l in (tmp_path / "o" / "topics.csv").read_text().splitlines()] == ["0", "1"]
    code, err = refine_t(tmp_path, "-i", "w.csv", "-K", "2", "-n", "1", "--in.topicmodel", "tm.csv")
    assert code == 0, err
    assert (tmp_path / "topics.csv").read_bytes().startswith(b"0,"), "the first timestamp is 0, not BOM + 0"
    p = subprocess.run([os.path.join(CLI_DIR, "topics.refine.t"), "-V", "5", "-K", "2", "--online", "--online.mint",
                        "1"], cwd=tmp_path, input=BOM + b"0,1,2\n1,3\n", capture_output=True, timeout=120)
    assert p.returncode == 0, p.stderr.decode()
    assert (tmp_path / "topics.online.csv").read_bytes().startswith(b"0,")
    p = subprocess.run([os.path.join(CLI_DIR, "words.bincount"), "-V", "5"], input=BOM + b"0,1,1\n", capture_output=True,
                       timeout=120)
    assert p.stdout == b"0,0,2,0,0,0\n", p.stdout + p.stderr
    # In the middle: an error naming its line on every face (rost-cli's timestamps are text, copied
    # as written: a mark there is refused by name rather than copied into the timestamp).
    (tmp_path / "mid.csv").write_bytes(b"0,1,2\n" + BOM + b"1,3,4\n")
    needle = "mid.csv:2:1: expected "
    refused(*tool(tmp_path, "refine", "mid.csv", "--out", "om"), needle, out=tmp_path / "om")
    with pytest.raises(ValueError, match=needle):
        rost.Mission(tmp_path / "mid.csv")
    said = "mid.csv:2:1: a byte-order mark before the timestamp '1' (two files joined?)\n"
    code, err = refine_t(tmp_path, "-i", "mid.csv", "-V", "5", "-K", "2", "-n", "1", "--out.topics", "mid_topics.csv")
    assert (code, err) == (2, "topics.refine.t: " + said)
    assert not (tmp_path / "mid_topics.csv").exists()
    p = subprocess.run([os.path.join(CLI_DIR, "topics.refine.t"), "-V", "5", "-K", "2", "--online", "--online.mint", "1",
                        "--out.topics.online", "mid_online.csv"], cwd=tmp_path, input=b"0,1,2\n" + BOM + b"1,3\n",
                       capture_output=True, timeout=120)
    assert p.returncode == 2 and p.stderr.decode() == "topics.refine.t: <stdin>:2:1: " + said.split(": ", 1)[1], p.stderr
    p = subprocess.run([os.path.join(CLI_DIR, "words.bincount"), "-V", "5", "-i", "mid.csv"], cwd=tmp_path,
                       capture_output=True, timeout=120)
    assert p.returncode == 2 and p.stderr.decode() == "words.bincount: " + said, p.stderr


def test_an_error_quoting_bytes_of_no_character_is_still_a_message(tmp_path):
    words = tmp_path / "w.csv"
    words.write_bytes(b"0,1,2\n1,3,\xff4\n")
    with pytest.raises(ValueError) as e:
        rost.Mission(words)
    assert str(e.value).endswith("w.csv:2:5: expected an integer, found '\\xff4'"), repr(str(e.value))


def test_a_repeated_time_stamp_in_the_window_is_refused_and_changes_nothing():
    m = rost.Model(rost.Config(K=4, V=10, frame_width=1, frame_height=1, ring_steps=4))
    m.add_observation(0, np.array([1, 2, 3], np.int32))
    m.add_observation(1, np.array([4, 5], np.int32))
    with pytest.raises(ValueError, match=r"time stamp 0 is already an observation's in the window"):
        m.add_observation(0, np.array([6], np.int32))
    assert m.observations == 2 and list(m.timestamps()) == [0, 1]
    assert len(m.topics(0)) == 3, "the first observation at 0 is still the one topics(0) finds"
    for t in range(2, 8):  # 0 leaves the 4-step window: its time stamp may come again
        m.add_observation(t, np.array([7], np.int32))
    m.add_observation(0, np.array([8, 9], np.int32))
    assert len(m.topics(0)) == 2


def test_unwritable_output_python_raises(tmp_path):
    m = rost.Model(rost.Config(V=10, frame_width=64, frame_height=64))
    m.add_observation(0, np.arange(10, dtype=np.int32), np.zeros((10, 2), np.int32))
    with pytest.raises(FileNotFoundError) as e:  # as open() raises it, on every face's save
        m.save(str(tmp_path / "no/such/dir/m.ckpt"))
    # Probed before the state is copied, as rost.Mission.save's and the tool's --checkpoint.
    assert str(e.value) == ("rost.Model.save: " + str(tmp_path / "no/such/dir/m.ckpt") + ": cannot write in " +
                            str(tmp_path / "no/such/dir") + ": No such file or directory")


# ---- settings ----------------------------------------------------------------------------

def test_two_budgets_are_refused_by_every_face(tmp_path):
    planted(tmp_path)
    code, err = tool(tmp_path, "refine", "docs.csv", "--out", tmp_path / "o", "--budget.refines", "3",
                     "--budget.ms", "10")
    refused(code, err, "--budget.refines", "--budget.ms", out=tmp_path / "o")
    with pytest.raises(ValueError, match="budget_refines.*budget_ms|budget_ms.*budget_refines"):
        rost.Config(budget_refines=4, budget_ms=5.0)


def test_unknown_setting_is_an_error_on_the_command_line_and_in_python(tmp_path):
    planted(tmp_path)
    code, err = tool(tmp_path, "refine", "docs.csv", "--out", tmp_path / "o", "--etta", "0.5")
    refused(code, err, "--etta", out=tmp_path / "o")
    code, err = refine_t(tmp_path, "-i", "docs.csv", "--etta", "0.5")
    refused(code, err, "--etta")
    with pytest.raises(ValueError, match=r"unknown setting 'etta' \(did you mean 'eta'\?\)"):
        rost.Config(etta=0.5)


@pytest.mark.parametrize("value", ["2", "-0.5"])
def test_a_value_out_of_range_is_named_in_each_faces_spelling(tmp_path, value):
    code, err = tool(tmp_path, "config", "--eta", value)
    refused(code, err, "--eta = %s, allowed [0, 1]" % value)
    with pytest.raises(ValueError) as e:
        rost.Config(eta=float(value))
    assert "eta = %s, allowed [0, 1]" % value in str(e.value) and "strategy" not in str(e.value)


# ---- checkpoints -------------------------------------------------------------------------

@pytest.fixture
def checkpoint(tmp_path):
    planted(tmp_path)
    code, err = tool(tmp_path, "refine", "docs.csv", "--out", tmp_path / "first", "-K", "4", "--checkpoint", "m.ckpt",
                     "-q")
    assert code == 0, err
    return tmp_path / "m.ckpt"


def test_a_checkpoint_of_another_K_or_V(tmp_path, checkpoint):
    for option, value in (("-K", "8"), ("-V", "99")):
        code, err = tool(tmp_path, "refine", "docs.csv", "--out", tmp_path / "o", "--resume", checkpoint, option, value)
        refused(code, err, option, "differs from %s" % checkpoint, out=tmp_path / "o")
        with pytest.raises(ValueError) as e:
            rost.Mission(tmp_path / "docs.csv", resume=checkpoint, **{option[1]: int(value)})
        assert "%s=%s differs from %s" % (option[1], value, checkpoint) in str(e.value), str(e.value)


def test_a_truncated_checkpoint_is_named(tmp_path, checkpoint):
    data = checkpoint.read_bytes()
    short = tmp_path / "short.ckpt"
    short.write_bytes(data[:len(data) // 2])
    code, err = tool(tmp_path, "refine", "docs.csv", "--out", tmp_path / "o", "--resume", short)
    refused(code, err, "--resume", str(short), out=tmp_path / "o")
    with pytest.raises(ValueError) as e:
        rost.Model.load(str(short))
    assert str(short) in str(e.value)
    with pytest.raises(ValueError) as e:
        rost.Mission(tmp_path / "docs.csv", resume=short)
    assert "resume: " in str(e.value) and str(short) in str(e.value), str(e.value)
    assert checkpoint.read_bytes() == data, "the checkpoint the run started from is untouched"


def test_a_run_resumed_on_frames_of_another_size_says_so_first(tmp_path):
    cv2 = cv2_or_skip()
    a = image_dir(tmp_path, (96, 64), "a")
    code, err = tool(tmp_path, "run", a, "--out", tmp_path / "first", "--checkpoint", "a.ckpt", "-q", "--no-overlay",
                     "--no-summary")
    assert code == 0, err
    b = tmp_path / "b"
    b.mkdir()
    for i in range(2):  # fewer frames than the checkpoint holds, and of another size: the size is the error
        cv2.imwrite(str(b / ("b%d.png" % i)), np.zeros((48, 64, 3), np.uint8))
    code, err = tool(tmp_path, "run", b, "--out", tmp_path / "o", "--resume", "a.ckpt")
    refused(code, err, "--resume a.ckpt: the frames are 64 pixels wide but a.ckpt models 96x64 frames",
            out=tmp_path / "o")


def test_a_value_a_config_file_set_is_named_by_its_line(tmp_path):
    (tmp_path / "docs.csv").write_text("0,1,2\n1,2,3\n")
    (tmp_path / "k.conf").write_text("# mission\ng.time = 5\n")
    code, err = tool(tmp_path, "refine", "docs.csv", "--out", tmp_path / "o", "--config", "k.conf")
    refused(code, err, "k.conf:2: key 'g.time': g.time = 5, allowed [0, 2]; below ring.steps = 3", out=tmp_path / "o")


# Settings whose tables do not fit in memory: MemoryError naming the settings
# they grow with, from rost.Model and rost.Engine alike, as the tool says it
# (not "std::bad_alloc"). Run in a child under a 2 GiB address-space limit;
# skipped where such a limit is not enforced.
_OUT_OF_MEMORY = """
import mmap, resource, sys
resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
try:
    mmap.mmap(-1, 2 << 30)
    print("unenforced")
    sys.exit(0)
except (OSError, MemoryError, ValueError):
    pass
import rost
for make in (rost.Model, rost.Engine):
    try:
        make(rost.Config(V=10_000_000, K=1000, frame_width=64, frame_height=64))
        print(make.__name__, "made")
    except MemoryError as e:
        print(make.__name__, "MemoryError", e)
"""


def test_settings_too_large_for_memory_raise_memory_error_naming_them():
    import sys
    p = subprocess.run([sys.executable, "-c", _OUT_OF_MEMORY], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       timeout=120, env=os.environ)
    out = p.stdout.decode()
    if "unenforced" in out:
        pytest.skip("an address-space limit is not enforced here")
    assert p.returncode == 0, p.stderr.decode()
    lines = out.strip().splitlines()
    assert len(lines) == 2, out
    for line, name in zip(lines, ("Model", "Engine")):
        assert line.startswith(name + " MemoryError"), line
        assert "K = 1000" in line and "V = 10000000" in line, line
        assert "bad_alloc" not in line, line


# Inputs too large for memory: MemoryError naming what ran out, as the tool
# says it (not an abort, not OpenCV's multi-line report): a word stream that
# never ends (/dev/zero, read whole), frames resized beyond the memory there is.
_INPUT_OUT_OF_MEMORY = """
import mmap, resource, sys
resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))
try:
    mmap.mmap(-1, 1 << 30)
    print("unenforced")
    sys.exit(0)
except (OSError, MemoryError, ValueError):
    pass
import rost, rost.vision
for make in (lambda: rost.Mission("/dev/zero"),
             lambda: rost.vision.Mission(sys.argv[1], width=30000, height=30000, cell_space=4096, max_words=500,
                                               threads=1).run()):
    try:
        make()
        print("made")
    except MemoryError as e:
        print("MemoryError", e)
"""


def test_inputs_too_large_for_memory_raise_memory_error_naming_them(tmp_path):
    import sys
    frames = image_dir(tmp_path, (32, 32))
    p = subprocess.run([sys.executable, "-c", _INPUT_OUT_OF_MEMORY, str(frames)], stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, timeout=120, env=os.environ)
    out = p.stdout.decode()
    if "unenforced" in out:
        pytest.skip("an address-space limit is not enforced here")
    assert p.returncode == 0, p.stderr.decode()
    lines = out.strip().splitlines()
    assert len(lines) == 2, out
    assert lines[0].startswith("MemoryError rost.Mission: /dev/zero: out of memory reading it whole, after "), lines[0]
    assert lines[1].startswith("MemoryError out of memory: OpenCV: Failed to allocate "), lines[1]
