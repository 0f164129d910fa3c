#!/usr/bin/env python3
"""The comparator for `hapticlab bench analyze --compare`: the same work as
`hapticlab analyze --no-ks --no-plots` (without the report), written as fast
as numpy allows, so that the speed ratio says something about HapticLab.

Work done, as analyze does it: read the complete trials' sample chunks and
events with Python's sqlite3 (read-only); check every chunk's place (instrument
0 or 1, ticks from 0, none overlapping), its CRC-32C over where it belongs
and its bytes, and its zstd frame (content size within the row's count, the
content-checksum flag, exactly one frame; zstd verifies the content
checksum); decode the channels the metrics read; compute the per-trial
metrics (task window, median and 95th-percentile |F| over samples with |F|
>= 1 mN, median |v|, path length; percentiles as MATLAB's prctile) and the
energy each hand's device gave and took over the whole trial (per axis, and
the engine's part: analysis/metrics/device_energy.h); run the
Table 3.4 Friedman tests (per participant and task: both hands as blocks,
then each hand alone; repetitions as replicates, as MATLAB's friedman(X,
reps)). A damaged, misplaced or missing chunk stops it with a message
naming the chunk or the ticks (exit 1): its numbers would be wrong.

How it is made fast (one thread throughout; numpy's own operations are
single-threaded, and zstd and the CRC are called one chunk at a time):
- one query for all the chunks of the complete trials, in (trial,
  instrument, tick) order, one for all their task events; no per-trial
  queries; the place check is a few vectorised comparisons over all rows;
- CRC-32C by python3-crc32c (Debian; a C table-driven CRC, 1.7 GB/s here
  without SSE 4.2), fed the row's 32 bytes and then the blob through a
  memoryview: no copy; without that module, the numpy CRC of
  python/hapticlab_db.py, all of a trial's chunks at once (a printed note
  says which was used);
- zstd by python3-zstandard's one-shot decompress() into a buffer of the
  frame's stated size, after its header is checked;
- column projection: of the 28 channels only those the metrics read are
  decoded (t_s, tip position, tip velocity, tissue force, the first three
  raw joints, the joint forces; dt_s only when t_s is stored as a running
  sum); the others' tags are walked past (every tag and size checked, as
  analyze does), never undone;
- bit planes undone for all chunks of a batch of trials at once, grouped by
  (value width, update count): the planes of a group are gathered into one
  (chunks, width, 8, count/8) array, transposed so that each 64-bit word
  holds one byte position of 8 consecutive values as an 8 x 8 bit matrix,
  and every word of the group transposed with three masked shifts and XORs
  (Hacker's Delight transpose8); the differences are summed with one
  wrapping cumsum along the group's rows; t_s running sums likewise, one
  float64 cumsum per group (sequential, as the format defines them);
- percentiles by np.partition on the two order statistics prctile needs
  (the same values as sorting, to the bit), not a full sort;
- the energy sums vectorised per hand: the VE force's joint components
  (J^T F) only for samples in contact, the pose's sines and cosines by
  math.sin/math.cos (the C library's bits; numpy's SVML ones differ) once
  per distinct angle after collapsing runs of one value; the 12 sums of a
  hand by one float64 cumsum along rows (sequential, as analyze adds
  them; np.sum would add pairwise and differ in the last bits);
- no scipy: ranks with ties averaged by one argsort, the chi-square tail
  in closed form (math.erfc / exp series), since importing scipy.stats
  alone takes longer than most of the analysis.

Its metrics are checked against analyze's in CI, to the bit
(tests/python/test_analyze_numpy.py); only its speed is benchmarked.

    analyze_numpy.py STUDY.db [--metrics-out CSV] [--friedman-out CSV]
"""
import argparse
import collections
import csv
import math
import os
import sqlite3
import struct
import sys

import numpy as np
import zstandard

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
import hapticlab_db  # noqa: E402  (the reader that ships with HapticLab: its format constants and checks)

try:
    import crc32c as _crc32c_module  # Debian python3-crc32c
except ImportError:
    _crc32c_module = None

MIN_CONTACT_FORCE_N = 1e-3
MEASURES = ("force_median_N", "force_p95_N", "completion_time_s", "speed_median_m_per_s", "path_length_m")
PER_HAND = {"force_median_N", "force_p95_N", "speed_median_m_per_s", "path_length_m"}

