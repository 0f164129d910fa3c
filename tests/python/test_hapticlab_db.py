"""python/hapticlab_db.py against the real thing: a study database from a
real session, and `hapticlab export`'s CSV of its trial. The reader must
give every channel bit for bit, list the study, and detect damage through
the CRC-32C. Run by ctest with /usr/bin/python3 (tests/python/CMakeLists.txt).
"""

import json
import os
import sqlite3
import struct
import subprocess
import unittest

import numpy as np

import study_fixture as fx
import hapticlab_db as h

STUDY = None


def setUpModule():
    global STUDY
    STUDY = fx.Study()


def tearDownModule():
    STUDY.remove()


def flip_byte(path, chunk_id, offset):
    """A stray write: one byte of a chunk blob inverted, through SQLite."""
    conn = sqlite3.connect(path)
    blob = bytearray(conn.execute("SELECT data FROM sample_chunk WHERE id = ?", (chunk_id,)).fetchone()[0])
    blob[offset] ^= 0xFF
    conn.execute("UPDATE sample_chunk SET data = ? WHERE id = ?", (bytes(blob), chunk_id))
    conn.commit()
    conn.close()


class Crc32cTest(unittest.TestCase):
    def test_standard_check_value(self):
        # CRC-32C of "123456789" (the catalogue's check value for CRC-32/ISCSI).
        self.assertEqual(h.crc32c(b"123456789"), 0xE3069283)
        self.assertEqual(h._crc32c_bytewise(b"123456789"), 0xE3069283)

    def test_vectorized_equals_bytewise_at_segment_edges(self):
        rng = np.random.default_rng(7)
        lengths = [4, 5, 17, 255, 256, 257, 511, 512, 513, 3000]
        messages = [rng.integers(0, 256, n, dtype=np.uint8).tobytes() for n in lengths]
        self.assertEqual([int(c) for c in h._crc32c_many(messages)], [h._crc32c_bytewise(m) for m in messages])

    def test_continues_like_the_cpp_one(self):
        self.assertEqual(h.crc32c(b"56789", h.crc32c(b"1234")), 0xE3069283)


class StudyListingTest(unittest.TestCase):
    def test_studies_participants_trials(self):
        with h.open_study(STUDY.db) as db:
            (study,) = db.studies()
            self.assertEqual(study["name"], "Thesis study as run, quick (2 repetitions)")
            self.assertEqual(study["seed"], "2004")
            self.assertEqual([p["code"] for p in db.participants(study["id"])], ["S1", "S2", "S3"])
            self.assertEqual(len(db.settings()), 8)
            trials = db.trials()
            self.assertEqual(len(trials), 50)  # 20 + 20 + 10 in thesis_quick.json
            (done,) = db.trials(status="complete")
            self.assertEqual((done["id"], done["participant"], done["position"]), (1, "S1", 1))
            self.assertGreater(done["chunks"], 2)
            self.assertEqual(len(db.trials(participant="S3")), 10)

    def test_what_the_file_does_not_have_is_refused_not_an_empty_list(self):
        # An empty list reads as "no such trials" or, from check_chunks,
        # "no damage": for a misspelt status or code, or a trial the file
        # does not have, that is wrong; each raises, naming it.
        with h.open_study(STUDY.db) as db:
            with self.assertRaisesRegex(ValueError, "status is 'completed'; it must be one of planned, running"):
                db.trials(status="completed")
            with self.assertRaisesRegex(KeyError, "no participant 's1'; the codes are S1, S2, S3"):
                db.trials(participant="s1")
            with self.assertRaisesRegex(KeyError, "no study 99"):
                db.trials(study_id=99)
            for call in (db.events, db.check_chunks, db.samples):
                with self.assertRaisesRegex(KeyError, "no trial 999"):
                    call(999)
            with self.assertRaisesRegex(ValueError, "instrument is True"):
                db.samples(1, instrument=True)
            self.assertEqual(db.check_chunks(1), [])  # a trial it has: no damage

    def test_opened_read_only(self):
        with h.open_study(STUDY.db) as db:
            with self.assertRaisesRegex(sqlite3.OperationalError, "readonly"):
                db.connection.execute("DELETE FROM event")


