"""bench/analyze_numpy.py, the comparator of `hapticlab bench analyze
--compare`, does the same work as `hapticlab analyze`: on a real session's
database its per-trial metrics equal analyze's metrics.csv, and its Table 3.4
Friedman statistics equal `hapticlab stats friedman` on that CSV. Only then
is a speed ratio between the two meaningful. Run by ctest with
/usr/bin/python3 (tests/python/CMakeLists.txt).
"""

import csv
import json
import math
import shutil
import sqlite3
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

import study_fixture as fx

COMPARATOR = fx.SOURCE_DIR / "bench" / "analyze_numpy.py"
MEASURES = ("completion_time_s", "force_median_N", "force_p95_N", "speed_median_m_per_s", "path_length_m")
ENERGY = ("device_out_insertion_J", "device_in_insertion_J", "device_out_pitch_J", "device_in_pitch_J",
          "device_out_yaw_J", "device_in_yaw_J", "engine_out_J", "engine_in_J")


def read_rows(path):
    with open(path, newline="") as f:
        return {(r["trial_id"], r["instrument"]): r for r in csv.DictReader(f)}


def number(text):
    return float(text) if text != "" else math.nan


class ComparatorTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = Path(tempfile.mkdtemp(prefix="hapticlab_np_"))
        db = cls.dir / "study.db"
        fx.run_cli("study", "create", "--protocol", str(fx.SOURCE_DIR / "examples/protocols/thesis_quick.json"),
                   "--db", str(db))
        # One participant's whole session: 20 trials, 2 tasks x 5 settings x 2
        # repetitions; at 250 Hz, a quarter of the samples to simulate and read.
        fx.run_cli("session", "run", "--db", str(db), "--participant", "S1", "--training-trials", "0",
                   "--rate-hz", "250")
        fx.run_cli("analyze", "--db", str(db), "--out", str(cls.dir / "analysis"), "--no-ks", "--no-plots")
        cls.metrics_csv = cls.dir / "analysis" / "metrics.csv"
        done = subprocess.run([sys.executable, str(COMPARATOR), str(db), "--metrics-out", str(cls.dir / "np.csv"),
                               "--friedman-out", str(cls.dir / "np_friedman.csv")], capture_output=True, text=True)
        if done.returncode != 0:
            raise AssertionError(f"{COMPARATOR} exited {done.returncode}:\n{done.stdout}{done.stderr}")
        cls.hapticlab = read_rows(cls.metrics_csv)
        cls.numpy = read_rows(cls.dir / "np.csv")
        with open(cls.dir / "np_friedman.csv", newline="") as f:
            cls.friedman = list(csv.DictReader(f))

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.dir, ignore_errors=True)

    def test_same_trials_and_instruments(self):
        self.assertEqual(len(self.hapticlab), 40)
        self.assertEqual(set(self.hapticlab), set(self.numpy))

    def test_metrics_are_equal(self):
        checked = 0
        for key, ours in self.hapticlab.items():
            theirs = self.numpy[key]
            for column in ("samples", "force_samples"):
                self.assertEqual(int(ours[column]), int(theirs[column]), f"{key} {column}")
            for m in MEASURES:
                a, b = number(ours[m]), number(theirs[m])
                if math.isnan(a) or math.isnan(b):
                    self.assertTrue(math.isnan(a) and math.isnan(b), f"{key} {m}: {a} vs {b}")
                    continue
                checked += 1
                if m == "path_length_m":
                    # A sum of ~2e4 steps: HapticLab adds them in order, numpy
                    # pairwise; each rounding is <= 2^-53 relative, so the two
                    # can differ by n·2^-53 ~ 2e-12 at worst.
                    self.assertLessEqual(abs(a - b), 1e-11 * abs(a), f"{key} {m}: {a!r} vs {b!r}")
                else:
                    # The same float64 operations in the same order: equal to the bit.
                    self.assertEqual(a, b, f"{key} {m}")
        self.assertGreater(checked, 150)

    def test_energy_is_equal_to_the_bit(self):
        # Sums in sample order from +0.0 on both sides, the pose's sines
        # from the C library on both: equal, not close.
        checked = 0
        for key, ours in self.hapticlab.items():
            theirs = self.numpy[key]
            for column in ENERGY:
                a, b = number(ours[column]), number(theirs[column])
                self.assertEqual(a.hex(), b.hex(), f"{key} {column}: {a!r} vs {b!r}")
                checked += a != 0.0
        # Every hand moved and touched: most sums are not zero.
        self.assertGreater(checked, 200)

    def test_a_chunk_that_fails_its_checksum_stops_it_naming_the_chunk(self):
        # The stored CRC changed, nothing else: only the CRC-32C check can
        # see it (the frame still decompresses), and the comparator must make
        # it, as analyze does, or its speed is not that of the same work.
        damaged = self.dir / "damaged.db"
        shutil.copyfile(self.dir / "study.db", damaged)
        conn = sqlite3.connect(damaged)
        chunk_id, trial, hand, first, count, blob = conn.execute(
            "SELECT id, trial_id, instrument, first_tick, count, data FROM sample_chunk ORDER BY id LIMIT 1 OFFSET 5"
        ).fetchone()
        blob = bytearray(blob)
        blob[2] ^= 0x10
        conn.execute("UPDATE sample_chunk SET data = ? WHERE id = ?", (bytes(blob), chunk_id))
        conn.commit()
        conn.close()
        done = subprocess.run([sys.executable, str(COMPARATOR), str(damaged)], capture_output=True, text=True)
        self.assertEqual(done.returncode, 1, done.stdout + done.stderr)
        hand_name = ("left", "right")[hand]
        self.assertIn(f"damaged sample chunk: trial {trial}, {hand_name} instrument ({hand}), ticks {first}..", done.stderr)
        self.assertIn("checksum mismatch", done.stderr)

    def test_a_removed_chunk_stops_it_naming_the_ticks(self):
        # analyze leaves such a trial out (db/chunk_coverage_rules.h); the
        # comparator must see it too, or it computes numbers analyze does not.
        for which in ("DESC LIMIT 1", "LIMIT 1 OFFSET 1"):  # the last chunk; one between two
            removed = self.dir / "removed.db"
            shutil.copyfile(self.dir / "study.db", removed)
            conn = sqlite3.connect(removed)
            conn.execute("DELETE FROM sample_chunk WHERE id = (SELECT id FROM sample_chunk WHERE trial_id = 1 AND "
                         f"instrument = 1 ORDER BY first_tick {which})")
            conn.commit()
            conn.close()
            done = subprocess.run([sys.executable, str(COMPARATOR), str(removed)], capture_output=True, text=True)
            self.assertEqual(done.returncode, 1, which + done.stdout + done.stderr)
            self.assertIn("missing samples: trial 1, ", done.stderr)
            self.assertIn("(a chunk was removed)", done.stderr)

    def test_a_gap_the_writer_logged_leaves_path_length_and_energy_out_in_both(self):
        # Updates the writer could not store (a full queue) leave a gap it
        # logs as samples_missing: legitimate, so no reader refuses the file.
        # A path length or an energy would bridge it with one straight step
        # (a 1 s gap shortened a path by 1.8 %, with no note): both readers
        # leave them out of that trial and keep the rest.
        gapped = self.dir / "gapped.db"
        shutil.copyfile(self.dir / "study.db", gapped)
        conn = sqlite3.connect(gapped)
        first, count = conn.execute("SELECT first_tick, count FROM sample_chunk WHERE trial_id = 2 AND instrument = 0 "
                                    "ORDER BY first_tick LIMIT 1 OFFSET 1").fetchone()
        conn.execute("DELETE FROM sample_chunk WHERE trial_id = 2 AND first_tick = ?", (first,))
        conn.execute("INSERT INTO event (trial_id, t_s, type, instrument, item_index) "
                     "VALUES (2, ?, 'samples_missing', -1, ?)", (first / 250.0, count))
        conn.execute("UPDATE loop_timing SET dropped_samples = dropped_samples + ? WHERE trial_id = 2", (count,))
        conn.commit()
        conn.close()
        check = subprocess.run([str(fx.CLI), "study", "check", "--db", str(gapped)], capture_output=True, text=True)
        self.assertEqual(check.returncode, 0, check.stdout + check.stderr)
        out = self.dir / "gapped_analysis"
        fx.run_cli("analyze", "--db", str(gapped), "--out", str(out), "--no-ks", "--no-plots")
        ours = read_rows(out / "metrics.csv")
        done = subprocess.run([sys.executable, str(COMPARATOR), str(gapped), "--metrics-out", str(self.dir / "g.csv")],
                              capture_output=True, text=True)
        self.assertEqual(done.returncode, 0, done.stdout + done.stderr)
        theirs = read_rows(self.dir / "g.csv")
        for hand in ("0", "1"):
            row = ours[("2", hand)]
            self.assertEqual(row["path_length_m"], "", row)
            for column in ENERGY:
                self.assertEqual(row[column], "", column)
                self.assertTrue(math.isnan(number(theirs[("2", hand)][column])), column)
            self.assertTrue(math.isnan(number(theirs[("2", hand)]["path_length_m"])))
            self.assertIn(f"{count} update(s) missing from the samples", row["note"])
            self.assertIn("path length and energy left out", row["note"])
            # The rest stands on the samples there are.
            self.assertNotEqual(row["force_p95_N"], "")
            self.assertEqual(row["completion_time_s"], self.hapticlab[("2", hand)]["completion_time_s"])
        # Another trial is untouched.
        self.assertEqual(ours[("3", "0")]["path_length_m"], self.hapticlab[("3", "0")]["path_length_m"])
        self.assertIn("updates missing from its samples", (out / "report.md").read_text())

    def test_friedman_equals_hapticlab_stats(self):
        both = [r for r in self.friedman if r["instrument"] == "both" and r["measure"] in ("force_p95_N", "path_length_m")]
        self.assertEqual(len(both), 4)  # 2 tasks x 2 measures
        for measure in ("force_p95_N", "path_length_m"):
            out = fx.run_cli("stats", "friedman", "--csv", str(self.metrics_csv), "--block", "instrument", "--treatment",
                             "setting", "--replicate", "repetition", "--value", measure, "--group",
                             "participant,task", "--json")
            for group in json.loads(out)["groups"]:
                (row,) = [r for r in both if r["measure"] == measure and r["task"] == group["group"]["task"]]
                self.assertAlmostEqual(float(row["chi_square"]), group["statistic"], delta=1e-12 * group["statistic"])
                self.assertAlmostEqual(float(row["p"]), group["p"], delta=1e-12)


if __name__ == "__main__":
    unittest.main()
