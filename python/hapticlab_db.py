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

Opening checks the file's structure (the tables are tables of the
schema's columns, every reference points at a row, every value has its
column's type) and raises ``StructureError`` naming what is wrong. Before a
trial's samples are decoded, its chunks' places are checked (instrument 0
or 1, ticks from 0, none overlapping), then every chunk's CRC-32C (which
covers its trial, instrument and ticks) and its zstd frame (content size
against the chunk's count before anything is decompressed, content
checksum, nothing after the frame). A damaged or misplaced chunk raises
``ChunkError`` naming trial, instrument and ticks (as ``hapticlab export``
and ``hapticlab study check`` do), never returns wrong numbers.
"""

import collections
import contextlib
import hashlib
import json
import sqlite3
import struct
import urllib.parse

import numpy as np

__all__ = [
    "CHANNELS", "ChunkError", "StructureError", "StudyDatabase", "open_study", "decode_chunk", "verify_chunk",
    "crc32c", "SCHEMA_VERSION",
]

# The schema this module reads: version 11 (db/schema.h); since version 7 its chunk
# checksums cover their trial and instrument. Older files are migrated by
# any HapticLab command that opens them read-write (`hapticlab analyze`).
SCHEMA_VERSION = 11
APPLICATION_ID = 0x484C4142  # "HLAB"

# Chunk formats (byte 0 of the blob).
FORMAT_MIGRATED = 0  # written before schema 4, checksummed by the migration
FORMAT_PLAIN = 1     # the uncompressed body
FORMAT_SCHEMA6 = 2   # a zstd frame without content checksum: schemas 4..6, converted by the migration to 7
FORMAT_CURRENT = 3   # the plain body preconditioned, one zstd frame with its content checksum
HEADER_BYTES = 5
MAX_CHUNK_UPDATES = 1 << 20

# The current schema's tables: (name, ((column, declared type, NOT NULL), ...)),
# as PRAGMA table_info reports them (db/schema_shape.cc holds the same).
# The schema's CHECK constraints (db/value_rules.cc): SQLite does not check
# them in integrity_check on a read-only connection. sample_chunk's are
# checked chunk by chunk (_layout).
VALUE_RULES = (
    ("study", "protocol_sha256", "length(protocol_sha256) = 64"),
    ("session", "clock", "clock IN ('virtual', 'wall')"),
    ("session", "status", "status IN ('open', 'closed', 'interrupted')"),
    ("trial", "status", "status IN ('planned', 'running', 'complete', 'aborted')"),
    ("event", "instrument", "instrument IN (-1, 0, 1)"),
)

TABLES = (
    ("study", (("id", "INTEGER", False), ("name", "TEXT", True), ("protocol_json", "TEXT", True),
               ("protocol_sha256", "TEXT", True), ("seed", "TEXT", True), ("software_version", "TEXT", True),
               ("created_utc", "TEXT", True))),
    ("participant", (("id", "INTEGER", False), ("study_id", "INTEGER", True), ("code", "TEXT", True))),
    ("setting", (("id", "INTEGER", False), ("study_id", "INTEGER", True), ("name", "TEXT", True),
                 ("parameters_json", "TEXT", True), ("parameters_sha256", "TEXT", True))),
    ("session", (("id", "INTEGER", False), ("participant_id", "INTEGER", True), ("started_unix_s", "REAL", True),
                 ("ended_unix_s", "REAL", False), ("device", "TEXT", True), ("clock", "TEXT", True),
                 ("status", "TEXT", True), ("site", "TEXT", False), ("rate_Hz", "REAL", False),
                 ("participant_model", "TEXT", False))),
    ("training", (("id", "INTEGER", False), ("session_id", "INTEGER", True), ("task", "TEXT", True),
                  ("started_unix_s", "REAL", True), ("ended_unix_s", "REAL", False), ("duration_s", "REAL", False),
                  ("trials", "INTEGER", True), ("cut_short", "INTEGER", True), ("cut_short_reason", "TEXT", False))),
    ("trial", (("id", "INTEGER", False), ("participant_id", "INTEGER", True), ("task", "TEXT", True),
               ("setting_id", "INTEGER", True), ("repetition", "INTEGER", True), ("block", "INTEGER", True),
               ("position", "INTEGER", True), ("status", "TEXT", True), ("session_id", "INTEGER", False),
               ("started_unix_s", "REAL", False), ("ended_unix_s", "REAL", False), ("abort_reason", "TEXT", False))),
    ("sample_chunk", (("id", "INTEGER", False), ("trial_id", "INTEGER", True), ("instrument", "INTEGER", True),
                      ("first_tick", "INTEGER", True), ("count", "INTEGER", True), ("t0_s", "REAL", True),
                      ("data", "BLOB", True))),
    ("event", (("id", "INTEGER", False), ("trial_id", "INTEGER", True), ("t_s", "REAL", True),
               ("type", "TEXT", True), ("instrument", "INTEGER", True), ("item_index", "INTEGER", True),
               ("detail", "TEXT", False))),
    ("loop_timing", (("trial_id", "INTEGER", False), ("count", "INTEGER", False), ("p50_period_s", "REAL", False),
                     ("p99_period_s", "REAL", False), ("max_period_s", "REAL", False),
                     ("mean_period_s", "REAL", False), ("overruns", "INTEGER", False),
                     ("rejected_periods", "INTEGER", False), ("dropped_samples", "INTEGER", True),
                     ("dropped_events", "INTEGER", True))),
    ("device_counter", (("trial_id", "INTEGER", True), ("name", "TEXT", True), ("value", "INTEGER", True))),
    ("operator_action", (("id", "INTEGER", False), ("session_id", "INTEGER", False), ("trial_id", "INTEGER", False),
                         ("unix_s", "REAL", True), ("t_s", "REAL", False), ("type", "TEXT", True),
                         ("detail", "TEXT", True))),
)

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
TRIAL_STATUSES = ("planned", "running", "complete", "aborted")  # the schema's CHECK on trial.status


class StructureError(ValueError):
    """The file is not what the schema says: a table missing or not a table
    (a view), a reference to no row, a value of the wrong type. ``findings``
    lists every one found (each a message naming table, row and trial)."""

    def __init__(self, path, findings):
        self.path = path
        self.findings = list(findings)
        shown = "; ".join(self.findings[:5]) + ("; ..." if len(self.findings) > 5 else "")
        super().__init__(f"{path}: the file's structure is damaged, {len(self.findings)} finding(s): {shown}")


def loop_count(row):
    """(ticks the loop ran, updates it dropped) from a loop_timing row's
    integer count, rejected_periods and dropped_samples, or None when the
    row cannot tell (none, a negative value, or no period at all), as
    db/chunk_coverage_rules.h's loop_count."""
    if row is None or min(row) < 0 or row[0] + row[1] == 0:
        return None
    return row[0] + row[1] + 1, row[2]


