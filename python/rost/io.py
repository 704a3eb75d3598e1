"""rost.io: the rost tool's files as numpy arrays (formats: docs/tool.md, "Outputs").

Row files, one observation per line, ``timestamp,v1,v2,...``:
    words.csv, topics.csv       read_words / read_topics  -> (timestamps int64 (F,), [int32 (N_f,), ...])
    positions.csv               read_positions            -> (timestamps, [int32 (N_f, 2), ...])
Table files:
    perplexity.csv              read_perplexity  -> structured array: frame, instantaneous, final, plugin, topics
                                write_perplexity <- a Mission's run() (the tool's bytes)
    surprise.csv                read_surprise    -> structured array: frame, surprise
                                write_surprise   <- a Mission's run()
    surprise_cells.csv          read_surprise_cells -> (frames int64 (F,), float64 (F, cells))
    topicmodel.csv              read_topicmodel  -> int64 (K, V) counts n_k^v

The reading, the lines and fields, the numbers and the writing are the core's
text I/O layer (rost/text_io.hpp, through rost._rost.text): blank lines and
lines starting with '#' are skipped, errors name the file, the line and the
column ("words.csv:4:5: expected an integer, found 'x'"), a missing file or a
directory raises OSError (FileNotFoundError, IsADirectoryError). The writers
produce what ``rost refine`` (words, positions) and ``--in.topicmodel`` read,
through a temporary file renamed into place: a failed write leaves the old file.
"""

import os

import numpy as np

from ._rost import text as _text

__all__ = [
    "read_words", "read_topics", "read_positions", "read_perplexity", "read_surprise",
    "read_surprise_cells", "read_topicmodel",
    "write_words", "write_topics", "write_positions", "write_topicmodel",
]


def _rows(path):
    """(timestamps int64, [(line number, int64 values after the timestamp), ...])."""
    rows, numbers = _text.TextFile(os.fspath(path)).integer_rows()
    timestamps = np.asarray([r[0] for r in rows], dtype=np.int64)
    return timestamps, [(n, r[1:]) for n, r in zip(numbers, rows)]


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


def _numbers(path, header_ok, header_text):
    """A header line, then rows of an integer and numbers as wide as the header:
    (header, line numbers, first column, the other columns, field counts)."""
    f = _text.TextFile(os.fspath(path))
    header = f.header()
    if not header_ok(header):
        raise ValueError(f"{path}:1: expected the header '{header_text}'")
    numbers, first, values, counts = f.number_rows(len(header))
    return header, numbers, first, values, counts


def _table(path, names):
    _, numbers, first, values, counts = _numbers(path, lambda h: h == list(names), ",".join(names))
    bad = np.flatnonzero(counts != len(names))
    if bad.size:
        raise ValueError(f"{path}:{numbers[bad[0]]}: {counts[bad[0]]} fields, expected {len(names)}")
    dtype = [(names[0], np.int64)] + [(n, np.float64) for n in names[1:]]
    out = np.empty(len(first), dtype=dtype)
    out[names[0]] = first
    for i, n in enumerate(names[1:]):
        out[n] = values[:, i]
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
    header, numbers, frames, values, counts = _numbers(
        path, lambda h: bool(h) and h[0] == "frame", "frame,cell0,cell1,...")
    cells = len(header) - 1
    bad = np.flatnonzero(counts != cells + 1)
    if bad.size:
        n = counts[bad[0]] - 1
        raise ValueError(f"{path}:{numbers[bad[0]]}: {n} cell{'' if n == 1 else 's'}, expected {cells}")
    return frames, values


def read_topicmodel(path):
    """topicmodel.csv: K x V counts (int64), topic k on line k+1."""
    rows, numbers = _text.TextFile(os.fspath(path)).integer_rows()
    if not rows:
        raise ValueError(f"{path}: no topic lines")
    width = len(rows[0])
    for n, r in zip(numbers, rows):
        if len(r) != width:
            raise ValueError(f"{path}:{n}: {len(r)} counts, expected {width} (as on the first line)")
        if r.min() < 0:
            raise ValueError(f"{path}:{n}: a count is negative")
    return np.asarray(rows, dtype=np.int64)