# Channel numbers in the body (db/README.md, "The chunk format").
DT, T = 0, 1
# The float32 channels the metrics read, rows 0..14 of the float output:
# tip_x..z, tip_vx..vz, ve_force_x..z (the task-window measures), then
# raw_insertion, raw_pitch, raw_yaw and the joint forces (the energy
# measures). The others' tags are walked past.
FLOAT_CHANNELS = tuple(range(10, 19)) + (2, 3, 4) + (22, 23, 24)
ROW = {c: row for row, c in enumerate(FLOAT_CHANNELS)}
TIP, VELOCITY, VE_FORCE, RAW, JOINT_FORCE = range(0, 3), range(3, 6), range(6, 9), range(9, 12), range(12, 15)
LAST_NEEDED = max(FLOAT_CHANNELS)
ENERGY_COLUMNS = ("device_out_insertion_J", "device_in_insertion_J", "device_out_pitch_J", "device_in_pitch_J",
                  "device_out_yaw_J", "device_in_yaw_J", "engine_out_J", "engine_in_J")
WIDTH = [np.dtype(code).itemsize for _, code in hapticlab_db.CHANNELS]
HEADER = hapticlab_db.HEADER_BYTES
MAX_BODY_PER_UPDATE = sum(WIDTH)
ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"
TRIALS_PER_BATCH = 8  # decoded together: ~25 MB of decompressed bodies on the demo study

_S7, _S14, _S28 = np.uint64(7), np.uint64(14), np.uint64(28)
_M7, _M14, _M28 = np.uint64(0x00AA00AA00AA00AA), np.uint64(0x0000CCCC0000CCCC), np.uint64(0x00000000F0F0F0F0)


class ChunkDamage(Exception):
    pass


def chunk_name(trial, hand, first, count):
    return hapticlab_db.chunk_name(trial, hand, first, count)


def transpose8x8(x):
    """Every uint64 of x as an 8 x 8 bit matrix (row = byte, column = bit)
    transposed; in place where numpy allows."""
    t = x >> _S7
    t ^= x
    t &= _M7
    x ^= t
    x ^= t << _S7
    t = x >> _S14
    t ^= x
    t &= _M14
    x ^= t
    x ^= t << _S14
    t = x >> _S28
    t ^= x
    t &= _M28
    x ^= t
    x ^= t << _S28
    return x


def undo_planes(raw, width, count):
    """raw: (N, width * count) uint8, each row a channel's format-3 values
    (bit planes of the first count - count % 8 values, then the rest as
    they are) -> (N, count) unsigned ints of `width` bytes."""
    n_rows = raw.shape[0]
    whole = count - count % 8
    groups = whole // 8
    out = np.empty((n_rows, count), dtype="<u%d" % width)
    if groups:
        planes = raw[:, :whole * width].reshape(n_rows, width, 8, groups)
        # word [row, g, b]: byte s is plane 8b + s's byte g
        words = np.ascontiguousarray(planes.transpose(0, 3, 1, 2)).view("<u8").reshape(n_rows, groups, width)
        transpose8x8(words)  # byte j of word [row, g, b] is now byte b of value 8g + j
        values = words.view(np.uint8).reshape(n_rows, groups, width, 8).transpose(0, 1, 3, 2)
        out[:, :whole].view(np.uint8).reshape(n_rows, groups, 8, width)[:] = values
    if count > whole:
        out[:, whole:] = raw[:, whole * width:].copy().view("<u%d" % width)
    return out


def crc32c_of(head, body):
    if _crc32c_module is not None:
        return _crc32c_module.crc32c(body, _crc32c_module.crc32c(head))
    return None


def check_frame(frame, count):
    """The checks HapticLab makes on a format-3 frame before decompressing;
    returns its content size."""
    if len(frame) <= 4 or frame[:4] != ZSTD_MAGIC:
        raise ChunkDamage("the zstd frame does not decompress (no zstd magic number)")
    try:
        params = zstandard.get_frame_parameters(frame)
        header_size = zstandard.frame_header_size(frame)
    except zstandard.ZstdError as e:
        raise ChunkDamage(f"the zstd frame does not decompress (no valid frame header: {e})") from None
    limit = len(WIDTH) + count * MAX_BODY_PER_UPDATE
    if params.content_size == zstandard.CONTENTSIZE_UNKNOWN or params.content_size > limit:
        raise ChunkDamage(f"the zstd frame states {params.content_size} bytes; at most {limit} allowed")
    if not params.has_checksum:
        raise ChunkDamage("the zstd frame carries no content checksum")
    try:
        end = hapticlab_db._frame_end(frame, header_size, True)
    except hapticlab_db.ChunkError as e:
        raise ChunkDamage(e.problem) from None
    if end != len(frame):
        raise ChunkDamage(f"{len(frame) - end} bytes follow the zstd frame")
    return params.content_size


