#!/usr/bin/env python3
"""A minimal driver side of the HapticLab UDP bridge (docs/udp_bridge.md).

Run it next to your device driver, then `hapticlab session run --device
udp:127.0.0.1:5000`. Replace read_encoders() and apply_forces() with your
device's calls; fill RATINGS with your device's limits. Standard library only.
"""
import argparse
import socket
import struct
import time

MAGIC, VERSION = 0x42554C48, 1
HELLO, HELLO_REPLY, CONFIGURE, ACTIVATE, DEACTIVATE, ACK, POLL, STATE, COMMAND = range(1, 10)
PAYLOAD = {HELLO: 0, CONFIGURE: 16, ACTIVATE: 0, DEACTIVATE: 0, POLL: 0, COMMAND: 80, 10: 48, 11: 248}
HEADER = struct.Struct("<IHHId")  # magic, version, type, sequence, time_s: 20 bytes
FLAG_SIMULATED, FLAG_CALIBRATED = 1, 2

# CRC-32C (Castagnoli), reflected polynomial 0x82F63B78; zlib.crc32 is another CRC.
_TABLE = []
for _i in range(256):
    _c = _i
    for _ in range(8):
        _c = (_c >> 1) ^ 0x82F63B78 if _c & 1 else _c >> 1
    _TABLE.append(_c)


def crc32c(data: bytes) -> int:
    crc = 0xFFFFFFFF
    for b in data:
        crc = _TABLE[(crc ^ b) & 0xFF] ^ (crc >> 8)
    return crc ^ 0xFFFFFFFF


assert crc32c(b"123456789") == 0xE3069283

# Per joint (insertion [m], pitch, yaw, twist, grip [rad]): min, max position,
# continuous force, peak force [N or N·m], max velocity [units/s]. Illustrative
# values: put your device's here, for both instruments.
RATINGS = [
    (0.0, 0.25, 2.0, 8.0, 2.0),
    (-1.0, 1.0, 0.2, 0.8, 20.0),
    (-1.0, 1.0, 0.2, 0.8, 20.0),
    (-3.2, 3.2, 0.0, 0.0, 40.0),
    (0.0, 0.6, 0.05, 0.2, 40.0),
] * 2


def read_encoders():
    """Your device's newest reading: 2 instruments x 5 joints."""
    return [[0.1, 0.0, 0.0, 0.0, 0.3], [0.1, 0.0, 0.0, 0.0, 0.3]]


def apply_forces(forces):
    """Send 2 x 5 forces [N, N·m] to your amplifiers, now."""


def packet(kind, seq, t, payload=b""):
    body = HEADER.pack(MAGIC, VERSION, kind, seq, t) + payload
    return body + struct.pack("<I", crc32c(body))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--port", type=int, default=5000)
    parser.add_argument("--host", default="127.0.0.1")
    args = parser.parse_args()
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind((args.host, args.port))
    print(f"driver on udp:{args.host}:{args.port}", flush=True)
    seq, start, active = 0, time.monotonic(), False
    while True:
        data, peer = sock.recvfrom(2048)
        if len(data) < 24 or struct.unpack_from("<I", data, len(data) - 4)[0] != crc32c(data[:-4]):
            continue  # malformed: ignore it
        magic, version, kind, req_seq, t = HEADER.unpack_from(data)
        if magic != MAGIC or version != VERSION or len(data) != 24 + PAYLOAD.get(kind, -1000):
            continue
        seq += 1
        now = time.monotonic() - start
        if kind == HELLO:
            name = b"my-device".ljust(32, b"\0")
            ratings = b"".join(struct.pack("<5d", *r) for r in RATINGS)
            sock.sendto(packet(HELLO_REPLY, seq, now, struct.pack("<II", req_seq, FLAG_CALIBRATED) + name + ratings),
                        peer)
        elif kind in (CONFIGURE, ACTIVATE, DEACTIVATE):
            active = kind == ACTIVATE
            if kind == DEACTIVATE:
                apply_forces([[0.0] * 5, [0.0] * 5])
            sock.sendto(packet(ACK, seq, now, struct.pack("<Ii", req_seq, 0)), peer)
        elif kind == POLL:
            position = [x for instrument in read_encoders() for x in instrument]
            zeros = [0.0] * 20  # hand and motor force: simulated devices only
            sock.sendto(packet(STATE, seq, now, struct.pack("<Iid", req_seq, 0 if active else 2, now) +
                               struct.pack("<30d", *position, *zeros)), peer)
        elif kind == COMMAND and active:
            f = struct.unpack_from("<10d", data, 20)
            apply_forces([list(f[:5]), list(f[5:])])


if __name__ == "__main__":
    main()