def coverage_findings(trial_id, spans, logged, loop):
    """The updates missing from a trial's well-placed chunks, as
    db/chunk_coverage_rules.h finds them: a gap between chunks that no
    samples_missing event explains, and chunks holding fewer updates than
    the loop ran (count + rejected_periods + 1 ticks, less dropped_samples;
    one short at the end is allowed, the last update of a trial that ended
    on a fault). spans[k]: instrument k's (first_tick, count) in tick
    order; logged: a Counter of the logged gaps' lengths; loop: loop_count's
    answer. [ChunkError]"""
    out = []
    for k in (0, 1):
        rows = spans[k]
        unexplained = collections.Counter(logged)
        reported = 0
        for (first_a, count_a), (first_b, _) in zip(rows, rows[1:]):
            start = first_a + count_a
            length = first_b - start
            if length <= 0:
                continue
            if unexplained[length] > 0:
                unexplained[length] -= 1
                continue
            reported += length
            out.append(ChunkError("placement", "not stored, and no samples_missing event accounts for them "
                                               "(a chunk was removed)", trial_id, k, start, length))
        if loop is None:
            continue
        ticks, dropped = loop
        stored = sum(count for _, count in rows)
        short_by = ticks - dropped - stored - reported
        if short_by <= 1:
            continue
        ran = (f"the loop ran {ticks} updates (ticks 0..{ticks - 1}) and could not queue {dropped}, but the "
               f"chunks hold {stored} (a chunk was removed)")
        if dropped > 0:
            out.append(ChunkError("placement", f"{short_by} of them not stored: {ran}", trial_id, k, 0, ticks))
        elif not rows:
            out.append(ChunkError("placement", "not stored: " + ran, trial_id, k, 0, ticks))
        else:
            end = rows[-1][0] + rows[-1][1]
            if rows[0][0] > 0:
                out.append(ChunkError("placement", "not stored: " + ran, trial_id, k, 0, rows[0][0]))
            if end < ticks - 1:
                out.append(ChunkError("placement", "not stored: " + ran, trial_id, k, end, ticks - end))
    return out


class ChunkError(ValueError):
    """A stored chunk that cannot be used: ``kind`` is "checksum",
    "format" (written by a newer HapticLab), "structure" or "placement"
    (its row does not fit with the trial's other chunks). When raised by
    ``StudyDatabase``, ``trial_id``, ``instrument``, ``first_tick`` and
    ``count`` name the chunk."""

    def __init__(self, kind, problem, trial_id=None, instrument=None, first_tick=None, count=None, path=None):
        self.kind = kind
        self.problem = problem
        self.trial_id = trial_id
        self.instrument = instrument
        self.first_tick = first_tick
        self.count = count
        self.path = path
        super().__init__(self._message())

    def _message(self):
        if self.trial_id is None:
            return self.problem
        return (f"{self.path}: " if self.path else "") + \
            f"damaged sample chunk: {chunk_name(self.trial_id, self.instrument, self.first_tick, self.count)}: " \
            f"{self.problem}"

    def located(self, trial_id, instrument, first_tick, count, path=None):
        return ChunkError(self.kind, self.problem, trial_id, instrument, first_tick, count, path or self.path)

    def in_file(self, path):
        return ChunkError(self.kind, self.problem, self.trial_id, self.instrument, self.first_tick, self.count, path)


def chunk_name(trial_id, instrument, first_tick, count):
    """"trial 3, left instrument (0), ticks 1000..1999", as HapticLab names a chunk."""
    ticks = str(first_tick)
    if isinstance(count, int) and isinstance(first_tick, int) and count > 1:
        ticks += f"..{first_tick + count - 1}"
    hand = INSTRUMENT_NAMES.get(instrument, "unknown")
    return f"trial {trial_id}, {hand} instrument ({instrument}), ticks {ticks}"


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

_U64 = 0xFFFFFFFFFFFFFFFF


def _checked_message(trial_id, instrument, first_tick, count, blob):
    """The bytes the chunk's checksum covers: where it belongs -- the row's
    trial_id, instrument, first_tick and count as 8-byte little-endian
    integers -- then the format byte and the body."""
    return struct.pack("<QQQQ", trial_id & _U64, instrument & _U64, first_tick & _U64, count & _U64) + \
        bytes(blob[:1]) + bytes(blob[HEADER_BYTES:])


def _check_header(blob, computed, count):
    stored = struct.unpack_from("<I", blob, 1)[0]
    if stored != computed:
        raise ChunkError("checksum", f"checksum mismatch (stored CRC-32C 0x{stored:08x}, the data gives "
                                     f"0x{computed:08x}): the chunk is damaged")
    fmt = blob[0]
    if fmt == FORMAT_SCHEMA6:
        raise ChunkError("structure", "chunk format 2 (a zstd frame without its content checksum) belongs to "
                                      "schemas 4..6, and the migration to schema 7 converts every such chunk to "
                                      "format 3; this one was not converted")
    if fmt not in (FORMAT_MIGRATED, FORMAT_PLAIN, FORMAT_CURRENT):
        raise ChunkError("format", f"chunk format {fmt} is not one this reader reads "
                                   f"({FORMAT_MIGRATED}, {FORMAT_PLAIN}, {FORMAT_CURRENT}); it was written by a "
                                   f"newer HapticLab")
    if not isinstance(count, int) or not 1 <= count <= MAX_CHUNK_UPDATES:
        raise ChunkError("structure", f"count is {count}, must be 1..{MAX_CHUNK_UPDATES}")
    return fmt