class Batch:
    """The decoded channels of some trials' chunks, laid end to end in chunk
    order: t (float64), and the float32 channels of FLOAT_CHANNELS."""

    def __init__(self, chunks, dctx):
        self.total = sum(c[3] for c in chunks)
        self.t = np.empty(self.total, dtype=np.float64)
        dt = np.empty(self.total, dtype=np.uint64)
        f32 = np.empty((len(FLOAT_CHANNELS), self.total), dtype=np.uint32)
        self.starts = []
        # (width, count) -> [(body, offset, destination array row, start)] of tag-0 channels
        planes = {}
        running = []  # (start, count, t0) of t_s stored as a running sum
        start = 0
        if _crc32c_module is None:
            stored = [struct.unpack_from("<I", c[4], 1)[0] for c in chunks]
            computed = hapticlab_db._crc32c_many([hapticlab_db._checked_message(*c[:4], c[4]) for c in chunks])
        for k, (trial, hand, first, count, blob) in enumerate(chunks):
            self.starts.append(start)
            try:
                if _crc32c_module is not None:
                    got = crc32c_of(struct.pack("<qqqqB", trial, hand, first, count, blob[0]),
                                    memoryview(blob)[HEADER:])
                    if got != struct.unpack_from("<I", blob, 1)[0]:
                        raise ChunkDamage("checksum mismatch: the chunk is damaged")
                elif int(computed[k]) != stored[k]:
                    raise ChunkDamage("checksum mismatch: the chunk is damaged")
                if blob[0] == hapticlab_db.FORMAT_CURRENT:
                    frame = memoryview(blob)[HEADER:]
                    size = check_frame(frame, count)
                    try:
                        body = dctx.decompress(frame)
                    except zstandard.ZstdError as e:
                        raise ChunkDamage(f"the zstd frame does not decompress: {e}") from None
                    if len(body) != size:
                        raise ChunkDamage("the zstd frame does not decompress to its stated size")
                    self._walk(body, count, start, planes, running, dt, f32)
                else:
                    # Formats 0 and 1 (files from before 0.2): the reference reader.
                    ch = hapticlab_db._decode_verified(first, count, bytes(blob), blob[0])
                    self.t[start:start + count] = ch["t_s"]
                    for row, c in enumerate(FLOAT_CHANNELS):
                        f32[row, start:start + count] = ch[hapticlab_db.CHANNEL_NAMES[c]].view(np.uint32)
            except (ChunkDamage, hapticlab_db.ChunkError) as e:
                raise ChunkDamage(f"damaged sample chunk: {chunk_name(trial, hand, first, count)}: {e}") from None
            start += count
        # Undo the bit planes and differences, a group of equal (width, count) at a time.
        for (width, count), segments in planes.items():
            raw = np.empty((len(segments), width * count), dtype=np.uint8)
            for i, (body, offset, _, _) in enumerate(segments):
                raw[i] = np.frombuffer(body, dtype=np.uint8, count=width * count, offset=offset)
            values = undo_planes(raw, width, count)
            np.cumsum(values, axis=1, dtype=values.dtype, out=values)  # wraps modulo 2^32 / 2^64
            for i, (_, _, dest, at) in enumerate(segments):
                dest[at:at + count] = values[i]
        # t_s as a running sum of dt_s (in order, float64, as the format says).
        by_count = {}
        for at, count, t0 in running:
            by_count.setdefault(count, []).append((at, t0))
        for count, rows in by_count.items():
            terms = np.empty((len(rows), count), dtype=np.float64)
            for i, (at, _) in enumerate(rows):
                terms[i] = dt[at:at + count].view(np.float64)
            terms[:, 0] = [t0 for _, t0 in rows]
            np.cumsum(terms, axis=1, out=terms)
            for i, (at, _) in enumerate(rows):
                self.t[at:at + count] = terms[i]
        self.f32 = f32.view(np.float32)

    def _walk(self, body, count, start, planes, running, dt, f32):
        """Walks the tags of all 28 channels of a preconditioned body (as
        analyze does: a wrong tag or size anywhere is damage), noting where
        each needed per-update channel's planes are and filling the
        constants."""
        pos = 0
        t_tag = None
        size = len(body)
        for c in range(len(WIDTH)):
            if pos >= size:
                raise ChunkDamage("blob too short for its count")
            tag = body[pos]
            pos += 1
            width = WIDTH[c]
            if tag == hapticlab_db.TAG_PER_UPDATE:
                if pos + count * width > size:
                    raise ChunkDamage("blob too short for its count")
                if c == T:
                    planes.setdefault((8, count), []).append((body, pos, self.t.view(np.uint64), start))
                elif c == DT:
                    dt_at = pos
                elif c in ROW:
                    planes.setdefault((4, count), []).append((body, pos, f32[ROW[c]], start))
                pos += count * width
            elif tag == hapticlab_db.TAG_CONSTANT:
                if pos + width > size:
                    raise ChunkDamage("blob too short for its count")
                if c == T:
                    self.t[start:start + count] = struct.unpack_from("<d", body, pos)[0]
                elif c == DT:
                    dt[start:start + count] = struct.unpack_from("<Q", body, pos)[0]
                elif c in ROW:
                    f32[ROW[c], start:start + count] = struct.unpack_from("<I", body, pos)[0]
                pos += width
            elif tag == hapticlab_db.TAG_RUNNING_SUM and c == T:
                running.append((start, count, struct.unpack_from("<d", body, pos)[0]))
                pos += 8
            else:
                raise ChunkDamage(f"channel {hapticlab_db.CHANNEL_NAMES[c]} has unknown tag {tag}")
            if c == DT:
                dt_tag = tag
            if c == T:
                t_tag = tag
        if pos != size:
            raise ChunkDamage(f"{size - pos} bytes follow the last channel")
        # dt_s is needed only for a running-sum t_s, and then it is plain differences.
        if t_tag == hapticlab_db.TAG_RUNNING_SUM and dt_tag == hapticlab_db.TAG_PER_UPDATE:
            planes.setdefault((8, count), []).append((body, dt_at, dt, start))


