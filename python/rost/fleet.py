"""rost.fleet: a season of missions, one shared set of topics (docs/fleet.md).

    import rost.fleet
    result = rost.fleet.run({"dive1": "dive1.mov", "dive2": "frames/", "auv": ("auv.bag", "/camera/image"),
                             "old": "old/words.csv"}, "season", K=6, final_sweeps=50)
    result["global_counts"], result["lifting"]["dive1"], result["topics_global"]["dive2"]

Each mission is one run of the `rost` tool (`rost run INPUT` for a video, an image folder or a
bag; `rost refine WORDS.csv` for a word stream) with the settings given as `rost.Config`
keywords, written once to `out/fleet.conf` and passed with `--config`. The missions run in this
process one after the other (`client=None`) or as one Dask task each (`client`: a
`distributed.Client` of a LocalCluster or of a scheduler on many machines; the inputs, `out` and
the tool must then be at the same paths on every worker). Their topic models are then merged
(rost.merge_topic_models, in mission order) and every mission's labels lifted to the global
topics. The same missions and settings give the same bytes with or without a cluster.

Writes out/<name>/ (the tool's files), out/<name>/topics.global.csv (topics.csv with every label
lifted to its global topic; -1 for a label whose topic holds no word), out/merged/topicmodel.csv
and out/merged/lifting.csv (`model,local,global`, the mission names in `model`); with
fixed=True also out/<name>/fixed/: the mission labelled again in the global topics
(`--in.topicmodel out/merged/topicmodel.csv --topicmodel.fixed`). With topics_grow=True that
relabelling always runs and is topics.global.csv: a topic that closes renumbers those above it,
so rows written before would not lift through the final numbering. The tool's notes are printed
on stderr naming the mission.
"""

import os
import re
import shutil
import subprocess
import sys
import uuid

import numpy as np

from . import io as _io
from ._rost import Config

__all__ = ["run", "find_tool", "lift_topics", "mission_command", "settings_text"]

# Names become directory names and CSV fields: a letter or digit, then letters, digits, '_', '.', '-'.
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*\Z")
# Names the fleet writes beside the missions' directories.
_RESERVED = ("merged", "fleet.conf", "fleet.conf.tmp")


def find_tool(tool=None):
    """The rost tool: `tool`, else $ROST_TOOL, else `rost` on PATH; an absolute path."""
    given = tool or os.environ.get("ROST_TOOL")
    found = shutil.which(os.fspath(given)) if given else shutil.which("rost")
    if not found:
        where = f"'{given}'" if given else "'rost' on PATH (or set ROST_TOOL)"
        raise FileNotFoundError(f"rost.fleet: the rost tool was not found: {where}")
    return os.path.abspath(found)


def settings_text(**settings):
    """`key = value` lines (as `rost config` writes them) of the given rost.Config keywords.

    Keywords are checked by rost.Config (an unknown one or a value out of range raises,
    naming it); None leaves a setting at the tool's default."""
    given = {k: v for k, v in settings.items() if v is not None}
    config = Config(**given)
    keys = {d["name"]: d["key"] for d in Config.describe()}
    lines = []
    for name in given:
        value = getattr(config, name)
        if isinstance(value, bool):
            text = "true" if value else "false"
        elif isinstance(value, float):
            text = repr(value)
        else:
            text = str(value)
        lines.append(f"{keys[name]} = {text}\n")
    return "".join(lines)


def _check_name(name):
    if not isinstance(name, str) or not _NAME.match(name) or name in _RESERVED:
        raise ValueError(f"rost.fleet: bad mission name {name!r}: a letter or digit, then letters, digits, "
                         f"'_', '.' or '-' (it names a directory and a CSV field), and not "
                         f"{', '.join(repr(r) for r in _RESERVED)}")


