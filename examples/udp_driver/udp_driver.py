#!/usr/bin/env python3
"""A minimal driver side of the HapticLab UDP bridge (docs/udp_bridge.md), format version 2.

Run it next to your device driver, then `hapticlab session run --device
udp:127.0.0.1:5000`. Replace read_encoders() and apply_forces() with your
device's calls; fill RATINGS with your device's limits. Standard library only.

Authentication: with --key-file KEY (the same file HapticLab gets as
`--device-option key_file=KEY`; make one with `hapticlab device keygen --out
KEY`), every datagram carries an HMAC-SHA-256 made with the key, and this
driver ignores any that does not, or that belongs to another session or
repeats an earlier one: a forged COMMAND moves nothing. Without a key, the
MAC is made with the empty key (a checksum that anyone can compute), for
loopback only.
"""
import argparse
import hashlib
import hmac
import os
import secrets
import signal
import socket
import stat
import struct
import sys
import time

MAGIC, VERSION = 0x42554C48, 2
HELLO, HELLO_REPLY, CONFIGURE, ACTIVATE, DEACTIVATE, ACK, POLL, STATE, COMMAND, SET_START_POSE, HAND = range(1, 12)
PAYLOAD = {HELLO: 0, CONFIGURE: 16, ACTIVATE: 0, DEACTIVATE: 0, POLL: 0, COMMAND: 80, SET_START_POSE: 48, HAND: 248}
# magic, version, type, sequence, flags, host nonce, device nonce, time_s: 40 bytes
HEADER = struct.Struct("<IHHIIQQd")
MAC_BYTES = 16
FLAG_KEYED = 1
# While active, a session whose host sends no valid COMMAND for this long is
# taken as dead: zero force, inactive (the host may be the thing that died).
# A few loop periods at the slowest rate (150 Hz), and above the host's own
# read timeout (timeout_ms, 10 ms by default). --command-timeout-ms sets it.
COMMAND_TIMEOUT_S = 0.05
FLAG_SIMULATED, FLAG_CALIBRATED = 1, 2

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


def newer(a, b):
    """Whether sequence a comes after b, modulo 2**32 (sequences wrap)."""
    return 0 < (a - b) % 2**32 < 2**31