def prctiles(values, ps):
    """MATLAB's prctile for each p of `ps` (the unsorted values; at least one):
    x(i) at 100 (i - 0.5) / n, linear between; order statistics by
    np.partition, equal to sorting to the bit."""
    n = values.size
    picks = []
    for p in ps:
        h = n * p / 100.0 + 0.5
        if h <= 1.0:
            picks.append((0, 0, 0.0))
        elif h >= n:
            picks.append((n - 1, n - 1, 0.0))
        else:
            lower = math.floor(h)
            picks.append((lower - 1, lower, h - lower))
    kth = sorted({i for a, b, _ in picks for i in (a, b)})
    part = np.partition(values, kth)
    out = []
    for a, b, frac in picks:
        if a == b:
            out.append(float(part[a]))
        else:
            x, y = float(part[a]), float(part[b])
            out.append(x + frac * (y - x))
    return out


EVENT_SAMPLE_SLACK_S = 0.5  # trial_reader.cc kEventSampleSlack_s


def task_window(events, trial_end_s):
    """(start_s, end_s) or None, as analysis/metrics/trial_metrics.h defines it."""
    events = sorted(events, key=lambda e: e[0])  # stable, like the C++
    starts = [t for t, kind, _ in events if kind == "insertion_passed_20mm"]
    if not starts:
        return None
    start = starts[0]
    open_ = [False, False]
    last = None
    for t, kind, hand in events:
        if hand not in (0, 1) or kind not in ("contact_start", "contact_end"):
            continue
        if (kind == "contact_start") == open_[hand]:
            return None  # contacts out of turn: no window (the C++ says which event)
        open_[hand] = kind == "contact_start"
        if t >= start:
            last = t if last is None else max(last, t)
    if (open_[0] or open_[1]) and trial_end_s >= start:
        last = trial_end_s if last is None else max(last, trial_end_s)
    return None if last is None else (start, last)