class OperatorActionsTest(unittest.TestCase):
    def test_the_consoles_actions_with_participant_and_trial(self):
        path = os.path.join(STUDY.dir, "actions.db")
        import shutil
        shutil.copyfile(STUDY.db, path)
        conn = sqlite3.connect(path)
        session = conn.execute("SELECT id FROM session LIMIT 1").fetchone()[0]
        conn.execute("INSERT INTO operator_action (session_id, trial_id, unix_s, t_s, type, detail) "
                     "VALUES (?, 1, 1.5e9, 0.25, 'operator_note', 'chair')", (session,))
        conn.execute("INSERT INTO operator_action (unix_s, type, detail) VALUES (1.6e9, 'operator_stop', 'nothing')")
        conn.commit()
        conn.close()
        with h.open_study(path) as db:
            note, stop = db.operator_actions()
            self.assertEqual((note["participant"], note["trial_id"], note["t_s"], note["type"], note["detail"]),
                             ("S1", 1, 0.25, "operator_note", "chair"))
            self.assertEqual((stop["session_id"], stop["participant"], stop["trial_id"]), (None, None, None))
            self.assertEqual([a["type"] for a in db.operator_actions(participant="S1")], ["operator_note"])


class SamplesEqualExportTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.header, cls.csv = fx.read_export(STUDY.samples_csv)
        with h.open_study(STUDY.db) as db:
            cls.samples = db.samples(1)
            cls.left = db.samples(1, instrument=0)

    def test_same_columns_as_the_export(self):
        channels = self.header[len(fx.KEY_COLUMNS):]
        self.assertEqual(list(h.CHANNEL_NAMES), channels)
        self.assertEqual(list(self.samples.dtype.names), ["trial_id", "instrument", "tick"] + channels)

    def test_every_channel_bit_for_bit(self):
        n = len(self.csv["tick"])
        self.assertGreater(n, 1000, "the trial must have stored samples")
        self.assertEqual(self.samples.size, n)
        for name in ("trial_id", "instrument", "tick"):
            want = np.array([int(t) for t in self.csv[name]])
            self.assertTrue(np.array_equal(self.samples[name].astype(np.int64), want), name)
        for name, code in h.CHANNELS:
            kind = np.dtype(code)
            text = self.csv[name]
            if kind == np.float64:
                want = fx.parse_float64(text)
            elif kind == np.float32:
                want = fx.parse_float32(text)
            else:
                want = np.array([int(t) for t in text]).astype(kind.newbyteorder("="))
            got = self.samples[name]
            self.assertTrue(fx.same_bits(got, want), f"{name}: {fx.first_difference(got, want)}")

    def test_one_instrument_is_the_exports_rows_of_it(self):
        rows = [i for i, k in enumerate(self.csv["instrument"]) if k == "0"]
        self.assertEqual(self.left.size, len(rows))
        self.assertTrue(np.all(self.left["instrument"] == 0))
        want = fx.parse_float32([self.csv["tip_x_m"][i] for i in rows])
        self.assertTrue(fx.same_bits(self.left["tip_x_m"], want))
        self.assertTrue(fx.same_bits(self.left["t_s"], fx.parse_float64([self.csv["t_s"][i] for i in rows])))

    def test_dict_and_dataframe_forms(self):
        with h.open_study(STUDY.db) as db:
            d = db.samples_dict(1)
            self.assertTrue(fx.same_bits(d["ve_force_z_N"], self.samples["ve_force_z_N"]))
            try:
                import pandas  # noqa: F401  (optional)
            except ImportError:
                with self.assertRaises(ImportError):
                    db.to_dataframe(1)
                return
            frame = db.to_dataframe(1)
            self.assertEqual(list(frame.columns), list(self.samples.dtype.names))
            self.assertEqual(len(frame), self.samples.size)