def _blob_bytes(blob):
    """A chunk's data as bytes; a NULL or TEXT value is a damaged chunk, named."""
    if isinstance(blob, (bytes, bytearray, memoryview)):
        return bytes(blob)
    kind = "NULL" if blob is None else type(blob).__name__
    raise ChunkError("structure", f"its data is {kind}, not a BLOB")


def verify_chunk(trial_id, instrument, first_tick, count, blob):
    """Checks a chunk's header and CRC-32C without decoding; returns its
    format. The checksum covers where the chunk belongs: `trial_id`,
    `instrument`, `first_tick` and `count` are its row's columns. Raises
    ChunkError (a checksum mismatch before an unknown format: a damaged
    format byte is damage)."""
    blob = _blob_bytes(blob)
    if len(blob) < HEADER_BYTES:
        raise ChunkError("structure", f"{len(blob)}-byte blob, shorter than the {HEADER_BYTES}-byte header")
    return _check_header(blob, crc32c(_checked_message(trial_id, instrument, first_tick, count, blob)), count)


_zstd = None
_BATCH_BYTES = 8 << 20  # compressed chunk bytes read and CRC'd together
_ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"  # 0xFD2FB528, little-endian
# At most every channel per update behind its tag (db/sample_codec.cc).
_BYTES_PER_UPDATE = sum(np.dtype(code).itemsize for _, code in CHANNELS)


def _zstandard():
    global _zstd
    if _zstd is None:
        try:
            import zstandard
        except ImportError:
            raise ImportError("chunk format 3 (zstd) needs the zstandard module: apt install python3-zstandard "
                              "(or pip install zstandard)") from None
        _zstd = zstandard
    return _zstd


def _frame_end(frame, header_size, has_checksum):
    """Where the zstd frame that starts `frame` ends (RFC 8878 section
    3.1.1): its header, then blocks of 3-byte headers (bit 0: last block;
    bits 1-2: type raw, RLE, compressed or reserved; bits 3-23: size),
    then the 4-byte content checksum when the header says so. What
    ZSTD_findFrameCompressedSize gives in C; python-zstandard has none, and
    its decompress() ignores whatever follows the first frame."""
    pos = header_size
    while True:
        if pos + 3 > len(frame):
            raise ChunkError("structure", "the zstd frame does not decompress: it ends inside a block header")
        header = int.from_bytes(frame[pos:pos + 3], "little")
        pos += 3
        kind = (header >> 1) & 3
        size = header >> 3
        if kind == 3:
            raise ChunkError("structure", "the zstd frame does not decompress: a block of the reserved type")
        pos += 1 if kind == 1 else size
        if header & 1:
            break
    if has_checksum:
        pos += 4
    if pos > len(frame):
        raise ChunkError("structure", "the zstd frame does not decompress: it is cut short")
    return pos


def _decompress(frame, count):
    """Format 3's zstd frame -> the preconditioned body (bytes), checked as
    HapticLab checks it before anything is allocated: one frame with its
    content size stated, no more than `count` updates can take, its content
    checksum flag set, and nothing after it. zstd then verifies the content
    checksum and never writes more than the stated size."""
    zstandard = _zstandard()
    limit = len(CHANNELS) + count * _BYTES_PER_UPDATE
    if len(frame) <= 4 or frame[:4] != _ZSTD_MAGIC:
        raise ChunkError("structure", "the zstd frame does not decompress (it does not start with a zstd frame's "
                                      "magic number)")
    try:
        params = zstandard.get_frame_parameters(frame)
        header_size = zstandard.frame_header_size(frame)
    except zstandard.ZstdError as e:
        raise ChunkError("structure", f"the zstd frame does not decompress (no valid frame header: {e})") from None
    if params.content_size == zstandard.CONTENTSIZE_UNKNOWN:
        raise ChunkError("structure", "the zstd frame does not state its content size")
    if params.content_size > limit:
        raise ChunkError("structure", f"the zstd frame's header states {params.content_size} bytes, more than the "
                                      f"{limit} that the row's count of updates can take")
    if not params.has_checksum:
        raise ChunkError("structure", "the zstd frame carries no content checksum (format 3 frames must)")
    end = _frame_end(frame, header_size, params.has_checksum)
    if end != len(frame):
        raise ChunkError("structure", f"{len(frame) - end} bytes follow the zstd frame (a chunk holds exactly one "
                                      f"frame)")
    # Straight into a buffer of the stated size (zstd never writes past it),
    # which the preconditioning is then undone in: one copy of the body.
    body = bytearray(params.content_size)
    got = 0
    try:
        with zstandard.ZstdDecompressor().stream_reader(frame, read_across_frames=False) as reader:
            view = memoryview(body)
            while got < len(body):
                n = reader.readinto(view[got:])
                if n == 0:
                    break
                got += n
            more = reader.read(1)  # the frame's end: its content checksum verified
    except zstandard.ZstdError as e:
        raise ChunkError("structure", f"the zstd frame does not decompress: {e}") from None
    if got != len(body) or more:
        raise ChunkError("structure", "the zstd frame does not decompress: not to the size its header states")
    return body


_U64_7, _U64_14, _U64_28 = np.uint64(7), np.uint64(14), np.uint64(28)
_MASK_7, _MASK_14, _MASK_28 = np.uint64(0x00AA00AA00AA00AA), np.uint64(0x0000CCCC0000CCCC), np.uint64(0x00000000F0F0F0F0)