def _input(name, source):
    """(command, input arguments) of a mission's input; errors name the mission."""
    if isinstance(source, tuple):
        if len(source) != 2 or not isinstance(source[1], str) or not source[1]:
            raise ValueError(f"rost.fleet: mission {name!r}: a bag is a (path, topic) pair, found {source!r}")
        path, topic = os.fspath(source[0]), source[1]
        extra = ["--topic", topic]
    elif isinstance(source, (str, os.PathLike)):
        path, extra = os.fspath(source), []
    else:
        raise TypeError(f"rost.fleet: mission {name!r}: expected a path or a (bag, topic) pair, "
                        f"found {type(source).__name__}")
    if not os.path.exists(path):
        raise FileNotFoundError(f"rost.fleet: mission {name!r}: no such input: {path}")
    path = os.path.abspath(path)
    if path.endswith(".bag") and not extra:
        raise ValueError(f"rost.fleet: mission {name!r}: a bag needs its image topic: ({path!r}, '/camera/image')")
    if path.endswith(".csv") and not extra:
        return "refine", [path]
    return "run", [path, *extra]


def mission_command(tool, name, source, out_dir, config_file, extra=()):
    """The tool's argument list for one mission, writing into out_dir."""
    command, args = _input(name, source)
    return [tool, command, *args, "--out", os.fspath(out_dir), "--config", os.fspath(config_file), *extra]


def _run_tool(argv):
    """One mission (a Dask task, or a call here): runs the tool; raises naming the mission.
    Returns the tool's notes (its `rost: note:` lines: words dropped, a cap reached, ...)."""
    done = subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, check=False)
    if done.returncode != 0:
        out = argv[argv.index("--out") + 1]
        raise RuntimeError(f"rost.fleet: mission {out} failed (exit {done.returncode}): {done.stderr.strip()}\n"
                           f"  command: {' '.join(argv)}")
    return [line[len("rost: "):] for line in done.stderr.splitlines() if line.startswith("rost: note: ")]


def _run_all(commands, names, client, stage):
    """Runs the commands in order here, or as Dask tasks. Keys name the mission and stage, and a
    token of this call: Dask takes a task whose key it holds already for that task, so another
    fleet's mission of the same name (on a shared client or scheduler) would not run.
    Returns each mission's notes, and prints them on stderr in mission order, naming it."""
    if client is None:
        notes = [_run_tool(c) for c in commands]
    else:
        token = uuid.uuid4().hex[:12]
        keys = [f"rost-fleet-{stage}-{n}-{token}" for n in names]
        notes = client.gather(client.map(_run_tool, commands, key=keys, pure=False))
    where = "" if stage == "mission" else f" ({stage})"
    for name, lines in zip(names, notes):
        for line in lines:
            print(f"rost.fleet: mission {name}{where}: {line}", file=sys.stderr)
    return dict(zip(names, notes))


def _merge(paths, threshold, beta):
    try:
        from ._rost import merge_topic_models
    except ImportError as e:  # a module built before the merge API
        raise ImportError("rost.fleet: this rost module has no merge_topic_models (rebuild rost)") from e
    return merge_topic_models(paths, threshold=threshold, beta=beta)


def _write_text(path, text):
    tmp = f"{path}.tmp"
    with open(tmp, "w", encoding="utf-8", newline="") as f:
        f.write(text)
    os.replace(tmp, path)


def lift_topics(topics_csv, lifting, out_csv):
    """Writes topics_csv with every label k replaced by lifting[k] (its global topic)."""
    lifting = np.asarray(lifting, dtype=np.int32)
    timestamps, rows = _io.read_topics(topics_csv)
    lifted = []
    for t, labels in zip(timestamps, rows):
        if labels.size and (labels.min() < 0 or labels.max() >= lifting.size):
            raise ValueError(f"{topics_csv}: observation {t}: a label outside the model's {lifting.size} topics")
        lifted.append(lifting[labels])
    _io.write_topics(out_csv, timestamps, lifted)


