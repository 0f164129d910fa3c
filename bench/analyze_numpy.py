#!/usr/bin/env python3
"""The comparator for `hapticlab bench analyze --compare`: what a researcher
would write in an afternoon instead of using `hapticlab analyze`.

It reads a study database with Python's sqlite3, decodes every sample chunk
with numpy (python/hapticlab_db.py's decoder, np.frombuffer per channel,
without the CRC-32C check that analyze makes), computes the per-trial metrics of `hapticlab analyze` (task
window, median and 95th-percentile |F| over samples with |F| >= 1 mN,
median |v|, path length; percentiles as MATLAB's prctile) and runs the
Table 3.4 Friedman tests (per participant and task: both hands as blocks,
then each hand alone; repetitions as replicates, balanced as MATLAB's
friedman(X, reps) needs), with scipy for ranks and the chi-square tail.

The same work as `hapticlab analyze --no-ks --no-plots`, without the report.
Its metrics are checked against analyze's in CI
(tests/python/test_analyze_numpy.py); only its speed is benchmarked.

    analyze_numpy.py STUDY.db [--metrics-out CSV] [--friedman-out CSV]
"""
import argparse
import csv
import os
import sqlite3
import sys

import numpy as np
from scipy import stats

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
import hapticlab_db  # noqa: E402  (the reader that ships with HapticLab)

MIN_CONTACT_FORCE_N = 1e-3
MEASURES = ("force_median_N", "force_p95_N", "completion_time_s", "speed_median_m_per_s", "path_length_m")
PER_HAND = {"force_median_N", "force_p95_N", "speed_median_m_per_s", "path_length_m"}


def prctile(sorted_values, p):
    """MATLAB's prctile on sorted data: x(i) at 100 (i - 0.5) / n, linear between."""
    n = sorted_values.size
    h = n * p / 100.0 + 0.5
    if h <= 1.0:
        return float(sorted_values[0])
    if h >= n:
        return float(sorted_values[-1])
    lower = np.floor(h)
    i = int(lower) - 1
    a, b = float(sorted_values[i]), float(sorted_values[i + 1])
    return a + (h - lower) * (b - a)


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
        open_[hand] = kind == "contact_start"
        if t >= start:
            last = t if last is None else max(last, t)
    if (open_[0] or open_[1]) and trial_end_s >= start:
        last = trial_end_s if last is None else max(last, trial_end_s)
    return None if last is None else (start, last)


def read_hand(conn, trial_id, hand):
    """t_s, position (n,3), velocity (n,3), force (n,3) of one hand, float64."""
    rows = conn.execute("SELECT first_tick, count, data FROM sample_chunk WHERE trial_id = ? AND instrument = ? "
                        "ORDER BY first_tick", (trial_id, hand)).fetchall()
    if not rows:
        return None
    # No checksum: a researcher's script would not verify one (hapticlab
    # analyze does, so this favours the script).
    parts = [hapticlab_db._decode_verified(first, count, blob, blob[0]) for first, count, blob in rows]

    def channel(name):
        return np.concatenate([p[name] for p in parts]).astype(np.float64)

    def vec(names):
        return np.column_stack([channel(name) for name in names])

    return channel("t_s"), vec(POSITION), vec(VELOCITY), vec(FORCE)


def hand_metrics(t, position, velocity, force, window):
    inside = (t >= window[0]) & (t <= window[1])
    n = int(inside.sum())
    f = np.sqrt(force[inside, 0] * force[inside, 0] + force[inside, 1] * force[inside, 1]
                + force[inside, 2] * force[inside, 2])
    v = np.sqrt(velocity[inside, 0] * velocity[inside, 0] + velocity[inside, 1] * velocity[inside, 1]
                + velocity[inside, 2] * velocity[inside, 2])
    f = np.sort(f[f >= MIN_CONTACT_FORCE_N])
    v = np.sort(v)
    step = np.diff(position[inside], axis=0)
    path = float(np.sqrt((step * step).sum(axis=1)).sum()) if n else float("nan")
    nan = float("nan")
    return {
        "samples": n, "force_samples": int(f.size),
        "force_median_N": prctile(f, 50.0) if f.size else nan,
        "force_p95_N": prctile(f, 95.0) if f.size else nan,
        "speed_median_m_per_s": prctile(v, 50.0) if v.size else nan,
        "path_length_m": path,
    }


def trial_metrics(conn):
    trials = conn.execute(
        "SELECT t.id, p.code, t.task, s.name, t.repetition, t.status FROM trial t "
        "JOIN participant p ON p.id = t.participant_id JOIN setting s ON s.id = t.setting_id "
        "WHERE t.status = 'complete' ORDER BY t.id").fetchall()
    rows = []
    for trial_id, participant, task, setting, repetition, _ in trials:
        hands = [read_hand(conn, trial_id, h) for h in (0, 1)]
        ends = [h[0][-1] for h in hands if h is not None and h[0].size]
        events = conn.execute("SELECT t_s, type, instrument FROM event WHERE trial_id = ? ORDER BY id",
                              (trial_id,)).fetchall()
        window = task_window(events, max(ends)) if ends else None
        for hand in (0, 1):
            row = {"trial_id": trial_id, "participant": participant, "task": task, "setting": setting,
                   "repetition": repetition, "instrument": hand}
            if window is None or hands[hand] is None:
                row.update({m: float("nan") for m in MEASURES})
            else:
                row.update(hand_metrics(*hands[hand], window))
                row["completion_time_s"] = window[1] - window[0]
            rows.append(row)
    return rows


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
        ranks = stats.rankdata(values)
        rank_sums += ranks.reshape(k, r).sum(axis=1)
        _, counts = np.unique(values, return_counts=True)
        tie_term += float((counts ** 3 - counts).sum())
    expected = b * r * (n + 1) / 2.0
    sigma_sq = n * (n + 1) / 12.0 - tie_term / (12.0 * b * (n - 1))
    if sigma_sq <= 1e-12 * n * (n + 1):
        q = 0.0
    else:
        q = float(((rank_sums - expected) ** 2).sum()) / (b * r * sigma_sq)
    return q, float(stats.chi2.sf(q, k - 1))


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
                    if not np.isfinite(value):
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


# The stored channels the metrics read (names as in db/README.md).
POSITION = ("tip_x_m", "tip_y_m", "tip_z_m")
VELOCITY = ("tip_vx_m_per_s", "tip_vy_m_per_s", "tip_vz_m_per_s")
FORCE = ("ve_force_x_N", "ve_force_y_N", "ve_force_z_N")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("db")
    parser.add_argument("--metrics-out")
    parser.add_argument("--friedman-out")
    args = parser.parse_args()
    conn = sqlite3.connect("file:" + args.db + "?mode=ro", uri=True)
    rows = trial_metrics(conn)
    tests = table_3_4(rows)
    if args.metrics_out:
        write_csv(args.metrics_out, rows)
    if args.friedman_out and tests:
        write_csv(args.friedman_out, tests)
    print(f"{len(rows) // 2} trials, {len(tests)} Friedman tests")
    return 0


if __name__ == "__main__":
    sys.exit(main())