def _transpose8x8(x):
    """Each uint64 of `x` as an 8 x 8 bit matrix (row r = byte r, column c
    = bit c) transposed, as db/sample_codec.cc transpose8x8 does; its own
    inverse."""
    t = (x ^ (x >> _U64_7)) & _MASK_7
    x = x ^ t ^ (t << _U64_7)
    t = (x ^ (x >> _U64_14)) & _MASK_14
    x = x ^ t ^ (t << _U64_14)
    t = (x ^ (x >> _U64_28)) & _MASK_28
    return x ^ t ^ (t << _U64_28)


def _from_bit_planes(raw, count, width, out):
    """Bit planes (db/sample_codec.cc bit_planes()) -> values as unsigned
    ints, written to `out` (a little-endian uint array of `count`): the first
    count - count % 8 values as 8 * width planes (plane k: bit k % 8 of byte
    k // 8 of each value, value i at bit i % 8 of byte i // 8), then the last
    count % 8 values as they are. For byte b of the values, the eight planes
    8b .. 8b + 7 hold, per group of 8 values, an 8 x 8 bit matrix whose
    transpose is those values' byte b: one uint64 per group."""
    whole = count - count % 8
    groups = whole // 8
    planes = np.frombuffer(raw, dtype=np.uint8, count=whole * width).reshape(width, 8, groups)
    # [b, g] as a uint64 whose byte j is plane 8b + j's byte g, for all b at once.
    rows = np.ascontiguousarray(planes.transpose(0, 2, 1)).view("<u8").reshape(width, groups)
    # Transposed, its byte r is value 8g + r's byte b.
    values = _transpose8x8(rows).view(np.uint8).reshape(width, whole)
    out[:whole].view(np.uint8).reshape(whole, width)[:] = values.T
    if count > whole:
        out[whole:] = np.frombuffer(raw, dtype="<u%d" % width, count=count - whole, offset=whole * width)


def _unprecondition(body, count):
    """Undoes format 3's preconditioning (db/sample_codec.h), in place in
    `body` (a bytearray, returned): every channel stored per update with 4-
    or 8-byte values is bit planes of the differences of consecutive bit
    patterns; when t_s is stored per update too, dt_s is bit planes of dt's
    bits XOR those of t's differences. Gives the format-1 body."""
    out = body
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
        values = np.empty(count, dtype="<u%d" % width)
        _from_bit_planes(memoryview(out)[at:at + count * width], count, width, values)
        if not (name == "dt_s" and residual_dt):
            # Unsigned sums wrap modulo 2^32 / 2^64, as the encoder's differences did.
            np.cumsum(values, dtype=values.dtype, out=values)
        out[at:at + count * width] = values.tobytes()
        del values
    if residual_dt:
        t = np.frombuffer(out, dtype="<f8", count=count, offset=places["t_s"])
        dt = np.frombuffer(out, dtype="<u8", count=count, offset=places["dt_s"])
        dt[1:] ^= (t[1:] - t[:-1]).view("<u8")
    return out


def _decode_body(blob, fmt, count):
    """The channels of a verified chunk as a dict name -> array of `count`."""
    pos = HEADER_BYTES

    def take(nbytes):
        nonlocal pos
        if pos + nbytes > size:
            raise ChunkError("structure", "blob too short for its count")
        start = pos
        pos += nbytes
        return start

    if fmt == FORMAT_CURRENT:
        blob = _unprecondition(_decompress(memoryview(blob)[HEADER_BYTES:], count), count)
        pos = 0
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


def decode_chunk(trial_id, instrument, first_tick, count, blob):
    """Verifies and decodes one chunk blob of `count` updates of `instrument`
    of trial `trial_id`, starting at tick `first_tick` (the row's columns,
    which its checksum covers); returns a dict: "tick" and every channel
    name -> numpy array of `count` values. Raises ChunkError."""
    fmt = verify_chunk(trial_id, instrument, first_tick, count, blob)
    return _decode_verified(first_tick, count, _blob_bytes(blob), fmt)


def _decode_verified(first_tick, count, blob, fmt):
    channels = _decode_body(blob, fmt, count)
    channels["tick"] = np.arange(first_tick, first_tick + count, dtype=np.uint64)
    return channels


# --- the database -----------------------------------------------------------

def _sql_name(name):
    return '"' + name.replace('"', '""') + '"'


def _allowed_types(declared, not_null):
    kind = {"INTEGER": "integer", "REAL": "real", "TEXT": "text"}.get(declared, "blob")
    return f"'{kind}'" + ("" if not_null else ", 'null'")


def _describe_columns(columns):
    return ", ".join(f"{n} {t or '(no type)'}{' NOT NULL' if nn else ''}" for n, t, nn in columns)


def _row_name(table, rowid, trial):
    if table == "trial":
        return f"trial {rowid}"
    return f"{table} row {rowid}" + (f" of trial {trial}" if trial is not None else "")


