"""Shared by the Python tests: a study database from a real session (the
hapticlab binary: `study create`, `session run` of one trial, `export`),
built once per test script, and the export's samples CSV read back exactly.

Environment (set by tests/python/CMakeLists.txt):
  HAPTICLAB_CLI          the hapticlab binary
  HAPTICLAB_SOURCE_DIR   the source tree (protocols, python/)
  HAPTICLAB_SQLITE_EXTENSION  hapticlab_sqlite.so (extension test only)
"""

import csv
import os
import shutil
import sqlite3
import subprocess
import sys
import tempfile
from fractions import Fraction
from pathlib import Path

import numpy as np

SOURCE_DIR = Path(os.environ["HAPTICLAB_SOURCE_DIR"])
CLI = os.environ["HAPTICLAB_CLI"]
sys.path.insert(0, str(SOURCE_DIR / "python"))

# Columns of the samples CSV before the channels (db/export_csv.h).
KEY_COLUMNS = ("trial_id", "participant", "task", "setting", "repetition", "instrument", "tick")


def run_cli(*args):
    done = subprocess.run([CLI, *args], capture_output=True, text=True)
    if done.returncode != 0:
        raise AssertionError(f"hapticlab {' '.join(args)} exited {done.returncode}:\n{done.stdout}{done.stderr}")
    return done.stdout


class Study:
    """A temporary directory with study.db (one complete trial, id 1) and
    its export; remove() deletes it."""

    def __init__(self):
        self.dir = Path(tempfile.mkdtemp(prefix="hapticlab_py_"))
        self.db = self.dir / "study.db"
        run_cli("study", "create", "--protocol", str(SOURCE_DIR / "examples/protocols/thesis_quick.json"),
                "--db", str(self.db))
        # 250 Hz: fewer rows to read back, the same chunks' layout.
        run_cli("session", "run", "--db", str(self.db), "--participant", "S1", "--training-trials", "0",
                "--max-trials", "1", "--rate-hz", "250")
        run_cli("export", "--db", str(self.db), "--trial", "1", "--format", "csv", "--out", str(self.dir / "csv"))
        (self.samples_csv,) = (self.dir / "csv").glob("*_samples.csv")

    def copy(self, name):
        """A copy of the database to damage (SQLite's backup API: the
        session left it in WAL mode, so the file alone is not the database)."""
        path = self.dir / name
        src = sqlite3.connect(f"file:{self.db}?mode=ro", uri=True)
        dst = sqlite3.connect(path)
        src.backup(dst)
        src.close()
        dst.close()
        return path

    def remove(self):
        shutil.rmtree(self.dir, ignore_errors=True)


def read_export(path):
    """(header, columns): the CSV's header and a dict column -> list of text."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header = rows[0]
    columns = {name: [row[k] for row in rows[1:]] for k, name in enumerate(header)}
    return header, columns


def _float32_exact(text):
    """The float32 that strtof gives for `text` (round to nearest, ties to
    even), from the exact decimal value: no double rounding."""
    if text.lower().lstrip("+-") in ("inf", "nan", "infinity"):
        return np.float32(float(text))
    x = Fraction(text)
    c = np.float32(float(x))
    best = None
    for cand in (np.nextafter(c, np.float32(-np.inf)), c, np.nextafter(c, np.float32(np.inf))):
        if not np.isfinite(cand):
            continue
        dist = abs(Fraction(float(cand)) - x)
        even = int(np.array(cand, dtype=np.float32).view(np.uint32)) % 2 == 0
        key = (dist, not even)
        if best is None or key < best[0]:
            best = (key, cand)
    return best[1]


def parse_float32(texts):
    """The export's float32 column text as the float32 values it stands for.
    Parsing as a double then rounding to float32 rounds twice, which can be
    off by one float32 step when the double lands on (or next to) a float32
    midpoint; those few (and float32 subnormals) are parsed exactly."""
    d = np.array([float(t) for t in texts], dtype=np.float64)
    f = d.astype(np.float32)
    low = (d.view(np.uint64) & np.uint64((1 << 29) - 1)).astype(np.int64)
    risky = (np.abs(low - (1 << 28)) <= 1) | ((np.abs(d) < 2.0 ** -126) & (d != 0))
    for i in np.nonzero(risky)[0]:
        f[i] = _float32_exact(texts[i])
    return f


def parse_float64(texts):
    return np.array([float(t) for t in texts], dtype=np.float64)


def same_bits(a, b):
    """Equal bit for bit (NaN equal to NaN: its text carries no payload)."""
    a = np.asarray(a)
    b = np.asarray(b)
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    nan = np.isnan(a) & np.isnan(b) if a.dtype.kind == "f" else np.zeros(a.shape, dtype=bool)
    if a.dtype.kind == "f":
        ua = a.view(np.uint64 if a.dtype.itemsize == 8 else np.uint32)
        ub = b.view(np.uint64 if b.dtype.itemsize == 8 else np.uint32)
        return bool(np.all((ua == ub) | nan))
    return bool(np.all(a == b))


def first_difference(a, b):
    a = np.asarray(a)
    b = np.asarray(b)
    for i in range(min(a.size, b.size)):
        if a[i].tobytes() != b[i].tobytes() and not (a.dtype.kind == "f" and np.isnan(a[i]) and np.isnan(b[i])):
            return f"row {i}: {a[i]!r} vs {b[i]!r}"
    return f"sizes {a.size} vs {b.size}"
