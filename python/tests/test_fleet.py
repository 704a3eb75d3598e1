"""rost.fleet: a season of missions run by the rost tool, merged into one set of topics
(docs/fleet.md). The planted bar of issue 29 (three missions sharing three topics, each with one of
its own, -K 6: purity >= 0.85 with 6 or 7 global topics holding >= 2 % of the words, merged and
relabelled with the fixed global model, well above identity matching); the same bytes with and
without a Dask cluster; bad missions refused before anything runs, naming them. Needs the rost
tool (ROST_TOOL) and the module's merge_topic_models."""

import os
import pathlib
import sys

import numpy as np
import pytest

import rost
import rost.fleet
import rost.io
from conftest import SOURCE_DIR

sys.path.insert(0, str(SOURCE_DIR / "bench"))
import fleet_planted  # noqa: E402  (bench/fleet_planted.py: the planted missions and their scores)

TOOL = os.environ.get("ROST_TOOL")
needs_tool = pytest.mark.skipif(not TOOL, reason="the rost tool is not built (ROST_TOOL)")
SWEEPS = 30  # final sweeps of each planted mission (the bench's default is 50): keeps the test fast


def _tree(root):
    root = pathlib.Path(root)
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _planted_inputs(tmp_path, missions=3, seed=1):
    fleet = fleet_planted.planted_fleet(missions, shared=3, own=1, seed=seed)
    return fleet, fleet_planted.write_fleet(fleet, str(tmp_path))


@needs_tool
def test_three_planted_missions_reach_the_bar_merged_and_relabelled(tmp_path):
    r = fleet_planted.measure(3, str(tmp_path), shared=3, own=1, K=6, sweeps=SWEEPS, seed=1)
    for method in ("merged", "merged, fixed"):
        purity, ami, big, _ = r[method]
        assert purity >= 0.85, (method, r)
        assert big in (6, 7), (method, r)
        assert ami > 0.6, (method, r)
    # Identity matching (topic i of every mission is one topic) mixes the missions' numberings.
    assert r["identity"][0] < r["merged"][0] - 0.1, r


def test_the_scores_of_known_labelings():
    truth = np.repeat([0, 1, 2], 100)
    assert fleet_planted.scores(truth, truth + 5)[:2] == pytest.approx((1.0, 1.0))
    # Two planted topics under one label: purity 2/3; one topic split in two: purity stays 1.
    assert fleet_planted.scores(truth, np.minimum(truth, 1))[0] == pytest.approx(2 / 3)
    split = np.where(np.arange(300) % 2 == 0, truth, truth + 3)
    purity, ami, big = fleet_planted.scores(truth, split)
    assert purity == 1.0 and 0.5 < ami < 1.0 and big == 6
    noise = np.random.default_rng(3).integers(0, 3, 300)
    assert abs(fleet_planted.scores(truth, noise)[1]) < 0.05, "AMI is adjusted for chance"


@needs_tool
def test_outputs_lift_every_label_through_the_lifting_with_mission_names(tmp_path):
    fleet, inputs = _planted_inputs(tmp_path, missions=2)
    out = tmp_path / "out"
    r = rost.fleet.run(inputs, out, K=6, final_sweeps=5, seed=2)
    assert (out / "fleet.conf").read_text().splitlines()[1:] == ["K = 6", "final.sweeps = 5", "seed = 2"]
    rows = (out / "merged" / "lifting.csv").read_text().splitlines()
    assert rows[0] == "model,local,global"
    assert [row.split(",")[:2] for row in rows[1:]] == [[n, str(k)] for n in inputs for k in range(6)]
    lifting = {n: np.array([int(row.split(",")[2]) for row in rows[1:] if row.startswith(n + ",")]) for n in inputs}
    G = rost.io.read_topicmodel(out / "merged" / "topicmodel.csv").shape[0]
    assert any(not np.array_equal(lifting[n], np.arange(6)) for n in inputs), "a lifting that renumbers"
    assert r["global_counts"].shape[0] == G and r["topicmodel"] == str(out / "merged" / "topicmodel.csv")
    for name in inputs:
        assert rost.io.read_topicmodel(out / name / "topicmodel.csv").shape[0] == 6, "K = 6 reached the tool"
        np.testing.assert_array_equal(r["lifting"][name], lifting[name])
        ts, local = rost.io.read_topics(out / name / "topics.csv")
        ts2, lifted = rost.io.read_topics(r["topics_global"][name])
        assert ts.tolist() == ts2.tolist()
        for a, b in zip(local, lifted):
            np.testing.assert_array_equal(lifting[name][a], b)
            assert b.min() >= 0 and b.max() < G