class WallClockSamplesTest(unittest.TestCase):
    """A trial on the wall clock: every dt_s differs, so format 3 stores dt
    per update as differences in bit planes (on the virtual clock it is one
    constant); the reader must give the export's values to the bit."""

    def test_times_and_periods_bit_for_bit(self):
        d = STUDY.dir / "wall"
        d.mkdir()
        db = d / "wall.db"
        # The loop's timing is not what this test is about: on a loaded CI
        # machine a trial may lose its rate (rate_violation) or trip the
        # watchdog, and three such trips end the session (exit 3). The widest
        # rate tolerance, three tries, and the longest trial kept is read.
        source = fx.SOURCE_DIR / "examples/protocols/thesis_quick.json"
        protocol = json.loads(source.read_text())
        protocol["settings"] = [str((source.parent / s).resolve()) for s in protocol["settings"]]
        protocol["rate_tolerance_fraction"] = 0.5
        (d / "wall.json").write_text(json.dumps(protocol))
        fx.run_cli("study", "create", "--protocol", str(d / "wall.json"), "--db", str(db))
        # 1.5 s of real time, then the time limit (the samples are kept).
        run = subprocess.run([fx.CLI, "session", "run", "--db", str(db), "--participant", "S1", "--training-trials",
                              "0", "--max-trials", "3", "--clock", "wall", "--max-trial-s", "1.5"],
                             capture_output=True, text=True)
        self.assertIn(run.returncode, (0, 3), run.stdout + run.stderr)
        conn = sqlite3.connect(db)
        (trial,) = conn.execute("SELECT trial_id FROM sample_chunk WHERE instrument = 0 GROUP BY trial_id "
                                "ORDER BY sum(count) DESC, trial_id LIMIT 1").fetchone()
        conn.close()
        fx.run_cli("export", "--db", str(db), "--trial", str(trial), "--format", "csv", "--out", str(d / "csv"))
        (samples_csv,) = (d / "csv").glob("*_samples.csv")
        _, csv = fx.read_export(samples_csv)
        with h.open_study(db) as study:
            got = study.samples(trial, instrument=0)
        rows = [i for i, k in enumerate(csv["instrument"]) if k == "0"]
        self.assertGreater(len(rows), 300, "no trial kept 0.3 s of samples")
        for name in ("t_s", "dt_s"):
            want = fx.parse_float64([csv[name][i] for i in rows])
            self.assertTrue(fx.same_bits(got[name], want), f"{name}: {fx.first_difference(got[name], want)}")
        self.assertGreater(np.unique(got["dt_s"]).size, 100, "dt is (nearly) constant: the per-update path is untested")