def hand_metrics(t, f32, window):
    inside = (t >= window[0]) & (t <= window[1])
    n = int(np.count_nonzero(inside))
    x, y, z, vx, vy, vz, fx, fy, fz = (f32[row][inside].astype(np.float64) for row in range(9))
    f = np.sqrt(fx * fx + fy * fy + fz * fz)
    v = np.sqrt(vx * vx + vy * vy + vz * vz)
    f = f[f >= MIN_CONTACT_FORCE_N]
    nan = float("nan")
    if n:
        dx, dy, dz = np.diff(x), np.diff(y), np.diff(z)
        path = float(np.sqrt(dx * dx + dy * dy + dz * dz).sum())
    else:
        path = nan
    force = prctiles(f, (50.0, 95.0)) if f.size else (nan, nan)
    return {
        "samples": n, "force_samples": int(f.size),
        "force_median_N": force[0],
        "force_p95_N": force[1],
        "speed_median_m_per_s": prctiles(v, (50.0,))[0] if v.size else nan,
        "path_length_m": path,
    }


def libm_sin_cos(angles):
    """sin and cos of float64 angles, with the bits of the C library's
    sin() and cos(), which analyze calls: numpy's own float64 sin and cos
    (SVML on AVX-512) differ from them in the last bit for about half of
    all angles. So math.sin and math.cos, once per distinct angle: the
    angles are widened float32 readings, so a hand held still repeats them
    (demo study: 7.0 M angles in 1.3 M runs of one value, 0.29 M distinct).
    Angles are told apart by their bits (sin(-0.0) is -0.0)."""
    bits = angles.view(np.uint64)
    change = np.empty(bits.size, dtype=bool)
    change[:1] = True
    np.not_equal(bits[1:], bits[:-1], out=change[1:])
    run = np.cumsum(change) - 1
    distinct, back = np.unique(bits[change], return_inverse=True)
    values = distinct.view(np.float64).tolist()
    sines = np.fromiter(map(math.sin, values), dtype=np.float64, count=len(values))[back]
    cosines = np.fromiter(map(math.cos, values), dtype=np.float64, count=len(values))[back]
    return sines[run], cosines[run]


def hand_energy(f32):
    """The energy columns of one hand's samples (all of its trial, tick
    order), as analysis/metrics/device_energy.cc computes them: for each
    interval whose two updates are finite, W = F_prev·Δq per axis (device)
    and (F_prev − F_ve,prev)·Δq (engine), with F_ve the VE force in joint
    space (J^T F, core/engine/joint_transform.h, written out in its order);
    positive W summed as given out, negative as taken in, each in sample
    order from +0.0 (one float64 cumsum per sum: sequential, not numpy's
    pairwise sum)."""
    if f32.shape[1] == 0:
        return dict.fromkeys(ENERGY_COLUMNS, 0.0)
    q = f32[RAW.start:RAW.stop].astype(np.float64)
    f = f32[JOINT_FORCE.start:JOINT_FORCE.stop].astype(np.float64)
    ve = f32[VE_FORCE.start:VE_FORCE.stop].astype(np.float64)
    finite = np.isfinite(q).all(axis=0) & np.isfinite(f).all(axis=0) & np.isfinite(ve).all(axis=0)
    f_ve = np.zeros_like(q)
    touching = np.flatnonzero(finite & ((ve[0] != 0.0) | (ve[1] != 0.0) | (ve[2] != 0.0)))
    if touching.size:
        insertion = q[0, touching]
        sp, cp = libm_sin_cos(q[1, touching])
        sy, cy = libm_sin_cos(q[2, touching])
        f0, f1, f2 = ve[0, touching], ve[1, touching], ve[2, touching]
        # R_w's columns (e_yaw, e_pitch, -d_in) dotted with F, row 0 first.
        dot0 = (cy * f0 + 0.0 * f1) + sy * f2
        dot1 = ((-sy) * sp * f0 + cp * f1) + (cy * sp) * f2
        dot2 = ((-sy) * cp * f0 + (-sp) * f1) + (cy * cp) * f2
        f_ve[0, touching] = -dot2
        f_ve[1, touching] = insertion * dot1
        f_ve[2, touching] = (insertion * cp) * dot0
    counted = finite[1:] & finite[:-1]
    every = bool(counted.all())
    dq = q[:, 1:] - q[:, :-1]
    # Column 0 is each sum's +0.0 start, so the sign of a zero term never
    # shows (+0.0 + -0.0 is +0.0): a term is the work when positive (given)
    # or its negation (taken), else a zero of either sign, which changes no
    # sum after it.
    terms = np.zeros((12, q.shape[1]), dtype=np.float64)
    for axis in range(3):
        for k, work in enumerate((f[axis, :-1] * dq[axis], (f[axis, :-1] - f_ve[axis, :-1]) * dq[axis])):
            if not every:
                work = np.where(counted, work, 0.0)
            row = 4 * axis + 2 * k
            np.maximum(work, 0.0, out=terms[row, 1:])
            np.minimum(work, 0.0, out=terms[row + 1, 1:])
            np.negative(terms[row + 1, 1:], out=terms[row + 1, 1:])
    sums = np.cumsum(terms, axis=1)[:, -1].tolist()
    # per axis: device out, device in, engine out, engine in
    out = {}
    for axis, name in enumerate(("insertion", "pitch", "yaw")):
        out[f"device_out_{name}_J"] = sums[4 * axis]
        out[f"device_in_{name}_J"] = sums[4 * axis + 1]
    out["engine_out_J"] = (sums[2] + sums[6]) + sums[10]
    out["engine_in_J"] = (sums[3] + sums[7]) + sums[11]
    return out


