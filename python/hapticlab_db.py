"""Read a HapticLab study database from Python: studies, participants,
trials, and every sample of a trial as numpy arrays.

Pure Python and numpy (pandas optional, for ``to_dataframe``; the
``zstandard`` module, Debian ``python3-zstandard``, for the compressed
chunks HapticLab writes since format 2). The sample
chunk format is implemented here from its documentation (``db/README.md``,
``db/sample_codec.h``), not by calling HapticLab's C++ code, so a lab can
read its data with nothing but this file. The file is opened read-only
(SQLite URI ``mode=ro``): reading never changes it.

    import hapticlab_db
    with hapticlab_db.open_study("study.db") as db:
        for trial in db.trials(status="complete"):
            s = db.samples(trial["id"], instrument=1)   # right hand
            print(trial["setting"], s["tick"].size, s["ve_force_z_N"].max())

``samples()`` returns a numpy structured array: one record per stored
update, fields ``trial_id``, ``instrument``, ``tick`` and then the channels
in the order and with the names of ``hapticlab export``'s samples CSV
(``CHANNELS``), in the same row order (by tick, left before right within a
tick). Values are the stored ones, bit for bit: ``dt_s`` and ``t_s`` as
float64, the physical channels as float32 (the codec stores float32; use
``.astype(float)`` before arithmetic that needs float64), ``engine_status``
uint32, ``device_status`` int32, ``in_contact`` uint8 (0/1).

Every chunk's CRC-32C is checked before it is decoded; a damaged chunk
raises ``ChunkError`` naming trial, instrument and ticks (as ``hapticlab
export`` and ``hapticlab study check`` do), never returns wrong numbers.
"""

import sqlite3
import struct
import urllib.parse

import numpy as np

__all__ = [
    "CHANNELS", "ChunkError", "StudyDatabase", "open_study", "decode_chunk", "verify_chunk", "crc32c",
    "SCHEMA_VERSION",
]

# The schemas whose chunks this module reads: the 5-byte chunk header exists
# from version 4 on, unchanged up to db/schema.h's kSchemaVersion (version 5
# added the device_counter table, 6 the operator_action table).
OLDEST_SCHEMA_VERSION = 4
SCHEMA_VERSION = 6
APPLICATION_ID = 0x484C4142  # "HLAB"

# Chunk formats (byte 0 of the blob).
FORMAT_MIGRATED = 0  # written before schema 4, checksummed by the migration
FORMAT_PLAIN = 1     # the uncompressed body
FORMAT_CURRENT = 2   # the plain body preconditioned and zstd-compressed
HEADER_BYTES = 5
MAX_CHUNK_UPDATES = 1 << 20

# The channels in blob order, which is also the CSV column order, and how
# each is stored (little-endian). Must match db/sample_codec.cc kChannelNames.
CHANNELS = (
    ("dt_s", "<f8"), ("t_s", "<f8"),
    ("raw_insertion_m", "<f4"), ("raw_pitch_rad", "<f4"), ("raw_yaw_rad", "<f4"),
    ("raw_twist_rad", "<f4"), ("raw_grip_rad", "<f4"),
    ("degraded_insertion_m", "<f4"), ("degraded_pitch_rad", "<f4"), ("degraded_yaw_rad", "<f4"),
    ("tip_x_m", "<f4"), ("tip_y_m", "<f4"), ("tip_z_m", "<f4"),
    ("tip_vx_m_per_s", "<f4"), ("tip_vy_m_per_s", "<f4"), ("tip_vz_m_per_s", "<f4"),
    ("ve_force_x_N", "<f4"), ("ve_force_y_N", "<f4"), ("ve_force_z_N", "<f4"),
    ("displayed_force_x_N", "<f4"), ("displayed_force_y_N", "<f4"), ("displayed_force_z_N", "<f4"),
    ("insertion_force_N", "<f4"), ("pitch_torque_Nm", "<f4"), ("yaw_torque_Nm", "<f4"),
    ("engine_status", "<u4"), ("device_status", "<i4"), ("in_contact", "u1"),
)
CHANNEL_NAMES = tuple(name for name, _ in CHANNELS)

# Per-channel tags in the body.
TAG_PER_UPDATE = 0  # `count` values follow
TAG_CONSTANT = 1    # one value, the same for every update
TAG_RUNNING_SUM = 2  # t_s only: t[0]; then t[i] = t[i-1] + dt[i] in float64