class DamageTest(unittest.TestCase):
    def chunk(self, path, instrument, offset_rows):
        conn = sqlite3.connect(path)
        row = conn.execute("SELECT id, first_tick, count FROM sample_chunk WHERE trial_id = 1 AND instrument = ? "
                           "ORDER BY first_tick LIMIT 1 OFFSET ?", (instrument, offset_rows)).fetchone()
        conn.close()
        return row

    def test_a_flipped_byte_is_a_checksum_error_naming_the_chunk(self):
        path = STUDY.copy("flipped.db")
        chunk_id, first, count = self.chunk(path, 1, 1)
        flip_byte(path, chunk_id, 40)
        with h.open_study(path) as db:
            with self.assertRaises(h.ChunkError) as caught:
                db.samples(1)
            e = caught.exception
            self.assertEqual((e.kind, e.trial_id, e.instrument, e.first_tick, e.count), ("checksum", 1, 1, first, count))
            self.assertIn(f"damaged sample chunk: trial 1, right instrument (1), ticks {first}..{first + count - 1}: "
                          "checksum mismatch", str(e))
            # The other instrument still reads; the check lists exactly the one chunk.
            self.assertGreater(db.samples(1, instrument=0).size, 1000)
            (bad,) = db.check_chunks()
            self.assertEqual((bad.trial_id, bad.instrument, bad.first_tick), (1, 1, first))

    def test_a_removed_chunk_is_named_not_read_as_a_shorter_trial(self):
        path = STUDY.copy("removed.db")
        chunk_id, first, count = self.chunk(path, 0, 1)  # between two others
        conn = sqlite3.connect(path)
        conn.execute("DELETE FROM sample_chunk WHERE id = ?", (chunk_id,))
        conn.commit()
        conn.close()
        with h.open_study(path) as db:
            with self.assertRaises(h.ChunkError) as caught:
                db.samples(1, instrument=0)
            e = caught.exception
            self.assertEqual((e.kind, e.instrument, e.first_tick, e.count), ("placement", 0, first, count))
            self.assertIn("no samples_missing event accounts for them", str(e))
            self.assertGreater(db.samples(1, instrument=1).size, 1000)  # the other hand's updates are all there
            (bad,) = db.check_chunks()
            self.assertEqual((bad.trial_id, bad.instrument, bad.first_tick), (1, 0, first))
        # The last chunk removed: the loop's count says the trial was longer.
        path = STUDY.copy("removed_last.db")
        conn = sqlite3.connect(path)
        last, = conn.execute("SELECT max(first_tick) FROM sample_chunk WHERE trial_id = 1 AND instrument = 1").fetchone()
        conn.execute("DELETE FROM sample_chunk WHERE trial_id = 1 AND instrument = 1 AND first_tick = ?", (last,))
        conn.commit()
        conn.close()
        with h.open_study(path) as db:
            with self.assertRaises(h.ChunkError) as caught:
                db.samples(1)
            self.assertEqual((caught.exception.instrument, caught.exception.first_tick), (1, last))
            self.assertIn("the loop ran", str(caught.exception))

    def test_a_damaged_format_byte_or_moved_chunk_is_damage_too(self):
        path = STUDY.copy("format.db")
        chunk_id, first, count = self.chunk(path, 0, 0)
        flip_byte(path, chunk_id, 0)  # format 3 -> 0xFC: damage, not "a newer format"
        with h.open_study(path) as db:
            with self.assertRaises(h.ChunkError) as caught:
                db.samples(1, instrument=0)
            self.assertEqual(caught.exception.kind, "checksum")
        path = STUDY.copy("moved.db")
        chunk_id, first, count = self.chunk(path, 0, 1)
        conn = sqlite3.connect(path)
        # first_tick is in the checksum: a chunk shifted in time is caught.
        conn.execute("UPDATE sample_chunk SET first_tick = first_tick + 100000 WHERE id = ?", (chunk_id,))
        conn.commit()
        conn.close()
        with h.open_study(path) as db:
            with self.assertRaises(h.ChunkError):
                db.samples(1)
            # Its checksum fails where it now claims to be, and its ticks are missing where it was.
            found = {(e.kind, e.first_tick) for e in db.check_chunks()}
            self.assertIn(("checksum", first + 100000), found)
            self.assertIn(("placement", first), found)

    def test_a_migrated_chunk_decodes_and_an_unknown_format_is_named(self):
        with h.open_study(STUDY.db) as db:
            cid, trial, hand, first, count, blob = db.connection.execute(
                "SELECT id, trial_id, instrument, first_tick, count, data FROM sample_chunk WHERE trial_id = 1 "
                "ORDER BY id LIMIT 1").fetchone()
        self.assertEqual(blob[0], h.FORMAT_CURRENT)
        current = h.decode_chunk(trial, hand, first, count, blob)

        def signed(fmt, body):
            crc = h.crc32c(struct.pack("<QQQQ", trial, hand, first, count) + bytes([fmt]) + body)
            return bytes([fmt]) + struct.pack("<I", crc) + body

        # Format 1: the same body uncompressed (the frame decompressed and its
        # differences summed), as HapticLab wrote it before format 2.
        body = h._unprecondition(h._decompress(blob[h.HEADER_BYTES:], count), count)
        self.assertGreater(len(body), 2 * len(blob))
        plain = h.decode_chunk(trial, hand, first, count, signed(1, body))
        for name in current:
            self.assertTrue(fx.same_bits(current[name], plain[name]), name)
        # Format 0 (db/README.md, "Damage"): the pre-version-4 blob (byte 1,
        # then the body) behind a header whose checksum the migrations made.
        migrated = h.decode_chunk(trial, hand, first, count, signed(0, b"\x01" + body))
        for name in current:
            self.assertTrue(fx.same_bits(current[name], migrated[name]), name)
        # A format from a newer HapticLab, correctly checksummed, is named as such.
        with self.assertRaisesRegex(h.ChunkError, "chunk format 4 is not one this reader reads") as caught:
            h.decode_chunk(trial, hand, first, count, signed(4, body))
        self.assertEqual(caught.exception.kind, "format")
        # The checksum covers where the chunk belongs: another trial or the
        # other instrument does not verify.
        for place in ((trial + 1, hand), (trial, 1 - hand)):
            with self.assertRaisesRegex(h.ChunkError, "checksum mismatch"):
                h.verify_chunk(*place, first, count, blob)

    def test_an_old_schema_is_refused_with_what_to_do(self):
        path = STUDY.copy("old.db")
        conn = sqlite3.connect(path)
        conn.execute("PRAGMA user_version = 6")
        conn.close()
        with self.assertRaisesRegex(ValueError, "schema version 6; this reader reads version 11.*hapticlab analyze"):
            h.open_study(path)