def check_layout(chunks):
    """chunks: (trial, instrument, first_tick, count) in (trial, instrument,
    first_tick) order; raises ChunkDamage for a chunk out of place."""
    if not chunks:
        return
    a = np.array(chunks, dtype=np.int64)
    trial, hand, first, count = a.T
    bad = (hand < 0) | (hand > 1) | (first < 0) | (count < 1) | (count > hapticlab_db.MAX_CHUNK_UPDATES)
    same = (trial[1:] == trial[:-1]) & (hand[1:] == hand[:-1])
    overlap = np.zeros(len(a), dtype=bool)
    overlap[1:] = same & (first[1:] < first[:-1] + count[:-1])
    if bad.any() or overlap.any():
        k = int(np.flatnonzero(bad | overlap)[0])
        raise ChunkDamage(f"misplaced sample chunk: {chunk_name(*chunks[k])}: instrument 0 or 1, ticks from 0, "
                          f"count 1..{hapticlab_db.MAX_CHUNK_UPDATES}, no tick shared by two chunks")


def check_coverage(conn, by_trial):
    """Every update each complete trial stored is in its chunks, by the
    rules analyze applies (db/chunk_coverage_rules.h; the Python reader's
    coverage_findings): two queries for the whole study, then each trial's
    chunk spans. Raises ChunkDamage naming the first missing ticks."""
    logged = {}
    for trial_id, length in conn.execute(
            "SELECT e.trial_id, e.item_index FROM event e JOIN trial t ON t.id = e.trial_id "
            "WHERE t.status = 'complete' AND e.type = 'samples_missing' AND typeof(e.item_index) = 'integer'"):
        logged.setdefault(trial_id, collections.Counter())[length] += 1
    loops = {}
    for trial_id, *row in conn.execute(
            "SELECT l.trial_id, l.count, l.rejected_periods, l.dropped_samples FROM loop_timing l "
            "JOIN trial t ON t.id = l.trial_id WHERE t.status = 'complete' AND typeof(l.count) = 'integer' AND "
            "typeof(l.rejected_periods) = 'integer' AND typeof(l.dropped_samples) = 'integer'"):
        loops[trial_id] = hapticlab_db.loop_count(row)
    for trial_id in sorted(set(by_trial) | set(loops)):
        rows = by_trial.get(trial_id, ())
        spans = [[(r[2], r[3]) for r in rows if r[1] == hand] for hand in (0, 1)]
        found = hapticlab_db.coverage_findings(trial_id, spans, logged.get(trial_id, ()), loops.get(trial_id))
        if found:
            e = found[0]
            raise ChunkDamage(f"missing samples: {chunk_name(trial_id, e.instrument, e.first_tick, e.count)}: "
                              f"{e.problem}")