def _layout(rows):
    """One trial's chunk rows (id, trial_id, instrument, first_tick, count
    and the typeof() of trial_id, instrument, first_tick, count and data),
    checked as db/chunk_layout.h does: integer columns and a BLOB, instrument
    0 or 1, first tick >= 0, count 1..MAX_CHUNK_UPDATES, and no two chunks
    of one instrument sharing a tick (both of an overlapping pair are bad).
    Returns (good rows per instrument in tick order, [ChunkError])."""
    rows = sorted(rows, key=lambda r: (r[2] if isinstance(r[2], int) else 1 << 62,
                                       r[3] if isinstance(r[3], int) else 1 << 62, r[0]))
    problem = {}
    for r in rows:
        rid, _, instrument, first, count = r[:5]
        types = r[5:10]
        wrong = [f"its {col} is {kind}{'' if kind == 'null' else ' ' + repr(value)}, expected "
                 f"{'a BLOB' if col == 'data' else 'an INTEGER'}"
                 for col, kind, value, want in zip(("trial_id", "instrument", "first_tick", "count", "data"), types,
                                                   (r[1], instrument, first, count, None),
                                                   ("integer",) * 4 + ("blob",)) if kind != want]
        if wrong:
            problem[rid] = "; ".join(wrong)
        elif instrument not in (0, 1):
            problem[rid] = f"instrument {instrument} is neither 0 (left) nor 1 (right)"
        elif first < 0:
            problem[rid] = f"first tick {first} is negative"
        elif not 1 <= count <= MAX_CHUNK_UPDATES:
            problem[rid] = f"count is {count}, must be 1..{MAX_CHUNK_UPDATES}"
    reach = None  # the row whose ticks end furthest in this instrument
    for r in rows:
        if r[0] in problem:
            continue
        if reach is not None and reach[2] != r[2]:
            reach = None
        if reach is not None:
            end = reach[3] + reach[4]
            if r[3] < end:
                problem[r[0]] = f"its ticks overlap those of the chunk with ticks {_ticks(reach[3], reach[4])} " \
                                f"(a tick stored twice)"
                problem.setdefault(reach[0], f"its ticks overlap those of the chunk with ticks "
                                             f"{_ticks(r[3], r[4])} (a tick stored twice)")
            if r[3] + r[4] <= end:
                continue
        reach = r
    good = ([], [])
    bad = []
    for r in rows:
        if r[0] in problem:
            bad.append(ChunkError("placement", problem[r[0]], r[1], r[2], r[3], r[4]))
        else:
            good[r[2]].append(r)
    return good, bad


def _ticks(first, count):
    return f"{first}..{first + count - 1}" if count > 1 else str(first)



