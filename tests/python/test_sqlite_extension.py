"""hapticlab_sqlite.so from Python's own sqlite3 module (as db/README.md
shows it): the rows of samples(trial) equal `hapticlab export`'s CSV bit for
bit, and a damaged chunk raises an error naming it. Run by ctest with
/usr/bin/python3 (tests/python/CMakeLists.txt).
"""

import os
import sqlite3
import unittest

import numpy as np

import study_fixture as fx

EXTENSION = os.environ["HAPTICLAB_SQLITE_EXTENSION"]
STUDY = None

# db/README.md's example, word for word: the median tissue force magnitude
# in contact, per trial and instrument (SQLite has no median(): the middle
# row of each group, the lower one for an even count).
MEDIAN_QUERY = """
WITH contact AS (
  SELECT s.trial_id, s.instrument,
         sqrt(s.ve_force_x_N * s.ve_force_x_N + s.ve_force_y_N * s.ve_force_y_N
              + s.ve_force_z_N * s.ve_force_z_N) AS force_N
  FROM trial t, samples(t.id) s
  WHERE t.status = 'complete' AND s.in_contact = 1),
ranked AS (
  SELECT *, row_number() OVER (PARTITION BY trial_id, instrument ORDER BY force_N) AS k,
            count(*) OVER (PARTITION BY trial_id, instrument) AS n
  FROM contact)
SELECT trial_id, instrument, n, force_N AS median_force_N
FROM ranked WHERE k = (n + 1) / 2 ORDER BY trial_id, instrument;
"""


def setUpModule():
    global STUDY
    STUDY = fx.Study()


def tearDownModule():
    STUDY.remove()


def connect(path):
    conn = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    conn.enable_load_extension(True)
    conn.load_extension(EXTENSION)
    conn.enable_load_extension(False)
    return conn


class ExtensionFromPythonTest(unittest.TestCase):
    def test_rows_equal_the_export_bit_for_bit(self):
        header, csv = fx.read_export(STUDY.samples_csv)
        conn = connect(STUDY.db)
        cur = conn.execute("SELECT * FROM samples(1)")
        names = [d[0] for d in cur.description]
        rows = cur.fetchall()
        conn.close()
        channels = header[len(fx.KEY_COLUMNS):]
        self.assertEqual(names, ["trial_id", "instrument", "tick"] + channels)
        self.assertGreater(len(rows), 1000)
        self.assertEqual(len(rows), len(csv["tick"]))
        columns = list(zip(*rows))
        for k, name in enumerate(names):
            got = columns[k]
            text = csv[name]
            if name in ("dt_s", "t_s"):
                ok = fx.same_bits(np.array(got, dtype=np.float64), fx.parse_float64(text))
            elif k >= 3 and k < 3 + 25:
                # float32 channels arrive as the double equal to the stored float.
                ok = fx.same_bits(np.array(got, dtype=np.float64), fx.parse_float32(text).astype(np.float64))
            else:
                ok = all(isinstance(g, int) for g in got) and list(got) == [int(t) for t in text]
            self.assertTrue(ok, name)

    def test_per_trial_median_force_as_in_the_readme(self):
        conn = connect(STUDY.db)
        got = conn.execute(MEDIAN_QUERY).fetchall()
        rows = np.array(conn.execute(
            "SELECT instrument, ve_force_x_N, ve_force_y_N, ve_force_z_N FROM samples(1) WHERE in_contact = 1"
        ).fetchall())
        conn.close()
        want = []
        for hand in (0, 1):
            f = np.sort(np.sqrt(np.sum(np.square(rows[rows[:, 0] == hand, 1:]), axis=1)))
            if f.size:
                want.append((1, hand, f.size, float(f[(f.size + 1) // 2 - 1])))
        self.assertGreater(len(want), 0, "the trial must have contact")
        self.assertEqual(got, want)

    def test_a_damaged_chunk_raises_naming_it(self):
        path = STUDY.copy("damaged.db")
        conn = sqlite3.connect(path)
        chunk_id, first, count, blob = conn.execute(
            "SELECT id, first_tick, count, data FROM sample_chunk WHERE trial_id = 1 AND instrument = 0 "
            "ORDER BY first_tick LIMIT 1 OFFSET 1").fetchone()
        damaged = bytearray(blob)
        damaged[40] ^= 0xFF
        conn.execute("UPDATE sample_chunk SET data = ? WHERE id = ?", (bytes(damaged), chunk_id))
        conn.commit()
        conn.close()
        conn = connect(path)
        with self.assertRaisesRegex(sqlite3.OperationalError,
                                    f"damaged sample chunk: trial 1, left instrument \\(0\\), ticks {first}\\.\\."
                                    f"{first + count - 1}: checksum mismatch"):
            conn.execute("SELECT avg(ve_force_z_N) FROM samples(1)").fetchall()
        # The right instrument is intact.
        (n,) = conn.execute("SELECT count(*) FROM samples(1, 1)").fetchone()
        conn.close()
        self.assertGreater(n, 1000)


if __name__ == "__main__":
    unittest.main(verbosity=2)