@needs_tool
def test_the_same_inputs_give_the_same_bytes_with_and_without_a_cluster(tmp_path):
    distributed = pytest.importorskip("distributed", reason="python3-distributed (scripts/install-deps.sh)")
    _, inputs = _planted_inputs(tmp_path, missions=3, seed=4)
    here = rost.fleet.run(inputs, tmp_path / "here", fixed=True, K=6, final_sweeps=10, seed=5)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as c, \
            distributed.Client(c) as client:
        spread = rost.fleet.run(inputs, tmp_path / "spread", client, fixed=True, K=6, final_sweeps=10, seed=5)
        # A second fleet on the same client, its missions of the same names: each one runs (Dask
        # takes a task of a key it holds already for that task, so the keys cannot be the names').
        again = rost.fleet.run(inputs, tmp_path / "again", client, K=6, final_sweeps=10, seed=5)
    for name in inputs:
        assert (tmp_path / "again" / name / "topics.csv").read_bytes() == (tmp_path / "here" / name / "topics.csv").read_bytes()
    np.testing.assert_array_equal(again["global_counts"], here["global_counts"])
    a, b = _tree(tmp_path / "here"), _tree(tmp_path / "spread")
    assert sorted(a) == sorted(b)
    assert {"m0/topics.global.csv", "m2/fixed/topics.csv", "merged/lifting.csv", "merged/topicmodel.csv"} <= set(a)
    assert [k for k in a if a[k] != b[k]] == []
    np.testing.assert_array_equal(here["global_counts"], spread["global_counts"])
    # The fixed pass labels in the global topics and leaves their counts as given.
    G = here["global_counts"].shape[0]
    for name in inputs:
        labels = np.concatenate(rost.io.read_topics(tmp_path / "here" / name / "fixed" / "topics.csv")[1])
        assert labels.min() >= 0 and labels.max() < G


def test_each_fleets_dask_keys_are_its_own():
    """Dask takes a task whose key it holds already for that task: two fleets (one client, or one
    scheduler shared by two users) with a mission of the same name must not share its key, or the
    second one's mission never runs."""
    class Recorder:  # a client that records the keys it is given
        def __init__(self):
            self.keys = []

        def map(self, fn, commands, key, pure):
            assert pure is False
            self.keys.append(list(key))
            return commands

        def gather(self, futures):
            return futures

    client = Recorder()
    for _ in range(2):
        rost.fleet._run_all([["rost", "run", "--out", "a"], ["rost", "run", "--out", "b"]], ["dive1", "dive2"], client,
                            "mission")
    first, second = client.keys
    assert all("mission" in k and "dive1" in k for k in (first[0], second[0])), client.keys
    assert len(set(first) | set(second)) == 4, "every task of both fleets has a key of its own: %s" % client.keys


