#!/usr/bin/env python3
"""A study file whose trial 1 holds eight valid all-zero sample chunks of
2^20 updates each (the format's own limit), four per instrument, end to
end: about 35 kB on disk, 4 Mi updates per instrument once decoded. Issue
34 measured the memory the readers took on such a file (export 2.4 GB,
`sim replay` 2.6 GB, the Python reader 3.3 GB); this makes it again, for
the binary given, so the figures can be taken before and after:

    bench/zero_chunk_study.py --hapticlab BIN --out FILE
    /usr/bin/time -v BIN export --db FILE --trial 1 --format csv --channels t_s --out DIR
    /usr/bin/time -v BIN sim replay --db FILE --trial 1 --out replay.csv
    /usr/bin/time -v python3 -c 'import sys; sys.path.insert(0, "python"); import hapticlab_db as h; \
        print(h.open_study("FILE").samples(1).size)'

The study is made by `BIN study create` (examples/protocols/thesis_quick.json);
the chunks are written as that binary's schema stores them: schema 7
(format 3, the checksum over trial, instrument, first tick and count, the
frame with its content checksum) or schema 6 (format 2, the checksum over
first tick and count, no frame checksum), so a binary from before issue 34
reads its own kind. Each chunk is valid: every channel stored per update,
all zero (a preconditioned body of zeros is zeros), in one zstd frame.
"""
import argparse
import os
import sqlite3
import struct
import subprocess
import sys

import zstandard

SOURCE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, os.path.join(SOURCE, "python"))
import hapticlab_db as h  # noqa: E402  (its CRC-32C)

COUNT = 1 << 20
CHUNKS_PER_INSTRUMENT = 4
BYTES_PER_UPDATE = 117  # every channel per update (db/README.md, "The chunk format")


def zero_chunk(schema, trial, instrument, first):
    body_size = 28 + BYTES_PER_UPDATE * COUNT  # 28 tags of 0 (per update), then zeros
    writer = zstandard.ZstdCompressor(level=1, write_checksum=schema >= 7).compressobj(size=body_size)
    zeros = bytes(1 << 20)
    frame = b"".join(writer.compress(zeros[:min(len(zeros), body_size - k)]) for k in range(0, body_size, len(zeros)))
    frame += writer.flush()
    fmt = 3 if schema >= 7 else 2
    place = struct.pack("<QQQQ", trial, instrument, first, COUNT) if schema >= 7 else struct.pack("<QQ", first, COUNT)
    crc = h.crc32c(place + bytes([fmt]) + frame)
    return bytes([fmt]) + struct.pack("<I", crc) + frame


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--hapticlab", required=True, help="the binary whose schema to write")
    ap.add_argument("--out", required=True, help="study file to make (must not exist)")
    args = ap.parse_args()
    if os.path.exists(args.out):
        sys.exit(f"{args.out} exists; give a new file")
    subprocess.run([args.hapticlab, "study", "create", "--protocol",
                    os.path.join(SOURCE, "examples/protocols/thesis_quick.json"), "--db", args.out],
                   check=True, stdout=subprocess.DEVNULL)
    conn = sqlite3.connect(args.out)
    schema = conn.execute("PRAGMA user_version").fetchone()[0]
    if schema < 6:
        sys.exit(f"{args.out}: schema {schema}; this script writes schemas 6 and 7")
    # A trial that ran has its session (db/structure_check.cc refuses one without).
    conn.execute("INSERT INTO session (participant_id, started_unix_s, ended_unix_s, device, clock, status) "
                 "SELECT participant_id, 1.7e9, 1.7e9, 'sim', 'virtual', 'closed' FROM trial WHERE id = 1")
    session, = conn.execute("SELECT max(id) FROM session").fetchone()
    conn.execute("UPDATE trial SET status = 'complete', session_id = ?, started_unix_s = 1.7e9, ended_unix_s = 1.7e9 "
                 "WHERE id = 1", (session,))
    for instrument in (0, 1):
        for k in range(CHUNKS_PER_INSTRUMENT):
            first = k * COUNT
            conn.execute("INSERT INTO sample_chunk (trial_id, instrument, first_tick, count, t0_s, data) "
                         "VALUES (1, ?, ?, ?, 0, ?)", (instrument, first, COUNT, zero_chunk(schema, 1, instrument, first)))
    conn.commit()
    conn.execute("PRAGMA journal_mode = DELETE")
    conn.close()
    print(f"{args.out}: schema {schema}, trial 1: {2 * CHUNKS_PER_INSTRUMENT} zero chunks of {COUNT} updates, "
          f"{os.path.getsize(args.out)} bytes")


if __name__ == "__main__":
    main()