class StudyDatabase:
    """A study database opened read-only. Use ``open_study(path)``."""

    def __init__(self, path):
        self.path = str(path)
        uri = "file:" + urllib.parse.quote(self.path) + "?mode=ro"
        self._conn = sqlite3.connect(uri, uri=True)
        try:
            self._check_schema()
            findings = self.check_structure()
            if findings:
                raise StructureError(self.path, findings)
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
        if version < SCHEMA_VERSION:
            raise ValueError(f"{self.path}: schema version {version}; this reader reads version {SCHEMA_VERSION}. "
                             f"Open the file once with `hapticlab analyze`, which migrates it")
        if version > SCHEMA_VERSION:
            raise ValueError(f"{self.path}: schema version {version} is newer than this reader ({SCHEMA_VERSION}); "
                             f"use hapticlab_db.py from a newer HapticLab")

    def check_structure(self):
        """The file's structure, as `hapticlab study check` checks it besides
        SQLite's integrity_check and the chunks: every table of the schema is
        a table (not a view, which could hold anything or never end) of the
        expected columns; then every reference points at a row (PRAGMA
        foreign_key_check), every value has its column's type (an event
        time is a REAL, never the TEXT 'nan'), and the protocol and settings
        match the SHA-256 stored with them. Returns the findings as
        messages naming table, row and trial; [] when sound. Opening runs it
        and raises StructureError when it finds anything."""
        findings = []
        for table, columns in TABLES:
            row = self._conn.execute("SELECT type FROM main.sqlite_schema WHERE name = ?1 COLLATE NOCASE AND "
                                     "type IN ('table', 'view') LIMIT 1", (table,)).fetchone()
            if row is None:
                findings.append(f"table {table} is missing")
                continue
            if row[0] != "table":
                findings.append(f"table {table} is a {row[0]}, not a table: it is refused before any query reads it "
                                f"(a view can hold anything, or never end)")
                continue
            found = [(name, declared, bool(notnull)) for name, declared, notnull in self._conn.execute(
                "SELECT name, type, \"notnull\" FROM pragma_table_info(?1, 'main') ORDER BY cid", (table,))]
            want = list(columns)
            if [(n.lower(), t.upper(), nn) for n, t, nn in found] != [(n.lower(), t, nn) for n, t, nn in want]:
                findings.append(f"table {table} has columns ({_describe_columns(found)}); expected "
                                f"({_describe_columns(want)})")
        if findings:
            return findings  # nothing reads tables that are not what they should be
        for table, rowid, parent, fk in self._conn.execute("PRAGMA main.foreign_key_check").fetchmany(100):
            column = self._conn.execute("SELECT \"from\" FROM pragma_foreign_key_list(?1, 'main') WHERE id = ?2",
                                        (table, fk)).fetchone()
            column = column[0] if column else "?"
            has_trial = any(c == "trial_id" for c, _, _ in dict(TABLES).get(table, ()))
            value, trial = self._conn.execute(
                f"SELECT quote({_sql_name(column)}), {'trial_id' if has_trial else 'NULL'} FROM main.{_sql_name(table)} "
                f"WHERE rowid = ?1", (rowid,)).fetchone() or ("?", None)
            if table == "trial":
                trial = rowid
            findings.append(f"{_row_name(table, rowid, trial)}: {column} {value} refers to no {parent} row")
        findings.extend(self._misfit_references())
        for table, columns in TABLES:
            findings.extend(self._mistyped_rows(table, columns))
        for table, column, condition in VALUE_RULES:
            trial = "rowid" if table == "trial" else \
                "trial_id" if any(c == "trial_id" for c, _, _ in dict(TABLES)[table]) else "NULL"
            for rowid, row_trial, value in self._conn.execute(
                    f"SELECT rowid, {trial}, substr(quote({column}), 1, 40) FROM main.{table} WHERE {column} IS NOT "
                    f"NULL AND NOT ({condition}) ORDER BY rowid LIMIT 20"):
                findings.append(f"{_row_name(table, rowid, row_trial)}: {column} is {value}, which breaks CHECK "
                                f"({condition})")
        findings.extend(self._edited_definitions())
        return findings

    def _edited_definitions(self):
        """The protocol texts and settings that no longer match the SHA-256
        stored with them (db/study_digest_rules.h): sessions take their
        schedule from the one and configure their engine from the other, so
        an edit changes what later participants feel. The stored bytes are
        hashed, as HapticLab hashes them (text that is not UTF-8 is damage,
        not an error of this reader)."""
        def short(digest):
            return digest[:12] + "..." if len(digest) > 12 else f"'{digest}'"

        def rows(table, text, digest, name):
            return self._conn.execute(
                f"SELECT id, {name}, CAST({text} AS BLOB), CAST({digest} AS BLOB) FROM main.{table} WHERE "
                f"typeof({text}) = 'text' AND typeof({digest}) = 'text' ORDER BY id")
        out = []
        for study, _, text, stored in rows("study", "protocol_json", "protocol_sha256", "NULL"):
            found, stored = hashlib.sha256(text).hexdigest(), stored.decode("ascii", "replace")
            if found != stored:
                out.append(f"study {study}: its protocol_json does not match the SHA-256 stored with it "
                           f"(stored {short(stored)}, the text now gives {short(found)})")
        for setting, name, text, stored in rows("setting", "parameters_json", "parameters_sha256", "name"):
            found, stored = hashlib.sha256(text).hexdigest(), stored.decode("ascii", "replace")
            if not stored:
                out.append(f"setting '{name}' (id {setting}): no SHA-256 is stored with its parameters_json: it was "
                           f"written by a HapticLab older than schema version 11 into a file already migrated")
            elif found != stored:
                out.append(f"setting '{name}' (id {setting}): its parameters_json does not match the SHA-256 stored "
                           f"with it (stored {short(stored)}, the text now gives {short(found)})")
        return out

    def _status_misfits(self):
        """A trial whose status is at odds with what it holds, as
        db/structure_check.cc finds it: planned with a session, times,
        samples or events; ran without a session or start time; complete
        without an end time."""
        out = []
        for t, status, session, started, ended, chunks, events in self._conn.execute(
                "SELECT t.id, t.status, quote(t.session_id), quote(t.started_unix_s), quote(t.ended_unix_s), "
                "(SELECT count(*) FROM main.sample_chunk c WHERE c.trial_id = t.id), "
                "(SELECT count(*) FROM main.event e WHERE e.trial_id = t.id) FROM main.trial t "
                "WHERE (t.status = 'planned' AND (t.session_id IS NOT NULL OR t.started_unix_s IS NOT NULL OR "
                "t.ended_unix_s IS NOT NULL OR EXISTS (SELECT 1 FROM main.sample_chunk c WHERE c.trial_id = t.id) OR "
                "EXISTS (SELECT 1 FROM main.event e WHERE e.trial_id = t.id))) OR "
                "(t.status IN ('running', 'complete', 'aborted') AND (t.session_id IS NULL OR "
                "t.started_unix_s IS NULL)) OR (t.status = 'complete' AND t.ended_unix_s IS NULL) ORDER BY t.id"):
            if status == "planned":
                held = [f"{name} {value}" for name, value in (("session_id", session), ("started_unix_s", started),
                                                               ("ended_unix_s", ended)) if value != "NULL"]
                held += [f"{n} {what}" for n, what in ((chunks, "sample chunk(s)"), (events, "event(s)")) if n > 0]
                out.append(f"trial {t}: status is 'planned', but it has {', '.join(held)} (a planned trial has not "
                           f"run: what it holds is read by no export or analysis)")
            else:
                missing = [name for name, value in (("session_id", session), ("started_unix_s", started)) if value == "NULL"]
                if status == "complete" and ended == "NULL":
                    missing.append("ended_unix_s")
                verb = "is" if len(missing) == 1 else "are"
                out.append(f"trial {t}: status is '{status}', but {', '.join(missing)} {verb} NULL (a trial gets its "
                           f"session and start time when it starts, and a complete one its end time)")
        return out

    def _misfit_references(self):
        """References that exist but do not fit, as db/structure_check.cc
        finds them: a trial in another participant's session, a trial running
        in a session that has ended, a trial or training of a task its
        study's protocol does not name, a trial whose status is at odds with
        what it holds, an action on another session's trial."""
        out = []
        for t, session, theirs, own in self._conn.execute(
                "SELECT t.id, t.session_id, q.code, p.code FROM main.trial t JOIN main.session s ON "
                "s.id = t.session_id JOIN main.participant p ON p.id = t.participant_id JOIN main.participant q ON "
                "q.id = s.participant_id WHERE s.participant_id <> t.participant_id ORDER BY t.id"):
            out.append(f"trial {t}: session_id {session} is participant '{theirs}''s session, but the trial is "
                       f"participant '{own}''s")
        for t, session, status in self._conn.execute(
                "SELECT t.id, s.id, s.status FROM main.trial t JOIN main.session s ON s.id = t.session_id "
                "WHERE t.status = 'running' AND s.status <> 'open' ORDER BY t.id"):
            out.append(f"trial {t}: status is 'running', but its session {session} is {status} (a session ends "
                       f"after its trials)")
        for study, text in self._conn.execute(
                "SELECT id, protocol_json FROM main.study WHERE typeof(protocol_json) = 'text'").fetchall():
            try:
                tasks = json.loads(text).get("tasks")
            except (ValueError, AttributeError):
                continue
            if not isinstance(tasks, list) or not all(isinstance(t, str) for t in tasks):
                continue
            named = ", ".join(sorted(set(tasks)))
            for table, rowid, trial, task in self._conn.execute(
                    "SELECT 'trial', t.id, t.id, t.task FROM main.trial t JOIN main.participant p ON "
                    "p.id = t.participant_id WHERE p.study_id = ?1 UNION ALL SELECT 'training', r.id, NULL, r.task "
                    "FROM main.training r JOIN main.session s ON s.id = r.session_id JOIN main.participant p ON "
                    "p.id = s.participant_id WHERE p.study_id = ?1", (study,)):
                if task not in tasks:
                    out.append(f"{_row_name(table, rowid, trial)}: task '{task}' is not one of its study's "
                               f"protocol's tasks ({named})")
        out.extend(self._status_misfits())
        for action, trial, session, ran in self._conn.execute(
                "SELECT a.id, a.trial_id, a.session_id, t.session_id FROM main.operator_action a JOIN main.trial t "
                "ON t.id = a.trial_id WHERE a.session_id IS NOT NULL AND t.session_id IS NOT NULL AND "
                "a.session_id <> t.session_id ORDER BY a.id"):
            out.append(f"{_row_name('operator_action', action, trial)}: session_id {session}, but its trial ran in "
                       f"session {ran}")
        return out

    def _mistyped_rows(self, table, columns, where="", params=(), limit=20):
        """Messages for the rows of `table` whose values do not have their
        column's type (INTEGER an integer, REAL a real, TEXT text, BLOB a
        blob, NULL only where allowed), as db/schema_shape.cc words them."""
        trial = "rowid" if table == "trial" else \
            "CASE typeof(trial_id) WHEN 'integer' THEN trial_id END" if any(c == "trial_id" for c, _, _ in columns) \
            else "NULL"
        select = [f"typeof({_sql_name(c)}), substr(quote({_sql_name(c)}), 1, 40)" for c, _, _ in columns]
        bad = " OR ".join(f"typeof({_sql_name(c)}) NOT IN ({_allowed_types(t, nn)})" for c, t, nn in columns)
        sql = f"SELECT rowid, {trial}, {', '.join(select)} FROM main.{_sql_name(table)} WHERE "
        sql += (f"({where}) AND " if where else "") + f"({bad}) ORDER BY rowid LIMIT {limit}"
        out = []
        for row in self._conn.execute(sql, params):
            rowid, row_trial = row[0], row[1]
            what = []
            for k, (column, declared, not_null) in enumerate(columns):
                kind, value = row[2 + 2 * k], row[3 + 2 * k]
                if kind in _allowed_types(declared, not_null):
                    continue
                article = "an" if declared == "INTEGER" else "a"
                what.append(f"{column} is {kind}{'' if kind == 'null' else ' ' + value}, expected {article} "
                            f"{declared}{'' if not_null else ' or NULL'}")
            out.append(f"{_row_name(table, rowid, row_trial)}: {'; '.join(what)}")
        return out

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
        code; `status` one of planned, running, complete, aborted. An
        unknown study, participant or status raises (an empty list would
        read as "no such trials")."""
        if status is not None and status not in TRIAL_STATUSES:
            raise ValueError(f"status is {status!r}; it must be one of {', '.join(TRIAL_STATUSES)}")
        if study_id is not None and not self._exists("study", "id", study_id):
            raise KeyError(f"{self.path}: no study {study_id!r}")
        if participant is not None and not self._exists("participant", "code", participant):
            codes = [r[0] for r in self._conn.execute("SELECT code FROM participant ORDER BY code")]
            raise KeyError(f"{self.path}: no participant {participant!r}; the codes are {', '.join(codes)}")
        return self._rows(
            "SELECT t.id, p.study_id, p.code AS participant, t.task, s.name AS setting, t.repetition, t.block, "
            "t.position, t.status, t.started_unix_s, t.ended_unix_s, t.abort_reason, "
            "(SELECT count(*) FROM sample_chunk c WHERE c.trial_id = t.id) AS chunks "
            "FROM trial t JOIN participant p ON p.id = t.participant_id JOIN setting s ON s.id = t.setting_id "
            "WHERE (?1 IS NULL OR p.study_id = ?1) AND (?2 IS NULL OR p.code = ?2) AND (?3 IS NULL OR t.status = ?3) "
            "ORDER BY p.study_id, p.code, t.position, t.id", (study_id, participant, status))

    @contextlib.contextmanager
    def _snapshot(self):
        """A read transaction, so a trial's chunk rows and the blobs read
        after them are one snapshot, even while a session appends."""
        own = not self._conn.in_transaction
        if own:
            self._conn.execute("BEGIN")
        try:
            yield
        finally:
            if own:
                self._conn.rollback()

    def _chunk_rows(self, trial_id):
        return self._conn.execute(
            "SELECT id, trial_id, instrument, first_tick, count, typeof(trial_id), typeof(instrument), "
            "typeof(first_tick), typeof(count), typeof(data) FROM main.sample_chunk WHERE trial_id = ?1",
            (trial_id,)).fetchall()

    def _verified(self, rows):
        """Yields (row, (format, blob)) or (row, ChunkError) for each of the
        layout's good `rows`, in order: blobs read a batch of at most 8 MB at
        a time, their CRC-32C computed together (numpy)."""
        batch = []
        size = 0

        def flush():
            checkable = [(r, b) for r, b in batch if not isinstance(b, ChunkError)]
            crcs = iter(_crc32c_many([_checked_message(r[1], r[2], r[3], r[4], b) for r, b in checkable]))
            for r, b in batch:
                if isinstance(b, ChunkError):
                    yield r, b
                    continue
                try:
                    yield r, (_check_header(b, int(next(crcs)), r[4]), b)
                except ChunkError as e:
                    yield r, e

        for r in rows:
            found = self._conn.execute("SELECT data FROM main.sample_chunk WHERE id = ?1", (r[0],)).fetchone()
            try:
                blob = _blob_bytes(found[0] if found else None)
                if len(blob) < HEADER_BYTES:
                    raise ChunkError("structure", f"{len(blob)}-byte blob, shorter than the {HEADER_BYTES}-byte "
                                                  f"header")
            except ChunkError as e:
                blob = e
            batch.append((r, blob))
            size += 0 if isinstance(blob, ChunkError) else len(blob)
            if size >= _BATCH_BYTES:
                yield from flush()
                batch, size = [], 0
        yield from flush()

    def check_chunks(self, trial_id=None):
        """Verifies every chunk, of one trial if given: its place among the
        trial's chunks (instrument, ticks, no overlap), checksum, format and
        structure (decoded, then discarded); returns the ChunkErrors of the
        bad ones (empty: no damage), like `hapticlab study check`."""
        if trial_id is None:
            trials = [t for (t,) in self._conn.execute(
                "SELECT trial_id FROM main.sample_chunk WHERE typeof(trial_id) = 'integer' UNION "
                "SELECT trial_id FROM main.loop_timing WHERE typeof(trial_id) = 'integer' ORDER BY trial_id")]
        else:
            if not self._exists("trial", "id", trial_id):
                raise KeyError(f"{self.path}: no trial {trial_id!r}")  # [] would read as "no damage"
            trials = [trial_id]
        bad = []
        for trial in trials:
            with self._snapshot():
                good, misplaced = _layout(self._chunk_rows(trial))
                if not misplaced:
                    misplaced = self._coverage(trial, good)
                bad.extend(e.in_file(self.path) for e in misplaced)
                for r, result in self._verified(good[0] + good[1]):
                    try:
                        if isinstance(result, ChunkError):
                            raise result
                        _decode_verified(r[3], r[4], result[1], result[0])
                    except ChunkError as e:
                        bad.append(e.located(r[1], r[2], r[3], r[4], self.path))
        return bad

    def _coverage(self, trial_id, good):
        """The updates missing from a trial's well-placed chunks
        (coverage_findings), with the two rows of the file it needs."""
        logged = collections.Counter(v for (v,) in self._conn.execute(
            "SELECT item_index FROM main.event WHERE trial_id = ?1 AND type = 'samples_missing' "
            "AND typeof(item_index) = 'integer'", (trial_id,)))
        loop = self._conn.execute(
            "SELECT count, rejected_periods, dropped_samples FROM main.loop_timing WHERE trial_id = ?1 AND "
            "typeof(count) = 'integer' AND typeof(rejected_periods) = 'integer' AND "
            "typeof(dropped_samples) = 'integer'", (trial_id,)).fetchone()
        spans = [[(r[3], r[4]) for r in good[k]] for k in (0, 1)]
        return coverage_findings(trial_id, spans, logged, loop_count(loop))

    def samples(self, trial_id, instrument=None):
        """Every stored update of a trial as a numpy structured array
        (SAMPLE_DTYPE), of one instrument (0 left, 1 right) or both, in the
        row order of `hapticlab export` (tick, then left before right).
        Raises ChunkError naming the first misplaced or damaged chunk; no
        data is returned for a trial with one. Holds the result and one
        chunk at a time (and the compressed blobs of at most 8 MB of chunks)."""
        if isinstance(instrument, bool) or instrument not in (None, 0, 1):
            raise ValueError(f"instrument is {instrument!r}; it must be 0 (left), 1 (right) or None (both)")
        if self._conn.execute("SELECT count(*) FROM trial WHERE id = ?1", (trial_id,)).fetchone()[0] == 0:
            raise KeyError(f"{self.path}: no trial {trial_id}")
        with self._snapshot():
            good, bad = _layout(self._chunk_rows(trial_id))
            if not bad:
                bad = self._coverage(trial_id, good)
            if instrument is not None:
                bad = [e for e in bad if e.instrument == instrument]
                good = tuple(g if k == instrument else [] for k, g in enumerate(good))
            if bad:
                raise bad[0].in_file(self.path)
            wanted = (0, 1) if instrument is None else (instrument,)
            total = sum(r[4] for k in wanted for r in good[k])
            out = np.empty(total, dtype=SAMPLE_DTYPE)
            out["trial_id"] = trial_id
            # Where each chunk's updates go: by tick, left before right
            # within a tick (db/README.md, "Row order").
            starts = [np.array([r[3] for r in good[k]], dtype=np.int64) for k in (0, 1)]
            counts = [np.array([r[4] for r in good[k]], dtype=np.int64) for k in (0, 1)]
            before = [np.concatenate(([0], np.cumsum(c)[:-1])).astype(np.int64) for c in counts]
            index = {r[0]: i for k in (0, 1) for i, r in enumerate(good[k])}

            def destination(hand, first, count, offset):
                """Rows of out for the chunk's updates; `offset`: the hand's
                updates before the chunk."""
                if instrument is not None:
                    return slice(offset, offset + count)
                t = np.arange(first, first + count, dtype=np.int64)
                other = 1 - hand
                if starts[other].size == 0:
                    return offset + (t - first)
                q = t if hand == 1 else t - 1  # the other hand's updates at ticks <= q come first
                j = np.searchsorted(starts[other], q, side="right") - 1
                jj = np.maximum(j, 0)
                n = np.where(j >= 0, before[other][jj] + np.minimum(q - starts[other][jj] + 1, counts[other][jj]), 0)
                rows = offset + (t - first) + n
                # Both hands at every tick (the usual case): every other row, a
                # strided slice, far cheaper to fill than a list of rows.
                step = int(rows[1] - rows[0]) if count > 1 else 1
                if step > 0 and int(rows[-1] - rows[0]) == step * (count - 1) and \
                        bool(np.all(np.diff(rows) == step)):
                    return slice(int(rows[0]), int(rows[-1]) + 1, step)
                return rows

            for r, result in self._verified([r for k in wanted for r in good[k]]):
                rid, _, hand, first, count = r[:5]
                try:
                    if isinstance(result, ChunkError):
                        raise result
                    channels = _decode_verified(first, count, result[1], result[0])
                except ChunkError as e:
                    raise e.located(trial_id, hand, first, count, self.path) from None
                where = destination(hand, first, count, int(before[hand][index[rid]]))
                out["instrument"][where] = hand
                for name, values in channels.items():
                    out[name][where] = values
                del channels
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

    def _exists(self, table, column, value):
        return self._conn.execute(f"SELECT count(*) FROM {table} WHERE {column} = ?1", (value,)).fetchone()[0] > 0

    def events(self, trial_id):
        """The trial's events (t_s, type, instrument, item_index, detail) in
        time order; KeyError for a trial the file does not have."""
        if not self._exists("trial", "id", trial_id):
            raise KeyError(f"{self.path}: no trial {trial_id!r}")
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