def _prepare(missions, out, tool, settings, threshold, merge_beta):
    """Checks every mission and setting (the merge's too) before anything runs; writes out/fleet.conf."""
    if not hasattr(missions, "items") or not missions:
        raise ValueError("rost.fleet: missions: expected a non-empty mapping of names to inputs")
    for name, source in missions.items():
        _check_name(name)
        _input(name, source)
    try:  # the merge's own checks, on a one-word model, before hours of missions
        _merge([np.ones((1, 1), dtype=np.int64)], threshold, merge_beta)
    except (ValueError, TypeError) as e:
        raise type(e)(f"rost.fleet: threshold={threshold!r}, merge_beta={merge_beta!r}: {e}") from e
    tool = find_tool(tool)
    out = os.path.abspath(os.fspath(out))
    text = settings_text(**settings)
    os.makedirs(os.path.join(out, "merged"), exist_ok=True)
    config_file = os.path.join(out, "fleet.conf")
    _write_text(config_file, "# rost.fleet: the missions' settings (rost run/refine --config)\n" + text)
    return tool, out, config_file


def run(missions, out, client=None, *, threshold=0.6, merge_beta=0.01, fixed=False, tool=None, **settings):
    """Runs every mission, merges their topic models and lifts their labels (module docstring).

    missions: name -> input (a video or image folder path; (bag, topic); a words .csv path), in the
    order the merge takes them. settings: rost.Config keywords (K=6, final_sweeps=50).
    threshold, merge_beta: the merge's Hellinger threshold and smoothing (rost merge's --threshold,
    --beta). Returns a dict: global_counts (G x V int64), lifting and distance (name -> array),
    topicmodel and lifting_csv (paths), missions, topics_global, notes (name -> the tool's notes,
    also printed on stderr naming the mission) and, with fixed (or topics_grow, which labels every
    mission again in the global topics), fixed (name -> path) and notes_fixed."""
    tool, out, config_file = _prepare(missions, out, tool, settings, threshold, merge_beta)
    # With topics_grow a topic that closes renumbers those above it from then on, and rows of
    # topics.csv written earlier keep the numbers of their time (docs/design.md): lifting them
    # through the final model's numbering could name another topic. So every mission is then
    # labelled again in the global topics, and that labelling is topics.global.csv.
    grows = bool(settings.get("topics_grow"))
    names = list(missions)
    dirs = [os.path.join(out, n) for n in names]
    commands = [mission_command(tool, n, missions[n], d, config_file) for n, d in zip(names, dirs)]
    notes = _run_all(commands, names, client, "mission")

    merged = _merge([os.path.join(d, "topicmodel.csv") for d in dirs], threshold, merge_beta)
    topicmodel = os.path.join(out, "merged", "topicmodel.csv")
    lifting_csv = os.path.join(out, "merged", "lifting.csv")
    _write_text(topicmodel, merged.topicmodel_csv())
    _write_text(lifting_csv, merged.lifting_csv(names=names))
    result = {
        "global_counts": np.asarray(merged.global_counts),
        "lifting": {n: np.asarray(a) for n, a in zip(names, merged.lifting)},
        "distance": {n: np.asarray(a) for n, a in zip(names, merged.distance)},
        "topicmodel": topicmodel, "lifting_csv": lifting_csv,
        "missions": dict(zip(names, dirs)), "topics_global": {}, "notes": notes,
    }
    for n, d in zip(names, dirs):
        result["topics_global"][n] = os.path.join(d, "topics.global.csv")
        if not grows:
            lift_topics(os.path.join(d, "topics.csv"), result["lifting"][n], result["topics_global"][n])
    if fixed or grows:
        G = result["global_counts"].shape[0]
        # The global model is held fixed: it neither grows nor loses a topic.
        pinned = ["-K", str(G), "--in.topicmodel", topicmodel, "--topicmodel.fixed", "--topics.grow=false"]
        fixed_dirs = [os.path.join(d, "fixed") for d in dirs]
        commands = [mission_command(tool, n, missions[n], d, config_file, pinned) for n, d in zip(names, fixed_dirs)]
        result["notes_fixed"] = _run_all(commands, names, client, "fixed")
        result["fixed"] = dict(zip(names, fixed_dirs))
        if grows:
            for n, d in zip(names, fixed_dirs):
                shutil.copyfile(os.path.join(d, "topics.csv"), result["topics_global"][n] + ".tmp")
                os.replace(result["topics_global"][n] + ".tmp", result["topics_global"][n])
    return result