def read_key(path):
    """The key in `path`: hex on one line, in a file only its owner may read (mode 600)."""
    mode = stat.S_IMODE(os.stat(path).st_mode)
    if mode & 0o077:
        sys.exit(f"--key-file: {path} is open to other users (mode {mode:04o}); chmod 600 it")
    with open(path, encoding="ascii") as f:
        text = f.read().rstrip("\r\n")
    if len(text) < 32 or len(text) % 2:
        sys.exit(f"--key-file: {path} must hold an even number of hex digits, at least 32 (e.g. `openssl rand -hex 32`)")
    return bytes.fromhex(text)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--port", type=int, default=5000, help="UDP port (0: any free one, printed)")
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--key-file", help="the bridge's shared key (hex, mode 600)")
    parser.add_argument("--command-timeout-ms", type=float, default=1e3 * COMMAND_TIMEOUT_S,
                        help="zero the force when an active session sends no COMMAND for this long")
    parser.add_argument("--insecure", action="store_true",
                        help="serve an address beyond loopback without a key (anyone there could move the device)")
    args = parser.parse_args()
    command_timeout_s = args.command_timeout_ms / 1e3
    key = read_key(args.key_file) if args.key_file else b""
    if not key and not args.insecure and not args.host.startswith("127."):
        sys.exit(f"--host {args.host}: refused: without --key-file anyone on the network could send COMMANDs to "
                 "this device; give the key file HapticLab uses (device-option key_file), or say --insecure")
    flags = FLAG_KEYED if key else 0

    def mac(body):
        return hmac.digest(key, body, "sha256")[:MAC_BYTES]

    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind((args.host, args.port))
    print(f"driver on udp:{args.host}:{sock.getsockname()[1]} "
          f"({'authenticated' if key else 'not authenticated: no --key-file'})", flush=True)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))

    seq, start, active = 0, time.monotonic(), False
    host_nonce = device_nonce = host_seq = 0  # the session; 0: none yet
    last_command = 0.0  # time.monotonic() of the session's last valid COMMAND (or ACTIVATE)
    counts = dict(received=0, malformed=0, rejected_mac=0, wrong_nonce=0, old_sequence=0, commands=0,
                  busy_hello=0, command_timeouts=0)
    peak_force = held_force = 0.0  # the largest force applied; the largest of the last command

    def apply(forces):
        nonlocal held_force
        held_force = max(abs(x) for instrument in forces for x in instrument)
        apply_forces(forces)

    def zero():
        apply([[0.0] * 5, [0.0] * 5])

    def send(kind, payload, peer):
        nonlocal seq
        seq += 1
        body = HEADER.pack(MAGIC, VERSION, kind, seq, flags, host_nonce, device_nonce,
                           time.monotonic() - start) + payload
        sock.sendto(body + mac(body), peer)

    try:
        while True:
            # While active, wake up in time to notice a host that went silent
            # (checked on every datagram too: a flood must not keep it from it).
            sock.settimeout(command_timeout_s / 2 if active else None)
            try:
                data, peer = sock.recvfrom(2048)
            except socket.timeout:
                data = None
            if active and time.monotonic() - last_command > command_timeout_s:
                zero()
                active = False
                counts["command_timeouts"] += 1
            if data is None:
                continue
            counts["received"] += 1
            if len(data) < HEADER.size + MAC_BYTES:
                counts["malformed"] += 1
                continue
            magic, version, kind, req_seq, req_flags, req_host, req_device, t = HEADER.unpack_from(data)
            if magic != MAGIC or version != VERSION or len(data) != HEADER.size + PAYLOAD.get(kind, -1000) + MAC_BYTES:
                counts["malformed"] += 1
                continue
            # Authenticated (or, without a key, intact), with our choice of key, not the sender's.
            if (req_flags & FLAG_KEYED) != flags or not hmac.compare_digest(data[-MAC_BYTES:], mac(data[:-MAC_BYTES])):
                counts["rejected_mac"] += 1
                continue
            # Of this session and newer than anything in it: not a replay.
            if kind == HELLO:
                if req_host == 0 or req_device != 0:
                    counts["wrong_nonce"] += 1
                    continue
                if req_host == host_nonce and not newer(req_seq, host_seq):
                    counts["old_sequence"] += 1
                    continue
                if req_host != host_nonce:
                    # Another session while this one is live (a replayed HELLO, a second
                    # program on the same driver): refused, so the live host keeps its
                    # device, and its zero COMMAND and DEACTIVATE still count.
                    if active and time.monotonic() - last_command <= command_timeout_s:
                        counts["busy_hello"] += 1
                        continue
                    host_nonce, device_nonce = req_host, secrets.randbits(64) or 1
            elif req_host != host_nonce or req_device != device_nonce or host_nonce == 0:
                counts["wrong_nonce"] += 1
                continue
            elif not newer(req_seq, host_seq):
                counts["old_sequence"] += 1
                continue
            host_seq = req_seq

            now = time.monotonic() - start
            if kind == HELLO:
                # A new session starts from zero force, whatever the last one left.
                zero()
                active = False
                name = b"my-device".ljust(32, b"\0")
                ratings = b"".join(struct.pack("<5d", *r) for r in RATINGS)
                send(HELLO_REPLY, struct.pack("<II", req_seq, FLAG_CALIBRATED) + name + ratings, peer)
            elif kind in (CONFIGURE, ACTIVATE, DEACTIVATE):
                active = kind == ACTIVATE
                last_command = time.monotonic()
                if kind == DEACTIVATE:
                    zero()
                send(ACK, struct.pack("<Ii", req_seq, 0), peer)
            elif kind == POLL:
                position = [x for instrument in read_encoders() for x in instrument]
                zeros = [0.0] * 20  # hand and motor force: simulated devices only
                send(STATE, struct.pack("<Iid", req_seq, 0 if active else 2, now) +
                     struct.pack("<30d", *position, *zeros), peer)
            elif kind == COMMAND and active:
                f = struct.unpack_from("<10d", data, HEADER.size)
                last_command = time.monotonic()
                counts["commands"] += 1
                peak_force = max([peak_force] + [abs(x) for x in f])
                apply([list(f[:5]), list(f[5:])])
    finally:
        print("stopped: " + ", ".join(f"{k} {v}" for k, v in counts.items()) +
              f", largest force applied {peak_force:g}, force held at stop {held_force:g}", flush=True)
        zero()


if __name__ == "__main__":
    main()