SAMPLE_DTYPE = np.dtype([("trial_id", "<i8"), ("instrument", "u1"), ("tick", "<u8")]
                        + [(name, np.dtype(code).newbyteorder("=")) for name, code in CHANNELS])

INSTRUMENT_NAMES = {0: "left", 1: "right"}


class ChunkError(ValueError):
    """A stored chunk that cannot be used: ``kind`` is "checksum",
    "format" (written by a newer HapticLab) or "structure". When raised
    by ``StudyDatabase``, ``trial_id``, ``instrument``, ``first_tick`` and
    ``count`` name the chunk."""

    def __init__(self, kind, problem, trial_id=None, instrument=None, first_tick=None, count=None):
        self.kind = kind
        self.problem = problem
        self.trial_id = trial_id
        self.instrument = instrument
        self.first_tick = first_tick
        self.count = count
        super().__init__(self._message())

    def _message(self):
        if self.trial_id is None:
            return self.problem
        ticks = str(self.first_tick)
        if self.count is not None and self.count > 1:
            ticks += f"..{self.first_tick + self.count - 1}"
        hand = INSTRUMENT_NAMES.get(self.instrument, "unknown")
        return (f"damaged sample chunk: trial {self.trial_id}, {hand} instrument ({self.instrument}), "
                f"ticks {ticks}: {self.problem}")

    def located(self, trial_id, instrument, first_tick, count):
        return ChunkError(self.kind, self.problem, trial_id, instrument, first_tick, count)


# --- CRC-32C (Castagnoli, reflected polynomial 0x82F63B78) ------------------

_POLY = 0x82F63B78


def _make_table():
    table = np.zeros(256, dtype=np.uint32)
    for i in range(256):
        r = i
        for _ in range(8):
            r = (r >> 1) ^ (_POLY if r & 1 else 0)
        table[i] = r
    return table


_TABLE = _make_table()
_TABLE_LIST = [int(v) for v in _TABLE]
# Messages are cut into segments of this many bytes, all CRC'd at once.
_SEGMENT = 256


def _zero_shift_tables(nbytes):
    """Four 256-entry tables giving the register after `nbytes` zero bytes
    are fed in, for each byte of the register (the operator is linear, so
    the four lookups XORed together give it for any register value)."""
    regs = (np.arange(256, dtype=np.uint32)[None, :] << (8 * np.arange(4, dtype=np.uint32))[:, None]).ravel()
    for _ in range(nbytes):
        regs = _TABLE[regs & 0xFF] ^ (regs >> 8)
    return regs.reshape(4, 256)


_SHIFT = _zero_shift_tables(_SEGMENT)


def _crc32c_bytewise(data, crc=0):
    c = crc ^ 0xFFFFFFFF
    table = _TABLE_LIST
    for b in data:
        c = table[(c ^ b) & 0xFF] ^ (c >> 8)
    return c ^ 0xFFFFFFFF


def _crc32c_many(messages):
    """The CRC-32C of each of `messages` (bytes-like, at least 4 bytes each),
    computed with numpy over all of them at once.

    CRC arithmetic is linear over GF(2). With register r, feeding bytes
    m gives raw(r, m) = Z^len(m) r XOR raw(0, m), where Z feeds one zero
    byte. Three consequences are used:
    - the initial register 0xFFFFFFFF equals XORing 0xFF into the first four
      message bytes and starting from 0;
    - from register 0, leading zero bytes change nothing, so each message is
      padded in front to a whole number of segments;
    - every segment's raw(0, segment) is computed in parallel (one numpy step
      per byte position), then each message's segments are chained with
      r = Z^SEGMENT r XOR raw(0, segment), Z^SEGMENT applied by table lookups.
    """
    n = len(messages)
    if n == 0:
        return np.zeros(0, dtype=np.uint32)
    lengths = np.fromiter((len(m) for m in messages), dtype=np.int64, count=n)
    if lengths.min() < 4:
        raise ValueError("messages shorter than 4 bytes")
    segments = (lengths + _SEGMENT - 1) // _SEGMENT
    padded = segments * _SEGMENT
    starts = np.concatenate(([0], np.cumsum(padded)[:-1]))
    buf = np.zeros(int(padded.sum()), dtype=np.uint8)
    for m, start, pad, length in zip(messages, starts, padded - lengths, lengths):
        at = int(start + pad)
        buf[at:at + int(length)] = np.frombuffer(m, dtype=np.uint8)
        buf[at:at + 4] ^= 0xFF
    seg = buf.reshape(-1, _SEGMENT)
    # raw(0, segment) for all segments: one step per byte position.
    r = np.zeros(seg.shape[0], dtype=np.uint32)
    for k in range(_SEGMENT):
        r = _TABLE[(r ^ seg[:, k]) & 0xFF] ^ (r >> 8)
    # Chain each message's segments, right-aligned so that every message
    # ends at the last step (leading empty segments keep register 0).
    most = int(segments.max())
    first_seg = np.concatenate(([0], np.cumsum(segments)[:-1]))
    crc = np.zeros(n, dtype=np.uint32)
    for j in range(most):
        index = first_seg + j - (most - segments)  # this message's segment at step j
        have = index >= first_seg
        c = np.where(have, r[np.where(have, index, 0)], 0).astype(np.uint32)
        crc = (_SHIFT[0][crc & 0xFF] ^ _SHIFT[1][(crc >> 8) & 0xFF] ^ _SHIFT[2][(crc >> 16) & 0xFF]
               ^ _SHIFT[3][crc >> 24] ^ c)
    return crc ^ np.uint32(0xFFFFFFFF)


