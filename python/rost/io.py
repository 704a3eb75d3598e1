"""rost.io: the rost tool's files as numpy arrays (formats: docs/tool.md, "Outputs").

Row files, one observation per line, ``timestamp,v1,v2,...``:
    words.csv, topics.csv       read_words / read_topics  -> (timestamps int64 (F,), [int32 (N_f,), ...])
    positions.csv               read_positions            -> (timestamps, [int32 (N_f, 2), ...])
Table files:
    perplexity.csv              read_perplexity  -> structured array: frame, instantaneous, final, plugin, topics
    surprise.csv                read_surprise    -> structured array: frame, surprise
    surprise_cells.csv          read_surprise_cells -> (frames int64 (F,), float64 (F, cells))
    topicmodel.csv              read_topicmodel  -> int64 (K, V) counts n_k^v

The writers produce what ``rost refine`` (words, positions) and ``--in.topicmodel``
read, through a temporary file renamed into place. Errors name the file and line.
"""

import os
import tempfile

import numpy as np

__all__ = [
    "read_words", "read_topics", "read_positions", "read_perplexity", "read_surprise",
    "read_surprise_cells", "read_topicmodel",
    "write_words", "write_topics", "write_positions", "write_topicmodel",
]


def _lines(path):
    """(line number, text) of each line that is not blank or a '#' comment."""
    with open(path, "r", encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            text = line.strip()
            if text and not text.startswith("#"):
                yield number, text


def _integers(path, number, fields):
    try:
        return [int(x) for x in fields]
    except ValueError:
        bad = next(x for x in fields if not x.strip().lstrip("-").isdigit())
        raise ValueError(f"{path}:{number}: expected an integer, found '{bad}'") from None


def _rows(path):
    timestamps, rows = [], []
    for number, text in _lines(path):
        values = _integers(path, number, text.split(","))
        timestamps.append(values[0])
        rows.append((number, values[1:]))
    return np.asarray(timestamps, dtype=np.int64), rows


def _as_int32(path, number, values):
    a = np.asarray(values, dtype=np.int64)
    if a.size and (a.min() < -2**31 or a.max() >= 2**31):
        raise ValueError(f"{path}:{number}: a value does not fit in int32")
    return a.astype(np.int32)


def read_words(path):
    """words.csv: (timestamps int64 (F,), list of F int32 arrays of word ids)."""
    ts, rows = _rows(path)
    return ts, [_as_int32(path, n, v) for n, v in rows]


def read_topics(path):
    """topics.csv: (timestamps int64 (F,), list of F int32 arrays of topics)."""
    return read_words(path)


def read_positions(path):
    """positions.csv: (timestamps int64 (F,), list of F int32 arrays of shape (N, 2))."""
    ts, rows = _rows(path)
    out = []
    for n, v in rows:
        if len(v) % 2:
            raise ValueError(f"{path}:{n}: {len(v)} coordinates, expected x,y pairs")
        out.append(_as_int32(path, n, v).reshape(-1, 2))
    return ts, out


def _table(path, names):
    lines = list(_lines(path))
    if not lines or lines[0][1].split(",") != list(names):
        raise ValueError(f"{path}:1: expected the header '{','.join(names)}'")
    dtype = [(names[0], np.int64)] + [(n, np.float64) for n in names[1:]]
    out = np.empty(len(lines) - 1, dtype=dtype)
    for i, (number, text) in enumerate(lines[1:]):
        fields = text.split(",")
        if len(fields) != len(names):
            raise ValueError(f"{path}:{number}: {len(fields)} fields, expected {len(names)}")
        try:
            out[i] = (int(fields[0]), *[float(x) for x in fields[1:]])
        except ValueError:
            raise ValueError(f"{path}:{number}: expected numbers, found '{text}'") from None
    return out


def read_perplexity(path):
    """perplexity.csv: structured array with fields frame, instantaneous, final, plugin
    (the plug-in perplexity of the 2013 ROST code at the instantaneous instant), topics
    (the open topics after the frame's refinement: K unless topics grow)."""
    return _table(path, ("frame", "instantaneous", "final", "plugin", "topics"))


def read_surprise(path):
    """surprise.csv: structured array with fields frame, surprise."""
    return _table(path, ("frame", "surprise"))


def read_surprise_cells(path):
    """surprise_cells.csv: (frames int64 (F,), surprise float64 (F, cells))."""
    lines = list(_lines(path))
    if not lines or lines[0][1].split(",")[0] != "frame":
        raise ValueError(f"{path}:1: expected the header 'frame,cell0,cell1,...'")
    cells = len(lines[0][1].split(",")) - 1
    frames = np.empty(len(lines) - 1, dtype=np.int64)
    values = np.empty((len(lines) - 1, cells), dtype=np.float64)
    for i, (number, text) in enumerate(lines[1:]):
        fields = text.split(",")
        if len(fields) != cells + 1:
            raise ValueError(f"{path}:{number}: {len(fields) - 1} cells, expected {cells}")
        frames[i] = _integers(path, number, fields[:1])[0]
        values[i] = [float(x) for x in fields[1:]]
    return frames, values


def read_topicmodel(path):
    """topicmodel.csv: K x V counts (int64), topic k on line k+1."""
    rows = [(n, _integers(path, n, text.split(","))) for n, text in _lines(path)]
    if not rows:
        raise ValueError(f"{path}: no topic lines")
    width = len(rows[0][1])
    for n, r in rows:
        if len(r) != width:
            raise ValueError(f"{path}:{n}: {len(r)} counts, expected {width} (as on the first line)")
        if min(r) < 0:
            raise ValueError(f"{path}:{n}: a count is negative")
    return np.asarray([r for _, r in rows], dtype=np.int64)


def _write(path, text):
    """Writes text through a temporary file in the same directory, renamed into place."""
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=".rost-io-")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _row_text(timestamps, rows, width):
    if len(timestamps) != len(rows):
        raise ValueError(f"{len(timestamps)} timestamps for {len(rows)} rows")
    out = []
    for t, r in zip(timestamps, rows):
        a = np.asarray(r)
        if a.dtype.kind not in "iu":
            raise TypeError(f"expected integer arrays, found dtype {a.dtype}")
        if width == 2 and (a.ndim != 2 or a.shape[1] != 2):
            raise ValueError(f"positions: expected shape (N, 2), found {a.shape}")
        out.append(",".join([str(int(t))] + [str(int(x)) for x in a.reshape(-1)]))
    return "\n".join(out) + ("\n" if out else "")


def write_words(path, timestamps, words):
    """words.csv (``rost refine`` reads it): one line per observation."""
    _write(path, _row_text(timestamps, words, 1))


def write_topics(path, timestamps, topics):
    """topics.csv: one line per observation."""
    _write(path, _row_text(timestamps, topics, 1))


def write_positions(path, timestamps, positions):
    """positions.csv (``rost refine --positions``): x,y pairs per observation."""
    _write(path, _row_text(timestamps, positions, 2))


def write_topicmodel(path, counts):
    """topicmodel.csv (``--in.topicmodel``): K lines of V counts."""
    a = np.asarray(counts)
    if a.ndim != 2 or a.dtype.kind not in "iu":
        raise ValueError(f"counts: expected a K x V integer array, found {a.dtype} of shape {a.shape}")
    if a.size and a.min() < 0:
        raise ValueError("counts: a count is negative")
    _write(path, "".join(",".join(str(int(x)) for x in row) + "\n" for row in a))