def trial_metrics(conn):
    trials = conn.execute(
        "SELECT t.id, p.code, t.task, s.name, t.repetition FROM trial t "
        "JOIN participant p ON p.id = t.participant_id JOIN setting s ON s.id = t.setting_id "
        "WHERE t.status = 'complete' ORDER BY t.id").fetchall()
    # Updates the writer could not store: path length and energy, which
    # would bridge a gap with one straight step, are left out (as
    # analysis/study/trial_reader.cc's leave_out_across_gaps).
    gaps = {}
    for trial_id, t_s in conn.execute(
            "SELECT e.trial_id, e.t_s FROM event e JOIN trial t ON t.id = e.trial_id "
            "WHERE t.status = 'complete' AND e.type = 'samples_missing'"):
        gaps.setdefault(trial_id, []).append(t_s)
    events = {}
    for trial_id, t_s, kind, hand in conn.execute(
            "SELECT e.trial_id, e.t_s, e.type, e.instrument FROM event e JOIN trial t ON t.id = e.trial_id "
            "WHERE t.status = 'complete' AND e.type IN ('insertion_passed_20mm', 'contact_start', 'contact_end') "
            "ORDER BY e.trial_id, e.id"):
        events.setdefault(trial_id, []).append((t_s, kind, hand))
    rows = conn.execute(
        "SELECT c.trial_id, c.instrument, c.first_tick, c.count, c.data FROM sample_chunk c "
        "JOIN trial t ON t.id = c.trial_id WHERE t.status = 'complete' "
        "ORDER BY c.trial_id, c.instrument, c.first_tick")
    check_layout_rows = []
    by_trial = {}
    for r in rows:
        if not (isinstance(r[4], bytes) and len(r[4]) >= HEADER):
            raise ChunkDamage(f"damaged sample chunk: {chunk_name(*r[:4])}: no blob of at least {HEADER} bytes")
        check_layout_rows.append(r[:4])
        by_trial.setdefault(r[0], []).append(r)
    check_layout(check_layout_rows)
    check_coverage(conn, by_trial)
    dctx = zstandard.ZstdDecompressor()
    out = []
    for b in range(0, len(trials), TRIALS_PER_BATCH):
        mine = trials[b:b + TRIALS_PER_BATCH]
        chunks = [c for tr in mine for c in by_trial.get(tr[0], ())]
        batch = Batch(chunks, dctx)
        k = 0
        for trial_id, participant, task, setting, repetition in mine:
            hands = [None, None]
            for c in by_trial.get(trial_id, ()):
                at, count = batch.starts[k], c[3]
                k += 1
                lo, hi = hands[c[1]] or (at, at)
                hands[c[1]] = (lo, at + count)
            ends = [batch.t[h[1] - 1] for h in hands if h is not None]
            window = task_window(events.get(trial_id, []), max(ends)) if ends else None
            # A window reaching past the samples (events of another clock):
            # measures missing, as analysis/study/trial_reader.cc says.
            firsts = [batch.t[h[0]] for h in hands if h is not None]
            if window is not None and (window[0] < min(firsts) - EVENT_SAMPLE_SLACK_S or
                                       window[1] > max(ends) + EVENT_SAMPLE_SLACK_S):
                window = None
            for hand in (0, 1):
                row = {"trial_id": trial_id, "participant": participant, "task": task, "setting": setting,
                       "repetition": repetition, "instrument": hand}
                if window is None or hands[hand] is None:
                    row.update({m: float("nan") for m in MEASURES})
                else:
                    lo, hi = hands[hand]
                    row.update(hand_metrics(batch.t[lo:hi], batch.f32[:, lo:hi], window))
                    row["completion_time_s"] = window[1] - window[0]
                # Over the whole trial, window or not (a hand without samples: none given or taken).
                if ends and trial_id not in gaps:
                    lo, hi = hands[hand] or (0, 0)
                    row.update(hand_energy(batch.f32[:, lo:hi]))
                else:
                    row.update({c: float("nan") for c in ENERGY_COLUMNS})
                if window is not None and any(window[0] <= t <= window[1] for t in gaps.get(trial_id, ())):
                    row["path_length_m"] = float("nan")
                out.append(row)
    return out


def average_ranks(values):
    """Ranks 1..n, ties given their average rank (as scipy's rankdata)."""
    order = np.argsort(values, kind="stable")
    s = values[order]
    new = np.concatenate(([True], s[1:] != s[:-1]))
    group = np.cumsum(new) - 1                                  # tie group of each sorted value
    first = np.flatnonzero(new)                                 # its first sorted position
    last = np.concatenate((first[1:], [s.size])) - 1            # its last
    ranks = np.empty(s.size)
    ranks[order] = (first[group] + last[group]) / 2.0 + 1.0
    return ranks, np.diff(np.concatenate((first, [s.size])))