def crc32c(data, crc=0):
    """CRC-32C of `data`, continuing from `crc` (0 to start), like
    db/sample_codec.h crc32c(): crc32c(b, crc32c(a)) == crc32c(a + b)."""
    data = bytes(data)
    if crc != 0 or len(data) < 4:
        return _crc32c_bytewise(data, crc)
    return int(_crc32c_many([data])[0])


# --- chunks -----------------------------------------------------------------

def _checked_message(first_tick, count, blob):
    """The bytes the chunk's checksum covers: first_tick and count as 8-byte
    little-endian integers (the row's columns), the format byte, the body."""
    return struct.pack("<QQ", first_tick & 0xFFFFFFFFFFFFFFFF, count & 0xFFFFFFFFFFFFFFFF) + bytes(blob[:1]) + \
        bytes(blob[HEADER_BYTES:])


def _check_header(blob, computed):
    stored = struct.unpack_from("<I", blob, 1)[0]
    if stored != computed:
        raise ChunkError("checksum", f"checksum mismatch (stored CRC-32C 0x{stored:08x}, the data gives "
                                     f"0x{computed:08x}): the chunk is damaged")
    fmt = blob[0]
    if fmt not in (FORMAT_MIGRATED, FORMAT_PLAIN, FORMAT_CURRENT):
        raise ChunkError("format", f"chunk format {fmt} is not one this reader reads "
                                   f"({FORMAT_MIGRATED}, {FORMAT_PLAIN}, {FORMAT_CURRENT}); it was written by a "
                                   f"newer HapticLab")
    return fmt


def verify_chunk(first_tick, count, blob):
    """Checks a chunk's header and CRC-32C without decoding; returns its
    format. Raises ChunkError (a checksum mismatch before an unknown
    format: a damaged format byte is damage)."""
    if len(blob) < HEADER_BYTES:
        raise ChunkError("structure", f"{len(blob)}-byte blob, shorter than the {HEADER_BYTES}-byte header")
    return _check_header(blob, crc32c(_checked_message(first_tick, count, blob)))


_zstd = None


def _decompress(frame, count):
    """Format 2's zstd frame -> the preconditioned body (bytes)."""
    global _zstd
    if _zstd is None:
        try:
            import zstandard
        except ImportError:
            raise ImportError("chunk format 2 (zstd) needs the zstandard module: apt install python3-zstandard "
                              "(or pip install zstandard)") from None
        _zstd = zstandard.ZstdDecompressor()
    # At most every channel per update behind its tag (db/sample_codec.cc).
    limit = len(CHANNELS) + count * sum(np.dtype(code).itemsize for _, code in CHANNELS)
    try:
        return _zstd.decompress(frame, max_output_size=limit)
    except Exception as e:  # zstandard.ZstdError
        raise ChunkError("structure", f"the zstd frame does not decompress: {e}") from None