def _int64s(values, what):
    """`values` as int64, each exactly: whole-number floats are taken, a fraction, a NaN or a value
    past int64 (a uint64 2^64 - 1 is not -1) is refused naming its index."""
    a = np.asarray(values)
    if a.size == 0:
        return a.astype(np.int64)
    if a.dtype.kind == "f":
        bad = np.flatnonzero(~(np.isfinite(a) & (a == np.floor(a)) & (a >= -(2.0**63)) & (a < 2.0**63)))
        if bad.size:
            raise ValueError(f"{what}[{bad[0]}] = {a.reshape(-1)[bad[0]]!r} is not a whole number in int64's range")
        return a.astype(np.int64)
    if a.dtype.kind not in "iu":
        raise TypeError(f"{what}: expected integers, found dtype {a.dtype}")
    if a.dtype.kind == "u":
        bad = np.flatnonzero(a.reshape(-1) > np.iinfo(np.int64).max)
        if bad.size:
            raise ValueError(f"{what}[{bad[0]}] = {a.reshape(-1)[bad[0]]} exceeds 2^63 - 1")
    return a.astype(np.int64)


def _write_rows(path, timestamps, rows, width):
    if len(timestamps) != len(rows):
        raise ValueError(f"{len(timestamps)} timestamps for {len(rows)} rows")
    stamps = np.asarray(timestamps)
    if stamps.ndim != 1:
        raise ValueError(f"timestamps: expected a 1-D sequence, found shape {stamps.shape}")
    stamps = _int64s(stamps, "timestamps")
    flat = []
    for i, r in enumerate(rows):
        a = np.asarray(r)
        if a.size and a.dtype.kind not in "iu":
            raise TypeError(f"row {i}: expected integer arrays, found dtype {a.dtype}")
        if width == 2 and (a.ndim != 2 or a.shape[1] != 2):
            raise ValueError(f"positions: expected shape (N, 2), found {a.shape}")
        if width == 1 and a.ndim != 1:
            raise ValueError(f"row {i}: expected a 1-D array, found shape {a.shape}")
        flat.append(_int64s(a, f"row {i}").reshape(-1))
    _text.write_rows(os.fspath(path), stamps, flat)


def write_words(path, timestamps, words):
    """words.csv (``rost refine`` reads it): one line per observation."""
    _write_rows(path, timestamps, words, 1)


def write_topics(path, timestamps, topics):
    """topics.csv: one line per observation."""
    _write_rows(path, timestamps, topics, 1)


def write_positions(path, timestamps, positions):
    """positions.csv (``rost refine --positions``): x,y pairs per observation."""
    _write_rows(path, timestamps, positions, 2)


def write_topicmodel(path, counts):
    """topicmodel.csv (``--in.topicmodel``): K lines of V counts."""
    a = np.asarray(counts)
    if a.ndim != 2 or a.dtype.kind not in "iu":
        raise ValueError(f"counts: expected a K x V integer array, found {a.dtype} of shape {a.shape}")
    a = _int64s(a, "counts")
    if a.size and a.min() < 0:
        raise ValueError("counts: a count is negative")
    _text.write_matrix(os.fspath(path), a)


def write_perplexity(path, results):
    """perplexity.csv as ``rost refine`` writes it, from a Mission's ``run()`` (or any mapping
    with timestamp, instantaneous, final, plugin and topics): read_perplexity reads it back."""
    cols = ("instantaneous", "final", "plugin", "topics")
    _text.write_table(os.fspath(path), ["frame", *cols], _int64s(results["timestamp"], "timestamp"),
                      [np.asarray(results[c], dtype=np.float64) for c in cols[:3]] + [_int64s(results["topics"], "topics")],
                      [False, False, False, True])


def write_surprise(path, results):
    """surprise.csv as ``rost refine`` writes it, from a Mission's ``run()`` (timestamp, surprise)."""
    _text.write_table(os.fspath(path), ["frame", "surprise"], _int64s(results["timestamp"], "timestamp"),
                      [np.asarray(results["surprise"], dtype=np.float64)], [False])