def test_bad_missions_are_refused_naming_them_before_anything_runs(tmp_path):
    (tmp_path / "w.csv").write_text("0,1,2\n1,2,3\n")
    good = str(tmp_path / "w.csv")
    out = tmp_path / "out"
    tool = {"tool": TOOL or "/bin/true"}
    with pytest.raises(FileNotFoundError, match=r"mission 'b': no such input: .*nowhere\.mov"):
        rost.fleet.run({"a": good, "b": tmp_path / "nowhere.mov"}, out, K=6, **tool)
    assert not out.exists(), "nothing was written"
    for bad in ("", "a/b", "../up", "merged", "fleet.conf", "fleet.conf.tmp", "x,y", ".hidden", 3):
        with pytest.raises(ValueError, match="bad mission name"):
            rost.fleet.run({"a": good, bad: good}, out, **tool)
    (tmp_path / "dive.bag").write_bytes(b"")
    with pytest.raises(ValueError, match=r"mission 'auv': a bag needs its image topic"):
        rost.fleet.run({"auv": str(tmp_path / "dive.bag")}, out, **tool)
    with pytest.raises(ValueError, match=r"mission 'auv': a bag is a \(path, topic\) pair"):
        rost.fleet.run({"auv": (str(tmp_path / "dive.bag"),)}, out, **tool)
    with pytest.raises(TypeError, match=r"mission 'a': expected a path"):
        rost.fleet.run({"a": 7}, out, **tool)
    with pytest.raises(ValueError, match="missions: expected a non-empty mapping"):
        rost.fleet.run({}, out, **tool)
    with pytest.raises(ValueError, match="unknown setting 'bogus'"):
        rost.fleet.run({"a": good}, out, bogus=1, **tool)
    with pytest.raises(FileNotFoundError, match="the rost tool was not found: '/no/such/rost'"):
        rost.fleet.run({"a": good}, out, tool="/no/such/rost")
    # The merge's settings are checked before the missions run (not after hours of them).
    with pytest.raises(ValueError, match=r"threshold=2\.0, merge_beta=0\.01: .*threshold 2 out of range \[0, 1\]"):
        rost.fleet.run({"a": good}, out, threshold=2.0, **tool)
    with pytest.raises(ValueError, match=r"merge_beta=-1\.0: .*beta"):
        rost.fleet.run({"a": good}, out, merge_beta=-1.0, **tool)
    assert not out.exists()