def _from_bit_planes(raw, count, width):
    """Bit planes (db/sample_codec.cc shuffle()) -> values as unsigned ints:
    the first count - count % 8 values as 8 * width planes (plane k: bit
    k % 8 of byte k // 8 of each value, value i at bit i % 8 of byte i // 8),
    then the last count % 8 values as they are."""
    whole = count - count % 8
    planes = np.frombuffer(raw, dtype=np.uint8, count=whole * width).reshape(8 * width, whole // 8)
    bits = np.unpackbits(planes, axis=1, bitorder="little")          # (8 * width, whole)
    head = np.packbits(np.ascontiguousarray(bits.T), axis=1, bitorder="little")  # (whole, width)
    data = head.tobytes() + bytes(raw[whole * width:count * width])
    return np.frombuffer(data, dtype="<u%d" % width).copy()


def _unprecondition(body, count):
    """Undoes format 2's preconditioning (db/sample_codec.h): every channel
    stored per update with 4- or 8-byte values is bit planes of the
    differences of consecutive bit patterns; when t_s is stored per update
    too, dt_s is bit planes of dt's bits XOR those of t's differences.
    Returns the format-1 body."""
    out = bytearray(body)
    pos = 0
    places = {}
    for name, code in CHANNELS:
        if pos >= len(out):
            raise ChunkError("structure", "blob too short for its count")
        tag = out[pos]
        pos += 1
        width = np.dtype(code).itemsize
        if tag != TAG_PER_UPDATE:
            pos += width
            continue
        if pos + count * width > len(out):
            raise ChunkError("structure", "blob too short for its count")
        places[name] = pos
        pos += count * width
    residual_dt = "dt_s" in places and "t_s" in places
    for name, code in CHANNELS:
        width = np.dtype(code).itemsize
        if name not in places or width == 1:
            continue
        at = places[name]
        values = _from_bit_planes(out[at:at + count * width], count, width)
        if not (name == "dt_s" and residual_dt):
            # Unsigned sums wrap modulo 2^32 / 2^64, as the encoder's differences did.
            values = np.cumsum(values, dtype=values.dtype)
        out[at:at + count * width] = values.tobytes()
    if residual_dt:
        t = np.frombuffer(bytes(out[places["t_s"]:places["t_s"] + 8 * count]), dtype="<f8")
        at = places["dt_s"]
        dt = np.frombuffer(bytes(out[at:at + 8 * count]), dtype="<u8").copy()
        dt[1:] ^= (t[1:] - t[:-1]).view("<u8")
        out[at:at + 8 * count] = dt.tobytes()
    return bytes(out)


def _decode_body(blob, fmt, count):
    """The channels of a verified chunk as a dict name -> array of `count`."""
    pos = HEADER_BYTES
    size = len(blob)

    def take(nbytes):
        nonlocal pos
        if pos + nbytes > size:
            raise ChunkError("structure", "blob too short for its count")
        start = pos
        pos += nbytes
        return start

    if fmt == FORMAT_CURRENT:
        plain = _unprecondition(_decompress(bytes(blob[HEADER_BYTES:]), count), count)
        blob = bytes(HEADER_BYTES) + plain
        size = len(blob)
    if fmt == FORMAT_MIGRATED:
        # The old blob whole, its own format byte (1) first.
        legacy = blob[take(1)]
        if legacy != 1:
            raise ChunkError("structure", f"migrated chunk starts with format {legacy}, expected 1")
    out = {}
    for name, code in CHANNELS:
        dtype = np.dtype(code)
        tag = blob[take(1)]
        if tag == TAG_PER_UPDATE:
            values = np.frombuffer(blob, dtype=dtype, count=count, offset=take(count * dtype.itemsize))
        elif tag == TAG_CONSTANT:
            values = np.full(count, np.frombuffer(blob, dtype=dtype, count=1, offset=take(dtype.itemsize))[0])
        elif tag == TAG_RUNNING_SUM and name == "t_s":
            # t[i] = t[i-1] + dt[i], summed in order in float64 (cumsum
            # accumulates left to right), as the encoder verified.
            terms = out["dt_s"].astype(np.float64)
            terms[0] = np.frombuffer(blob, dtype=dtype, count=1, offset=take(8))[0]
            values = np.cumsum(terms)
        else:
            raise ChunkError("structure", f"channel {name} has unknown tag {tag}")
        out[name] = values
    if pos != size:
        raise ChunkError("structure", f"{size} bytes, more than {count} samples use")
    # Any non-zero byte is "in contact", as HapticLab reads it (it writes 0 or 1).
    out["in_contact"] = (out["in_contact"] != 0).astype(np.uint8)
    return out


def decode_chunk(first_tick, count, blob):
    """Verifies and decodes one chunk blob of `count` updates starting at
    tick `first_tick`; returns a dict: "tick" and every channel name -> numpy
    array of `count` values. Raises ChunkError."""
    blob = bytes(blob)
    fmt = verify_chunk(first_tick, count, blob)
    return _decode_verified(first_tick, count, blob, fmt)


def _decode_verified(first_tick, count, blob, fmt):
    if not 1 <= count <= MAX_CHUNK_UPDATES:
        raise ChunkError("structure", f"count is {count}, must be 1..{MAX_CHUNK_UPDATES}")
    channels = _decode_body(blob, fmt, count)
    channels["tick"] = np.arange(first_tick, first_tick + count, dtype=np.uint64)
    return channels


# --- the database -----------------------------------------------------------

class StudyDatabase:
    """A study database opened read-only. Use ``open_study(path)``."""

    def __init__(self, path):
        self.path = str(path)
        uri = "file:" + urllib.parse.quote(self.path) + "?mode=ro"
        self._conn = sqlite3.connect(uri, uri=True)
        try:
            self._check_schema()
        except Exception:
            self._conn.close()
            raise

    def close(self):
        self._conn.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    @property
    def connection(self):
        """The read-only sqlite3 connection, for queries of your own."""
        return self._conn

    def _check_schema(self):
        version = self._conn.execute("PRAGMA user_version").fetchone()[0]
        app_id = self._conn.execute("PRAGMA application_id").fetchone()[0]
        if app_id != APPLICATION_ID:
            raise ValueError(f"{self.path}: not a HapticLab study database (application_id {app_id}, "
                             f"expected {APPLICATION_ID})")
        if version < OLDEST_SCHEMA_VERSION:
            raise ValueError(f"{self.path}: schema version {version}; this reader reads {OLDEST_SCHEMA_VERSION}.."
                             f"{SCHEMA_VERSION}. Open the "
                             f"file once with `hapticlab analyze`, which migrates it")
        if version > SCHEMA_VERSION:
            raise ValueError(f"{self.path}: schema version {version} is newer than this reader ({SCHEMA_VERSION}); "
                             f"use hapticlab_db.py from a newer HapticLab")

    def _rows(self, sql, params=()):
        cur = self._conn.execute(sql, params)
        names = [d[0] for d in cur.description]
        return [dict(zip(names, row)) for row in cur]

    def studies(self):
        """Every study: id, name, seed (decimal text), protocol_sha256,
        software_version, created_utc."""
        return self._rows("SELECT id, name, seed, protocol_sha256, software_version, created_utc "
                          "FROM study ORDER BY id")

    def participants(self, study_id=None):
        """Every participant (id, study_id, code), of one study if given."""
        return self._rows("SELECT id, study_id, code FROM participant WHERE ?1 IS NULL OR study_id = ?1 "
                          "ORDER BY id", (study_id,))

    def settings(self, study_id=None):
        """Every setting (id, study_id, name, parameters_json)."""
        return self._rows("SELECT id, study_id, name, parameters_json FROM setting "
                          "WHERE ?1 IS NULL OR study_id = ?1 ORDER BY id", (study_id,))

    def trials(self, study_id=None, participant=None, status=None):
        """Trials with their plan and outcome, in schedule order: id,
        study_id, participant (code), task, setting (name), repetition,
        block, position, status, started_unix_s, ended_unix_s,
        abort_reason, chunks (sample chunks stored). `participant` is a
        code; `status` one of planned, running, complete, aborted."""
        return self._rows(
            "SELECT t.id, p.study_id, p.code AS participant, t.task, s.name AS setting, t.repetition, t.block, "
            "t.position, t.status, t.started_unix_s, t.ended_unix_s, t.abort_reason, "
            "(SELECT count(*) FROM sample_chunk c WHERE c.trial_id = t.id) AS chunks "
            "FROM trial t JOIN participant p ON p.id = t.participant_id JOIN setting s ON s.id = t.setting_id "
            "WHERE (?1 IS NULL OR p.study_id = ?1) AND (?2 IS NULL OR p.code = ?2) AND (?3 IS NULL OR t.status = ?3) "
            "ORDER BY p.study_id, p.code, t.position, t.id", (study_id, participant, status))

    def _chunks(self, trial_id, instrument):
        return self._conn.execute(
            "SELECT instrument, first_tick, count, data FROM sample_chunk "
            "WHERE trial_id = ?1 AND (?2 IS NULL OR instrument = ?2) ORDER BY instrument, first_tick",
            (trial_id, instrument)).fetchall()

    def check_chunks(self, trial_id=None):
        """Verifies (checksum, format, structure) every chunk, of one trial
        if given; returns the ChunkErrors of the damaged ones (empty: no
        damage), like `hapticlab study check`."""
        rows = self._conn.execute(
            "SELECT trial_id, instrument, first_tick, count, data FROM sample_chunk "
            "WHERE ?1 IS NULL OR trial_id = ?1 ORDER BY trial_id, instrument, first_tick", (trial_id,)).fetchall()
        bad = []
        for trial, instrument, first, count, blob in rows:
            try:
                decode_chunk(first, count, blob)
            except ChunkError as e:
                bad.append(e.located(trial, instrument, first, count))
        return bad

    def samples(self, trial_id, instrument=None):
        """Every stored update of a trial as a numpy structured array
        (SAMPLE_DTYPE), of one instrument (0 left, 1 right) or both, in the
        row order of `hapticlab export` (tick, then left before right).
        Raises ChunkError naming the first damaged chunk; no data is
        returned for a trial with one."""
        if instrument not in (None, 0, 1):
            raise ValueError(f"instrument is {instrument!r}; it must be 0 (left), 1 (right) or None (both)")
        if self._conn.execute("SELECT count(*) FROM trial WHERE id = ?1", (trial_id,)).fetchone()[0] == 0:
            raise KeyError(f"{self.path}: no trial {trial_id}")
        rows = self._chunks(trial_id, instrument)
        # Every checksum at once (numpy), then decoding chunk by chunk.
        blobs = []
        for hand, first, count, blob in rows:
            if len(blob) < HEADER_BYTES:
                raise ChunkError("structure", f"{len(blob)}-byte blob, shorter than the {HEADER_BYTES}-byte header"
                                 ).located(trial_id, hand, first, count)
            blobs.append(bytes(blob))
        crcs = _crc32c_many([_checked_message(r[1], r[2], b) for r, b in zip(rows, blobs)])
        columns = {name: [] for name in SAMPLE_DTYPE.names}
        for (hand, first, count, _), blob, crc in zip(rows, blobs, crcs):
            try:
                fmt = _check_header(blob, int(crc))
                channels = _decode_verified(first, count, blob, fmt)
            except ChunkError as e:
                raise e.located(trial_id, hand, first, count) from None
            channels["instrument"] = np.full(count, hand, dtype=np.uint8)
            for name, values in channels.items():
                columns[name].append(values)
        total = sum(r[2] for r in rows)
        out = np.empty(total, dtype=SAMPLE_DTYPE)
        if total == 0:
            return out
        out["trial_id"] = trial_id
        del columns["trial_id"]
        joined = {name: np.concatenate(parts) for name, parts in columns.items()}
        # Rows by tick, left before right within a tick (chunks were read in
        # (instrument, tick) order; lexsort is stable).
        order = np.lexsort((joined["instrument"], joined["tick"]))
        for name, values in joined.items():
            out[name] = values[order]
        return out

    def samples_dict(self, trial_id, instrument=None):
        """samples() as a dict of column name -> contiguous numpy array."""
        s = self.samples(trial_id, instrument)
        return {name: np.ascontiguousarray(s[name]) for name in s.dtype.names}

    def to_dataframe(self, trial_id, instrument=None):
        """samples() as a pandas DataFrame (requires pandas), one column per
        field, long layout like `hapticlab export`."""
        import pandas as pd  # optional dependency: only this method needs it
        return pd.DataFrame(self.samples_dict(trial_id, instrument))

    def events(self, trial_id):
        """The trial's events (t_s, type, instrument, item_index, detail) in
        time order."""
        return self._rows("SELECT t_s, type, instrument, item_index, detail FROM event WHERE trial_id = ?1 "
                          "ORDER BY t_s, id", (trial_id,))

    def operator_actions(self, participant=None):
        """The console operator's actions (id, session_id, participant,
        trial_id, unix_s, t_s, type, detail) in the order they were
        accepted: notes, pauses, rests, next, end-training, aborts and STOPs,
        each stored before the console answered. trial_id and t_s are None
        for an action between trials; session_id and participant are None
        for a STOP while no session ran. [] for a file older than schema 6."""
        version = self._conn.execute("PRAGMA user_version").fetchone()[0]
        if version < 6:
            return []
        sql = ("SELECT a.id, a.session_id, p.code AS participant, a.trial_id, a.unix_s, a.t_s, a.type, a.detail "
               "FROM operator_action a LEFT JOIN session se ON se.id = a.session_id "
               "LEFT JOIN participant p ON p.id = se.participant_id")
        if participant is not None:
            return self._rows(sql + " WHERE p.code = ?1 ORDER BY a.id", (participant,))
        return self._rows(sql + " ORDER BY a.id")


def open_study(path):
    """Opens a study database read-only; use as a context manager."""
    return StudyDatabase(path)