def chi2_sf(x, df):
    """P(X > x) for X chi-square with df (>= 1) degrees of freedom: the
    closed forms (a finite Poisson sum for even df, erfc plus a finite sum
    for odd)."""
    if x <= 0.0:
        return 1.0
    half = x / 2.0
    if df % 2 == 0:
        term = math.exp(-half)
        total = term
        for j in range(1, df // 2):
            term *= half / j
            total += term
        return total
    total = math.erfc(math.sqrt(half))
    term = math.exp(-half) * math.sqrt(half) / math.gamma(1.5)
    for j in range(1, (df - 1) // 2 + 1):
        total += term
        term *= half / (j + 0.5)
    return total


def friedman_replicates(cells):
    """MATLAB friedman(X, reps): cells[block][treatment] = list of r values.
    Ranks within each block over all its r·k values; tie-corrected."""
    b = len(cells)
    k = len(cells[0])
    r = len(cells[0][0])
    n = r * k
    rank_sums = np.zeros(k)
    tie_term = 0.0
    for block in cells:
        values = np.concatenate([np.asarray(c, dtype=float) for c in block])
        ranks, counts = average_ranks(values)
        rank_sums += ranks.reshape(k, r).sum(axis=1)
        tie_term += float((counts ** 3 - counts).sum())
    expected = b * r * (n + 1) / 2.0
    sigma_sq = n * (n + 1) / 12.0 - tie_term / (12.0 * b * (n - 1))
    if sigma_sq <= 1e-12 * n * (n + 1):
        q = 0.0
    else:
        q = float(((rank_sums - expected) ** 2).sum()) / (b * r * sigma_sq)
    return q, chi2_sf(q, k - 1)


def table_3_4(rows):
    """Friedman per participant, task, measure: both instruments as blocks
    (instrument "both"), then each alone; settings missing from a block left out,
    each cell cut to the smallest replicate count."""
    out = []
    keys = sorted({(r["participant"], r["task"]) for r in rows})
    for participant, task in keys:
        mine = sorted([r for r in rows if r["participant"] == participant and r["task"] == task],
                      key=lambda r: r["repetition"])
        for hand in ("both", 0, 1):
            for m in MEASURES:
                if hand != "both" and m not in PER_HAND:
                    continue
                cells = {}
                for r in mine:
                    if m not in PER_HAND and r["instrument"] != 0:
                        continue  # one value per trial
                    if hand != "both" and r["instrument"] != hand:
                        continue
                    value = r[m]
                    if not math.isfinite(value):
                        continue
                    block = r["instrument"] if m in PER_HAND else "trial"
                    cells.setdefault(block, {}).setdefault(r["setting"], []).append(value)
                settings = sorted({s for block in cells.values() for s in block})
                settings = [s for s in settings if all(s in block for block in cells.values())]
                if len(settings) < 2:
                    continue
                reps = min(len(block[s]) for block in cells.values() for s in settings)
                table = [[block[s][:reps] for s in settings] for block in cells.values()]
                q, p = friedman_replicates(table)
                out.append({"participant": participant, "task": task, "instrument": hand, "measure": m,
                            "chi_square": q, "p": p})
    return out


def write_csv(path, rows):
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        for r in rows:
            writer.writerow({k: repr(v) if isinstance(v, float) else v for k, v in r.items()})


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("db")
    parser.add_argument("--metrics-out")
    parser.add_argument("--friedman-out")
    args = parser.parse_args()
    conn = sqlite3.connect("file:" + args.db + "?mode=ro", uri=True)
    try:
        rows = trial_metrics(conn)
    except ChunkDamage as e:
        print(f"{args.db}: {e}", file=sys.stderr)
        return 1
    tests = table_3_4(rows)
    if args.metrics_out:
        write_csv(args.metrics_out, rows)
    if args.friedman_out and tests:
        write_csv(args.friedman_out, tests)
    crc = "python3-crc32c" if _crc32c_module is not None else "numpy (python3-crc32c not installed: slower)"
    print(f"{len(rows) // 2} trials, {len(tests)} Friedman tests; CRC-32C by {crc}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