def _regimes(path, frames=150, scenes=3, words=60, seed=3):
    """A word stream whose parts use words 0-9, 10-19, ... (`scenes` scenes in turn)."""
    rng = np.random.default_rng(seed)
    with open(path, "w") as f:
        for t in range(frames):
            base = 10 * (scenes * t // frames)
            f.write(",".join(map(str, [t, *(base + rng.integers(0, 10, words))])) + "\n")
    return path


@needs_tool
def test_with_growth_the_global_labels_are_the_missions_labelled_again(tmp_path):
    """With topics_grow and a window shorter than the mission, a topic that closes renumbers those
    above it, and rows written before keep their old numbers: lifted through the final model they
    named another topic (every frame of the three scenes read as the last scene's). The fleet then
    labels every mission again in the global topics (the relabelling needs topics.grow off: the
    global model is fixed), and topics.global.csv is that labelling."""
    regimes = _regimes(tmp_path / "regimes.csv")
    plain = _regimes(tmp_path / "plain.csv", frames=50, scenes=1)  # words 0-9 only: the first scene
    r = rost.fleet.run({"a": regimes, "b": plain}, tmp_path / "season", K=10, topics_grow=True, ring_steps=20,
                       eviction="subtract", threads=1, final_sweeps=5)
    assert sorted(r["fixed"]) == ["a", "b"]
    _, a_rows = rost.io.read_topics(r["topics_global"]["a"])
    _, b_rows = rost.io.read_topics(r["topics_global"]["b"])
    first_scene = np.bincount(np.concatenate(b_rows)).argmax()
    assert np.mean(np.concatenate(b_rows) == first_scene) > 0.9
    # The regimes mission's first scene (words 0-9) is the plain mission's topic; its last is not.
    assert np.mean(np.concatenate(a_rows[:40]) == first_scene) > 0.9, a_rows[:3]
    assert np.mean(np.concatenate(a_rows[110:]) == first_scene) < 0.1, a_rows[-3:]
    for n in ("a", "b"):
        assert pathlib.Path(r["topics_global"][n]).read_bytes() == \
            (pathlib.Path(r["fixed"][n]) / "topics.csv").read_bytes()


@needs_tool
def test_the_tools_notes_are_kept_and_printed_naming_the_mission(tmp_path, capfd):
    """A word-stream mission has one cell a frame: words past cell.capacity are subsampled out,
    and the tool says so. The fleet runs the tool without -q and keeps and prints its notes."""
    rng = np.random.default_rng(1)
    with open(tmp_path / "w.csv", "w") as f:
        for t in range(5):
            f.write(",".join(map(str, [t, *rng.integers(0, 50, 1000)])) + "\n")
    r = rost.fleet.run({"dense": tmp_path / "w.csv"}, tmp_path / "season", K=4, threads=1)
    assert len(r["notes"]["dense"]) == 1 and "of the words were dropped (3720 of 5000" in r["notes"]["dense"][0], r
    err = capfd.readouterr().err
    assert "rost.fleet: mission dense: note: 74.4 % of the words were dropped" in err, err


def test_each_input_becomes_the_tools_command(tmp_path):
    (tmp_path / "frames").mkdir()
    (tmp_path / "w.csv").write_text("0,1\n")
    (tmp_path / "d.bag").write_bytes(b"")
    conf = tmp_path / "fleet.conf"
    cmd = lambda source: rost.fleet.mission_command("/t/rost", "m", source, "/o/m", conf)
    assert cmd(tmp_path / "w.csv")[:3] == ["/t/rost", "refine", str(tmp_path / "w.csv")]
    assert cmd(str(tmp_path / "frames"))[:3] == ["/t/rost", "run", str(tmp_path / "frames")]
    bag = cmd((tmp_path / "d.bag", "/camera/image"))
    assert bag[:5] == ["/t/rost", "run", str(tmp_path / "d.bag"), "--topic", "/camera/image"]
    assert bag[5:] == ["--out", "/o/m", "--config", str(conf)]  # not -q: the tool's notes are relayed
    text = rost.fleet.settings_text(K=6, final_sweeps=50, topics_grow=True, alpha=0.25, budget_ms=None)
    assert text == "K = 6\nfinal.sweeps = 50\ntopics.grow = true\nalpha = 0.25\n"


@needs_tool
def test_a_mission_the_tool_refuses_fails_naming_it(tmp_path):
    (tmp_path / "good.csv").write_text("0,1,2\n1,2,3\n")
    (tmp_path / "broken.csv").write_text("0,1,2\n1,2,x\n")
    with pytest.raises(RuntimeError, match=r"mission .*broken failed \(exit 2\): .*broken\.csv:2"):
        rost.fleet.run({"good": tmp_path / "good.csv", "broken": tmp_path / "broken.csv"}, tmp_path / "out", K=2)


def test_lift_topics_refuses_a_label_outside_the_lifting_naming_the_file(tmp_path):
    """A topics.csv of another model (a label k >= K of the lifting, or negative) is refused
    with ValueError naming the file and the observation, not numpy's IndexError, and writes nothing."""
    topics = tmp_path / "topics.csv"
    out = tmp_path / "lifted.csv"
    rost.io.write_topics(topics, [0, 1], [np.array([0, 1], np.int32), np.array([2, 1], np.int32)])
    rost.fleet.lift_topics(topics, [5, 6, 7], out)
    assert [list(l) for l in rost.io.read_topics(out)[1]] == [[5, 6], [7, 6]]
    out.unlink()
    for lifting, t in (([5, 6], 1), ([5], 0)):
        with pytest.raises(ValueError, match=r"topics\.csv: observation %d: a label outside the model's %d topics"
                           % (t, len(lifting))) as e:
            rost.fleet.lift_topics(topics, lifting, out)
        assert type(e.value) is ValueError
    # A negative label (numpy would read lifting[-1] as the last topic's) is refused too.
    topics.write_text("0,0,1\n1,-1,2\n")
    with pytest.raises(ValueError, match=r"topics\.csv: observation 1: a label outside the model's 3 topics"):
        rost.fleet.lift_topics(topics, [5, 6, 7], out)
    assert not out.exists()