class FrameTest(unittest.TestCase):
    """The zstd frame is checked as the C++ decoder checks it, before
    anything is allocated for it."""

    def setUp(self):
        import zstandard
        self.zstd = zstandard
        with h.open_study(STUDY.db) as db:
            self.trial, self.hand, self.first, self.count, self.blob = db.connection.execute(
                "SELECT trial_id, instrument, first_tick, count, data FROM sample_chunk WHERE trial_id = 1 "
                "ORDER BY id LIMIT 1").fetchone()
        self.frame = bytes(self.blob[h.HEADER_BYTES:])
        self.body = self.zstd.ZstdDecompressor().decompress(self.frame)

    def signed(self, frame, fmt=h.FORMAT_CURRENT):
        crc = h.crc32c(struct.pack("<QQQQ", self.trial, self.hand, self.first, self.count) + bytes([fmt]) + frame)
        return bytes([fmt]) + struct.pack("<I", crc) + frame

    def decode(self, frame):
        return h.decode_chunk(self.trial, self.hand, self.first, self.count, self.signed(frame))

    def test_a_bomb_is_refused_before_it_is_decompressed(self):
        import resource
        # 512 MiB of zeros in a frame of a few kB, stated in its header, for
        # a chunk of `count` updates (at most 28 + 117 * count bytes).
        zeros = bytes(1 << 20)
        writer = self.zstd.ZstdCompressor(level=1, write_checksum=True).compressobj(size=512 << 20)
        bomb = b"".join(writer.compress(zeros) for _ in range(512)) + writer.flush()
        self.assertLess(len(bomb), 64 << 10)
        before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        with self.assertRaisesRegex(h.ChunkError, "the zstd frame's header states 536870912 bytes, more than the"):
            self.decode(bomb)
        grown_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
        self.assertLess(grown_kb, 64 << 10, "the reader held the bomb's content")

    def test_a_frame_followed_by_another_or_without_checksum_is_refused(self):
        self.assertEqual(self.decode(self.frame)["tick"].size, self.count)
        second = self.zstd.ZstdCompressor(write_checksum=True).compress(b"")
        with self.assertRaisesRegex(h.ChunkError, "bytes follow the zstd frame"):
            self.decode(self.frame + second)
        with self.assertRaisesRegex(h.ChunkError, "carries no content checksum"):
            self.decode(self.zstd.ZstdCompressor(level=1, write_checksum=False).compress(self.body))
        # A byte changed inside the frame, with the chunk's CRC recomputed:
        # the frame's content checksum (or the decoder) refuses it, or the
        # byte was one zstd ignores and the values are the same.
        want = self.decode(self.frame)
        refused = 0
        for i in range(4, len(self.frame), max(1, len(self.frame) // 40)):
            bad = bytearray(self.frame)
            bad[i] ^= 0x10
            try:
                got = self.decode(bytes(bad))
            except h.ChunkError as e:
                self.assertEqual(e.kind, "structure")
                refused += 1
                continue
            for name in want:
                self.assertTrue(fx.same_bits(got[name], want[name]), f"byte {i}: {name} decoded to other values")
        self.assertGreater(refused, 30)

    def test_a_null_or_text_chunk_is_named(self):
        for value, kind in ((None, "NULL"), ("not a blob", "str")):
            with self.assertRaisesRegex(h.ChunkError, f"its data is {kind}, not a BLOB"):
                h.decode_chunk(self.trial, self.hand, self.first, self.count, value)
        path = STUDY.copy("text_chunk.db")
        conn = sqlite3.connect(path)
        conn.execute("UPDATE sample_chunk SET data = 'not a blob' WHERE trial_id = 1 AND instrument = 1 "
                     "AND first_tick = 0")
        conn.commit()
        conn.close()
        with self.assertRaisesRegex(h.StructureError, "sample_chunk row [0-9]+ of trial 1: data is text 'not a blob', "
                                                      "expected a BLOB"):
            h.open_study(path)


class ValueRulesTest(unittest.TestCase):
    """The schema's CHECKs (not checked by SQLite's integrity_check on a
    read-only connection) and the references that exist but do not fit, as
    `hapticlab study check` finds them."""

    def test_the_rules_are_the_schemas_checks(self):
        conn = sqlite3.connect(STUDY.db)
        found = set()
        for table, sql in conn.execute("SELECT name, sql FROM sqlite_schema WHERE type = 'table'"):
            at = sql.find("CHECK")
            while at >= 0:
                i = sql.index("(", at) + 1
                depth, j = 1, i
                while depth:
                    depth += {"(": 1, ")": -1}.get(sql[j], 0)
                    j += 1
                found.add((table, sql[i:j - 1]))
                at = sql.find("CHECK", j)
        conn.close()
        listed = {(t, c) for t, _, c in h.VALUE_RULES}
        # sample_chunk's are checked chunk by chunk (_layout), not here.
        self.assertEqual(listed, {f for f in found if f[0] != "sample_chunk"})

    def test_an_edited_file_is_refused_naming_each_row(self):
        path = STUDY.copy("edited.db")
        conn = sqlite3.connect(path)
        conn.execute("PRAGMA ignore_check_constraints = ON")
        conn.execute("UPDATE session SET clock = 'bogus'")
        conn.execute("UPDATE trial SET task = 'foo' WHERE id = 1")
        conn.commit()
        conn.close()
        with self.assertRaises(h.StructureError) as caught:
            h.open_study(path)
        self.assertIn("session row 1: clock is 'bogus', which breaks CHECK (clock IN ('virtual', 'wall'))",
                      str(caught.exception))
        self.assertIn("trial 1: task 'foo' is not one of its study's protocol's tasks", str(caught.exception))

    def test_a_status_at_odds_with_what_the_trial_holds_is_refused_as_study_check_says(self):
        """A trial edited back to planned keeps its session, times, samples
        and events; the finding is word for word `hapticlab study check`'s."""
        path = STUDY.copy("status_misfit.db")
        conn = sqlite3.connect(path)
        conn.execute("UPDATE trial SET status = 'planned' WHERE id = 1")
        conn.commit()
        conn.close()
        with self.assertRaises(h.StructureError) as caught:
            h.open_study(path)
        self.assertIn("trial 1: status is 'planned', but it has session_id 1, started_unix_s ", str(caught.exception))
        done = subprocess.run([fx.CLI, "study", "check", "--db", path], capture_output=True, text=True)
        self.assertEqual(done.returncode, 1, done.stdout + done.stderr)
        (line,) = [l.strip() for l in done.stdout.splitlines() if l.strip().startswith("trial 1: status")]
        self.assertIn(line, str(caught.exception))

    def test_an_edited_setting_or_protocol_is_refused_naming_it(self):
        """What a session configures its engine with, and the schedule's
        source, against the digests `study create` stored (schema 11)."""
        path = STUDY.copy("edited_definitions.db")
        conn = sqlite3.connect(path)
        name, = conn.execute("SELECT name FROM setting WHERE id = 1").fetchone()
        conn.execute("UPDATE setting SET parameters_json = parameters_json || ' ' WHERE id = 1")
        conn.execute("UPDATE study SET protocol_json = protocol_json || ' '")
        conn.commit()
        conn.close()
        with self.assertRaises(h.StructureError) as caught:
            h.open_study(path)
        self.assertIn(f"setting '{name}' (id 1): its parameters_json does not match the SHA-256 stored with "
                      f"it", str(caught.exception))
        self.assertIn("study 1: its protocol_json does not match the SHA-256 stored", str(caught.exception))
        with h.open_study(STUDY.db) as clean:
            self.assertEqual(clean.check_structure(), [])

    def test_a_setting_without_digest_or_not_utf8_is_a_finding_not_an_error(self):
        path = STUDY.copy("digest_cases.db")
        conn = sqlite3.connect(path)
        conn.execute("UPDATE setting SET parameters_sha256 = '' WHERE id = 1")
        # Bytes that are not UTF-8: damage, hashed as stored, never a decoding error.
        conn.execute("UPDATE setting SET parameters_json = CAST(x'7b22ff227d' AS TEXT) WHERE id = 2")
        conn.commit()
        conn.close()
        with self.assertRaises(h.StructureError) as caught:
            h.open_study(path)
        self.assertIn("(id 1): no SHA-256 is stored with its parameters_json: it was written by a HapticLab older "
                      "than schema version 11", str(caught.exception))
        self.assertIn("(id 2): its parameters_json does not match the SHA-256 stored with it", str(caught.exception))


if __name__ == "__main__":
    unittest.main(verbosity=2)
