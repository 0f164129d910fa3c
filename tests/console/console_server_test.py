"""`hapticlab console`'s server under attack and under load, through raw
sockets against the real binary (issue 33):

- STOP (POST /api/session/stop) and GET /api/status answered, and the
  running trial aborted, within a bound under each load: none; 50 live
  streams; 200 idle connections; 200 slowloris connections (a head trickled
  a byte at a time); a flood of stream requests past the cap (refused 503,
  naming it); more connections than the table holds (the oldest idle ones
  dropped, STOP still served); slowloris heads cut at the head deadline
  (408);
- a Host other than the bound address refused (421, naming it), on both
  ports; the participant's port serves its page, script and stream only;
  security headers on every answer;
- bodies: the token before the body (a chunked body without it: 403 before
  its first byte is read), 16 kB for chunked bodies too (413 on the
  declared size), an oversized Content-Length refused at once, STOP with no
  body at all or an empty one, wrong JSON types, 64-bit ranges, a NUL, and
  lengths in characters;
- --token-file: a token of spaces, of one repeated character, or readable
  by others (its mode printed in octal) refused; a CRLF line end not part
  of the token; a new file made 0600 with 128 random bits;
- controls with no session: 409; every operator action (before the first
  trial, during one, between trials, and STOP) stored in operator_action
  before its 200, and still there after `kill -9` of the console;
  `study check` passes, the export has them.

Also the benchmark of STOP under load (BENCHMARKS.md):
    console_server_test.py HAPTICLAB_CLI SOURCE_DIR WORK_DIR --bench 20
prints p50/p99/max of STOP's answer and of the trial's end per load.

usage: console_server_test.py HAPTICLAB_CLI SOURCE_DIR WORK_DIR [--bench N]
"""
import argparse
import json
import os
import re
import shutil
import signal
import socket
import sqlite3
import subprocess
import sys
import time


def fail(message):
    sys.exit("FAIL: " + message)


# CI runs this beside a compile or under the sanitizers on two cores: the
# bound a check asserts is what a loaded machine meets with room; the
# figures printed (and the --bench run) are the real ones.
LOADED_BOUND_S = 1.0
BENCH = False  # --bench: measure, check nothing


class Console:
    """A `hapticlab console` process on free ports (wall clock unless told)."""

    def __init__(self, cli, db, *extra, clock="wall", training_trials=0):
        self.proc = subprocess.Popen([cli, "console", "--db", db, "--port", "0", "--clock", clock,
                                      "--training-trials", str(training_trials), *extra],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        lines = []
        while not any("participant screen: http://" in l for l in lines):
            line = self.proc.stdout.readline()
            if not line:
                fail("the console exited before listening:\n" + "".join(lines))
            lines.append(line)
        text = "".join(lines)
        m = re.search(r"console: http://127\.0\.0\.1:([0-9]+)/(#token=([0-9a-f]+))?", text)
        self.port = int(m.group(1))
        self.token_in_address = m.group(3)
        token_file = extra[extra.index("--token-file") + 1] if "--token-file" in extra else db + ".console-token"
        self.token = open(token_file).read().strip()
        self.participant_port = int(re.search(r"participant screen: http://127\.0\.0\.1:([0-9]+)/participant", text).group(1))

    def kill(self):
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


def connect(port, timeout=5.0):
    s = socket.create_connection(("127.0.0.1", port), timeout=timeout)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return s


def read_response(s, timeout=10.0):
    """(status, headers dict lower-case, body bytes) of one answer with a
    Content-Length; None when the server closed before answering."""
    s.settimeout(timeout)
    data = b""
    while b"\r\n\r\n" not in data:
        try:
            chunk = s.recv(65536)
        except ConnectionResetError:
            return None  # closed at accept (no slot), or reset
        if not chunk:
            return None
        data += chunk
    head, _, body = data.partition(b"\r\n\r\n")
    lines = head.decode("latin-1").split("\r\n")
    status = int(lines[0].split()[1])
    headers = {k.lower(): v.strip() for k, _, v in (l.partition(":") for l in lines[1:])}
    length = int(headers.get("content-length", "-1"))
    if length < 0:
        return status, headers, body
    while len(body) < length:
        chunk = s.recv(65536)
        if not chunk:
            break
        body += chunk
    return status, headers, body[:length]


def request(port, method, path, body=None, token=None, host=None, extra=b"", raw_body=None, timeout=10.0, sock=None):
    """One request; returns (status, headers, parsed JSON or text)."""
    own = sock is None
    s = sock or connect(port)
    try:
        payload = raw_body if raw_body is not None else (json.dumps(body).encode() if body is not None else None)
        head = f"{method} {path} HTTP/1.1\r\nHost: {host or f'127.0.0.1:{port}'}\r\n"
        if token:
            head += f"X-HapticLab-Token: {token}\r\n"
        if payload is not None and raw_body is None:
            head += f"Content-Length: {len(payload)}\r\nContent-Type: application/json\r\n"
        s.sendall(head.encode() + extra + b"\r\n" + (payload or b""))
        r = read_response(s, timeout)
        if r is None:
            return None
        status, headers, data = r
        try:
            return status, headers, json.loads(data)
        except ValueError:
            return status, headers, data.decode("utf-8", "replace")
    finally:
        if own:
            s.close()


def expect(what, result, status, contains=""):
    if result is None:
        fail(f"{what}: the connection closed without an answer")
    got, _, body = result
    if isinstance(body, bytes):
        try:
            body = json.loads(body)
        except ValueError:
            body = body.decode("utf-8", "replace")
    text = json.dumps(body) if not isinstance(body, str) else body
    if got != status or contains not in text:
        fail(f"{what}: expected {status} mentioning {contains!r}, got {got}: {text[:400]}")
    return body


def status_of(c, sock=None):
    r = request(c.port, "GET", "/api/status", token=c.token, sock=sock)
    return r[2] if r and isinstance(r[2], dict) else {}


def wait_for(what, predicate, timeout_s, explain=None):
    """`explain`, if given, returns what a timeout's message adds (the
    server's state then), so a failure under load says why."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        v = predicate()
        if v:
            return v
        time.sleep(0.02)
    fail(f"timed out after {timeout_s} s waiting for {what}" + (f"; {explain()}" if explain else ""))


def percentile(values, q):
    v = sorted(values)
    return v[min(len(v) - 1, int(round(q / 100 * (len(v) - 1))))]


# --- loads

class Load:
    def __init__(self, name):
        self.name = name
        self.socks = []

    def close(self):
        for s in self.socks:
            try:
                s.close()
            except OSError:
                pass
        self.socks = []


def streams(c, n, path=None, port=None):
    # (/events/live: the page's stream before issue 33, for the --bench of an older binary)
    if path is None:
        probe = request(c.port, "GET", "/events/operator", token=c.token, timeout=5)
        path = "/events/operator" if probe and probe[0] == 200 else "/events/live"
    load = Load(f"{n} live streams")
    for _ in range(n):
        s = connect(port or c.port)
        s.sendall(f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port or c.port}\r\nX-HapticLab-Token: {c.token}\r\n\r\n"
                  .encode())
        load.socks.append(s)
    for s in load.socks:  # each answered as a stream (they keep reading nothing more: the server buffers)
        if BENCH:
            break  # an older binary may answer only some (the --bench of the figures before)
        s.settimeout(5)
        head = s.recv(4096)
        if not head.startswith(b"HTTP/1.1 200") or b"text/event-stream" not in head:
            fail(f"a live stream was not served: {head[:200]!r}")
    return load


def idle(c, n):
    load = Load(f"{n} idle connections")
    for _ in range(n):
        load.socks.append(connect(c.port))
    return load


def slowloris(c, n):
    """n connections that each send the first bytes of a head, then a byte
    now and then (trickle() sends the next one)."""
    load = Load(f"{n} slowloris connections")
    load.started = time.monotonic()
    for _ in range(n):
        s = connect(c.port)
        s.sendall(b"GET /api/status HTTP/1.1\r\nHost: 127.0.0.1\r\nX-A: ")
        load.socks.append(s)
    return load


def resets(load):
    """How many of a load's connections the server reset (dropped to make
    room, or past a deadline)."""
    import errno
    return sum(1 for s in load.socks if s.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR) == errno.ECONNRESET)


def pipelined(port, n, path, name):
    """n connections that each pipeline about 1,300 requests for `path`
    (64 kB of them, no token needed) with a 1 kB receive buffer and never
    read an answer: the attack of the review of issue 33. Every connection
    ends up with its answers waiting on the client (the state the server
    could not drop before)."""
    load = Load(name)
    one = f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode()
    burst = one * (65536 // len(one))
    for _ in range(n):
        s = socket.socket()
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1024)
        s.settimeout(5)
        s.connect(("127.0.0.1", port))
        s.setblocking(False)
        try:
            s.send(burst)  # what fits; the server reads the rest as it answers
        except OSError:
            pass  # dropped already to make room (its site's cap): the others go on
        load.socks.append(s)
    return load


class SlowReader:
    """One connection (no token) that pipelines 20 requests for Chart.js
    (200 kB each) and reads the answers at about 10 kB/s: a client that
    still reads, a little every moment, too slowly to take one answer within
    the server's write deadline (10 s and a second per MB, not moved by
    progress). Records when the server closed it."""

    def __init__(self, port):
        import threading
        self.sock = socket.socket()
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        self.sock.connect(("127.0.0.1", port))
        self.sock.sendall(f"GET /vendor/chart.js HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode() * 20)
        self.started = time.monotonic()
        self.closed_after_s = None
        self.received = 0
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.thread.start()

    def _read(self):
        self.sock.settimeout(1.0)
        while time.monotonic() - self.started < 40:
            try:
                data = self.sock.recv(2500)
            except socket.timeout:
                continue
            except OSError:
                data = b""
            if not data:
                self.closed_after_s = time.monotonic() - self.started
                return
            self.received += len(data)
            time.sleep(0.25)

    def close(self):
        self.sock.close()


def trickle(load):
    for s in load.socks:
        try:
            s.send(b"a")
        except OSError:
            pass


def measure_stop(c, samples, load=None, poll=None):
    """Starts a session, waits for its trial, sends STOP on a new
    connection; returns (answer_s, abort_s, status_s) per sample."""
    out = []
    for _ in range(samples):
        expect("start", request(c.port, "POST", "/api/session/start", {"participant": "S1"}, token=c.token), 200)
        wait_for("a running trial", lambda: status_of(c, poll).get("phase") == "trial", 30)
        if load is not None and load.name.endswith("slowloris connections"):
            trickle(load)
        t0 = time.monotonic()
        s = connect(c.port)
        s.sendall(f"POST /api/session/stop HTTP/1.1\r\nHost: 127.0.0.1:{c.port}\r\nX-HapticLab-Token: {c.token}\r\n"
                  "Content-Length: 2\r\n\r\n{}".encode())
        r = read_response(s, 60)
        answered = time.monotonic() - t0
        s.close()
        if r is None or r[0] != 200:
            fail(f"STOP under {load.name if load else 'no load'}: {r}")
        while status_of(c, poll).get("phase") == "trial":
            time.sleep(0.002)
        aborted = time.monotonic() - t0
        t1 = time.monotonic()
        status_of(c)  # on a new connection, as a page's poll
        status_s = time.monotonic() - t1
        out.append((answered, aborted, status_s))
        wait_for("the session's end", lambda: not status_of(c, poll).get("running"), 30)
    return out


def report(name, results):
    row = [name]
    for k in range(3):
        v = [1e3 * r[k] for r in results]
        row.append(f"{percentile(v, 50):.1f}/{percentile(v, 99):.1f}/{max(v):.1f}")
    print(f"  {row[0]:<28} STOP answered {row[1]:>18} ms   trial ended {row[2]:>18} ms   status {row[3]:>16} ms"
          " (p50/p99/max)")
    return results


def check_bound(name, results):
    worst = max(max(r[0], r[1], r[2]) for r in results)
    if worst > LOADED_BOUND_S:
        fail(f"under {name}, STOP or status took {worst:.3f} s (bound {LOADED_BOUND_S} s)")


def actions(db):
    conn = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    try:
        return conn.execute("SELECT session_id, trial_id, t_s, type, detail FROM operator_action ORDER BY id").fetchall()
    finally:
        conn.close()


def token_files(cli, db, work, consoles):
    """--token-file read as every secret file is (core/common/secret_file.h)."""
    def write(name, content, mode=0o600):
        path = os.path.join(work, name)
        with open(path, "wb") as f:
            f.write(content)
        os.chmod(path, mode)
        return path

    for name, content, mode, words in (("spaces", b" " * 20 + b"\n", 0o600, "character 1 is a space"),
                                       ("a16", b"a" * 16 + b"\n", 0o600, "uses only 1 different characters"),
                                       ("open", b"0123456789abcdef0123\n", 0o644, "mode 0644")):
        r = subprocess.run([cli, "console", "--db", db, "--port", "0", "--token-file", write(name, content, mode)],
                           capture_output=True, text=True, timeout=30)
        if r.returncode == 0 or words not in r.stdout + r.stderr:
            fail(f"a token file of {name} was not refused with {words!r}: exit {r.returncode}, {r.stdout}{r.stderr}")
    # A CRLF line end is not part of the token: the one before it works.
    crlf = write("crlf", b"0123456789abcdef0123\r\n")
    c = Console(cli, db, "--token-file", crlf)
    consoles.append(c)
    if c.token_in_address != "0123456789abcdef0123":
        fail(f"the token of a CRLF file: {c.token_in_address!r}")
    expect("STOP with the token of a CRLF file", request(c.port, "POST", "/api/session/stop", token="0123456789abcdef0123"),
           200)
    c.kill()
    consoles.remove(c)
    # A missing file is made: mode 600, 128 random bits in hex.
    made = os.path.join(work, "made-token")
    c = Console(cli, db, "--token-file", made)
    consoles.append(c)
    if oct(os.stat(made).st_mode & 0o777) != "0o600" or not re.fullmatch(r"[0-9a-f]{32}\n", open(made).read()):
        fail(f"the token file made: mode {oct(os.stat(made).st_mode)}, {open(made).read()!r}")
    c.kill()
    consoles.remove(c)


def reads_need_the_token(c):
    """Every operator route that names a setting or a participant needs the
    token (or a one-time ticket); only the page's shell and its files do
    not: a participant who types the operator's address into the screen's
    browser reads nothing."""
    for path in ("/api/status", "/api/study", "/api/tuning", "/api/results", "/events/operator",
                 "/results/report.html", "/tuning/tuning-log.csv"):
        for token in (None, "0" * 32):
            expect(f"GET {path} with token {token!r}", request(c.port, "GET", path, token=token), 403,
                   "X-HapticLab-Token")
    for path in ("/", "/console.js", "/console.css", "/tuning.js"):
        expect(f"GET {path} without the token", request(c.port, "GET", path), 200)
    # A ticket: for one path, once.
    expect("a ticket without the token", request(c.port, "POST", "/api/ticket", {"path": "/events/operator"}), 403)
    expect("a ticket for a route that takes none", request(c.port, "POST", "/api/ticket", {"path": "/api/status"},
                                                           token=c.token), 400, "takes no ticket")
    ticket = expect("a ticket", request(c.port, "POST", "/api/ticket", {"path": "/events/operator"}, token=c.token),
                    200)["ticket"]
    expect("a ticket on another path", request(c.port, "GET", "/api/status?ticket=" + ticket), 403, "ticket")
    expect("a ticket used again", request(c.port, "GET", "/events/operator?ticket=" + ticket), 403, "spent")
    ticket = request(c.port, "POST", "/api/ticket", {"path": "/events/operator"}, token=c.token)[2]["ticket"]
    s = connect(c.port)
    s.sendall(f"GET /events/operator?ticket={ticket} HTTP/1.1\r\nHost: 127.0.0.1:{c.port}\r\n\r\n".encode())
    s.settimeout(5)
    head = s.recv(4096)
    s.close()
    if not head.startswith(b"HTTP/1.1 200") or b"text/event-stream" not in head:
        fail(f"the operator's stream with a ticket: {head[:300]!r}")


def stop_while_the_control_thread_waits(c, db, poll):
    """STOP is answered within the bound while the one control thread waits
    on a note that the study database's lock holds up (this test holds the
    lock, as a long commit of another connection would), and while STOP's
    own record waits for it too: the answer says the record is pending, and
    the record is stored once the lock is free."""
    import threading
    expect("start", request(c.port, "POST", "/api/session/start", {"participant": "S1"}, token=c.token), 200)
    wait_for("a running trial", lambda: status_of(c, poll).get("phase") == "trial", 30)
    lock = sqlite3.connect(db, timeout=10, isolation_level=None)
    lock.execute("BEGIN IMMEDIATE")
    held = {}
    note = threading.Thread(target=lambda: held.update(
        r=request(c.port, "POST", "/api/session/note", {"text": "held up"}, token=c.token, timeout=30)))
    try:
        note.start()
        time.sleep(0.3)  # the note is on the control thread, waiting for the lock
        t0 = time.monotonic()
        try:
            r = request(c.port, "POST", "/api/session/stop", token=c.token, timeout=3)
        except socket.timeout:
            r = None
        answered = time.monotonic() - t0
    finally:
        lock.execute("ROLLBACK")
        lock.close()
    if r is None:
        fail("STOP while the control thread waited on the database: no answer within 3 s")
    print(f"  STOP while a note waits on the database's lock: answered in {1e3 * answered:.1f} ms")
    body = expect("STOP while the control thread waits", r, 200, "record_pending")
    if answered > LOADED_BOUND_S or body["recorded"] is not False or not body["stopped"].startswith("session S1"):
        fail(f"STOP while the control thread waited: {answered:.3f} s, {body}")
    wait_for("STOP's record stored once the lock was free",
             lambda: status_of(c, poll).get("last_stop", {}).get("recorded") == "stored", 15)
    note.join(30)
    expect("the held-up note, once the lock was free", held.get("r"), 200)
    stops = [r for r in actions(db) if r[3] == "operator_stop"]
    if not stops or stops[-1][4] != body["stopped"]:
        fail(f"STOP's record as stored: {stops[-1:]}, answered {body['stopped']!r}")
    wait_for("the session's end", lambda: not status_of(c, poll).get("running"), 30)


def start_device_hangs(cli, source, work, plugin, consoles):
    """A device read that never returns (the fake plugin, in-process), in a
    session and in a free trial of the Tuning page, each in a console of
    its own: the alert is in the status at once, before the hang is given
    up on (after 2 s, while the rest of this test runs; then
    check_device_hangs)."""
    protocol = os.path.join(source, "examples/protocols/thesis_quick.json")
    fault = ["--device", "plugin-inprocess:" + plugin, "--device-option", "fault=hang_in_read",
             "--device-option", "after=100"]
    hung = {}
    for what in ("session", "free trial"):
        db = os.path.join(work, what.replace(" ", "_") + "_hang.db")
        subprocess.run([cli, "study", "create", "--protocol", protocol, "--db", db], check=True, capture_output=True)
        c = hung[what] = Console(cli, db, *fault)
        c.db = db
        c.status_path = "/api/status" if what == "session" else "/api/tuning"
        consoles.append(c)
    s, t = hung["session"], hung["free trial"]
    t.setting = request(t.port, "GET", "/api/tuning", token=t.token)[2]["study_settings"][0]
    for what, c in hung.items():
        for attempt in range(3):
            if what == "free trial":
                expect("a free trial on the hanging device", request(
                    t.port, "POST", "/api/tuning/start", {"task": "dissection", "from": t.setting}, token=t.token), 200)
            else:
                expect("a session on the hanging device", request(
                    s.port, "POST", "/api/session/start", {"participant": "S1"}, token=s.token), 200)
            # The alert comes 20 ms after the hang, which comes 100 reads
            # into the trial; the time is the session's or free trial's
            # start, which took over 10 s beside the whole suite and two
            # busy processes on 2 cores (a failure seen so).
            seen = wait_for(f"the {what}'s device alert", lambda: (j := device_view(c)).get("device_alert") and
                            ("device read()" in j["device_alert"] or not j["running"]) and j, 30,
                            lambda: f"its status: {json.dumps(device_view(c))[:800]}")
            # (On a busy machine the loop's watchdog can end a free trial, or
            # a session after three trials, before the hang: started again.)
            if "device read() has not returned for" in seen["device_alert"]:
                break
        if "device read() has not returned for 20 ms" not in seen["device_alert"] or "device_hung" in seen:
            fail(f"the {what}'s alert, before the hang was given up on: {seen}")
    return hung


def device_view(c):
    r = request(c.port, "GET", c.status_path, token=c.token)
    return r[2] if r and isinstance(r[2], dict) else {}


def check_device_hangs(hung, consoles):
    """After the grace, each console's device is hung: every later session
    or free trial is refused saying so, STOP still answers, the alert is
    still shown, and the console, stopped, exits with status 3."""
    setting = hung["free trial"].setting
    for what, c in hung.items():
        seen = wait_for(f"the {what}'s device marked hung", lambda: (j := device_view(c)).get("device_hung") and j, 20)
        if "hung for" not in seen["device_hung"] or seen["running"] or "device read()" not in seen.get("device_alert", ""):
            fail(f"the {what}'s hung device: {seen}")
        for refused, body in (("/api/session/start", {"participant": "S2"}),
                              ("/api/tuning/start", {"task": "dissection", "from": setting})):
            expect(f"{refused} after the {what}'s device hung", request(c.port, "POST", refused, body, token=c.token),
                   409, "the device hung")
        expect(f"STOP after the {what}'s device hung", request(c.port, "POST", "/api/session/stop", token=c.token), 200)
    conn = sqlite3.connect(f"file:{hung['session'].db}?mode=ro", uri=True)
    reasons = [r[0] for r in conn.execute("SELECT abort_reason FROM trial WHERE status = 'aborted' ORDER BY id")]
    conn.close()
    # (before it, a busy machine may have aborted a trial by the loop's watchdog)
    if not reasons or not reasons[-1].startswith("device read hung for") or \
            any(not r.startswith("watchdog") for r in reasons[:-1]):
        fail(f"the session's hung trial as stored: {reasons}")
    for what, c in hung.items():
        c.proc.send_signal(signal.SIGINT)
        try:
            out, _ = c.proc.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            fail(f"the console whose {what}'s device hung did not end within 20 s of SIGINT")
        if c.proc.returncode != 3 or "the device hung" not in out:
            fail(f"the console whose {what}'s device hung ended with {c.proc.returncode}: {out[-600:]}")
        consoles.remove(c)
    print("  a device read hung in a session and in a free trial: the alert at once, then each console refused "
          "its device, and exited with status 3")


def ctrl_c_while_a_device_call_hangs(cli, source, work, plugin, consoles):
    """Ctrl-C as soon as the alert of a hung device read shows, before the
    session gives up on it: the console waits for the session to give up
    (zero force was commanded at once) and exits with status 3, as it does
    after the grace; it exited 0 before, the hang not yet marked."""
    protocol = os.path.join(source, "examples/protocols/thesis_quick.json")
    db = os.path.join(work, "ctrl_c_hang.db")
    subprocess.run([cli, "study", "create", "--protocol", protocol, "--db", db], check=True, capture_output=True)
    c = Console(cli, db, "--device", "plugin-inprocess:" + plugin, "--device-option", "fault=hang_in_read",
                "--device-option", "after=100")
    c.status_path = "/api/status"
    consoles.append(c)
    for attempt in range(3):
        expect("a session on the hanging device",
               request(c.port, "POST", "/api/session/start", {"participant": "S1"}, token=c.token), 200)
        seen = wait_for("the device alert", lambda: (j := device_view(c)).get("device_alert") and
                        ("device read()" in j["device_alert"] or not j["running"]) and j, 30,
                        lambda: f"its status: {json.dumps(device_view(c))[:800]}")
        if "device read() has not returned for" in seen["device_alert"]:
            break
    else:
        fail(f"no hang in three sessions: {seen}")
    c.proc.send_signal(signal.SIGINT)
    try:
        out, _ = c.proc.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        fail("the console did not end within 20 s of SIGINT during a device hang")
    if c.proc.returncode != 3 or "the device hung" not in out:
        fail(f"Ctrl-C during a device hang: the console ended with {c.proc.returncode}: {out[-600:]}")
    consoles.remove(c)
    print("  Ctrl-C while a device read hung: the console waited for the session to give up, exit status 3")


def free_trial_goes_on_after_a_host_stall(cli, source, work, consoles):
    """The host falls behind during a free trial (the console frozen by
    SIGSTOP for 0.3 s, as a loaded machine would): the loop's watchdog ends
    that repetition with zero force, the tuning log says so, and the free
    trial goes on with its next repetition, as a session goes on after such
    a trial. (Should the freeze land inside a device call, the trip is the
    device's and the free trial rightly stops: tried again, up to 3 times.)"""
    protocol = os.path.join(source, "examples/protocols/thesis_quick.json")
    db = os.path.join(work, "stall.db")
    subprocess.run([cli, "study", "create", "--protocol", protocol, "--db", db], check=True, capture_output=True)
    c = Console(cli, db)
    consoles.append(c)
    tuning = lambda: request(c.port, "GET", "/api/tuning", token=c.token)[2]
    setting = tuning()["study_settings"][0]
    for attempt in range(3):
        expect("a free trial", request(c.port, "POST", "/api/tuning/start", {"task": "dissection", "from": setting},
                                       token=c.token), 200)
        wait_for("the free trial's loop", lambda: (t := tuning()).get("running") and t.get("loop_t_s", 0) > 0.5, 30,
                 lambda: json.dumps(tuning())[:600])
        repetition = tuning()["free_trial"]
        os.kill(c.proc.pid, signal.SIGSTOP)
        time.sleep(0.3)
        os.kill(c.proc.pid, signal.SIGCONT)
        t = wait_for("the stall's trip in the tuning log", lambda: (t := tuning()) and any(
            e["field"] in ("watchdog", "stop") for e in t["log"]) and t, 30, lambda: json.dumps(tuning())[:800])
        if any(e["field"] == "watchdog" for e in t["log"]):
            break
        print(f"  (attempt {attempt + 1}: the freeze landed in a device call: {t['log'][-1]})")
    else:
        fail(f"three freezes, none ended only a repetition: {json.dumps(tuning())[:800]}")
    trip = next(e for e in t["log"] if e["field"] == "watchdog")
    if trip["free_trial"] != repetition or "watchdog" not in t.get("device_alert", ""):
        fail(f"the stall as logged and shown: {trip}, {json.dumps(t)[:800]}")
    t = wait_for("the next repetition", lambda: (t := tuning())["free_trial"] > repetition and t["running"] and t, 30,
                 lambda: json.dumps(tuning())[:800])
    if any(e["field"] == "stop" for e in t["log"]) or t["error"]:
        fail(f"the free trial stopped after the host's stall: {json.dumps(t)[:800]}")
    expect("STOP", request(c.port, "POST", "/api/session/stop", token=c.token), 200)
    wait_for("the free trial's end", lambda: not tuning()["running"], 20)
    c.kill()
    consoles.remove(c)
    print(f"  a 0.3 s host stall ended free trial repetition {repetition} ({trip['to']}); the free trial went on")


def stop_during_training(cli, source, work, consoles):
    """STOP while the participant practises (the training before a task's
    first trial, a practice trial of up to --max-trial-s on the device):
    the practice trial ends at once, as a trial does, not when it is done;
    the training is recorded as cut short by the stop."""
    protocol = os.path.join(source, "examples/protocols/thesis_quick.json")
    db = os.path.join(work, "training.db")
    subprocess.run([cli, "study", "create", "--protocol", protocol, "--db", db], check=True, capture_output=True)
    c = Console(cli, db, training_trials=2)
    consoles.append(c)
    expect("start", request(c.port, "POST", "/api/session/start", {"participant": "S1"}, token=c.token), 200)
    wait_for("the training", lambda: status_of(c).get("phase") == "training", 30)
    time.sleep(0.5)  # the practice trial's loop is running
    t0 = time.monotonic()
    expect("STOP in training", request(c.port, "POST", "/api/session/stop", token=c.token), 200)
    wait_for("the session's end after STOP in training", lambda: not status_of(c).get("running"), 30)
    ended_s = time.monotonic() - t0
    print(f"  STOP during training: the session ended {1e3 * ended_s:.0f} ms after STOP")
    # The practice trial ends within a drain; the session's end then writes
    # the training and closes the session (commits that a loaded CI machine
    # can hold up). Without the fix the practice trial ran on for 25 s.
    if ended_s > 5.0:
        fail(f"STOP during training: the session ran on for {ended_s:.2f} s (bound 5 s)")
    rows = sqlite3.connect(db).execute("SELECT trials, cut_short, cut_short_reason FROM training").fetchall()
    # The practice trial STOP ended is the last one, cut short by it; on a
    # loaded machine (the sanitizer build beside other work) the one before
    # it may have been cut short already (a host stall's watchdog trip, its
    # time limit): also recorded, and not this test's question.
    if len(rows) != 1 or rows[0][2] != "operator stopped the session" or not 1 <= rows[0][1] <= 2 \
            or rows[0][0] + rows[0][1] > 2:
        fail(f"the training cut short by STOP, as stored: {rows}")
    c.kill()
    consoles.remove(c)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("cli")
    ap.add_argument("source")
    ap.add_argument("work")
    ap.add_argument("--bench", type=int, default=0, help="STOPs per load, and print only the figures")
    ap.add_argument("--fake-plugin", help="tests/core/device/fake_device_plugin.so: the device that hangs")
    a = ap.parse_args()
    global BENCH
    BENCH = a.bench > 0
    shutil.rmtree(a.work, ignore_errors=True)
    os.makedirs(a.work)
    protocol = os.path.join(a.source, "examples/protocols/thesis_quick.json")
    db = os.path.join(a.work, "study.db")
    subprocess.run([a.cli, "study", "create", "--protocol", protocol, "--db", db], check=True, capture_output=True)
    consoles = []
    try:
        if not a.bench:
            token_files(a.cli, db, a.work, consoles)
        c = Console(a.cli, db)
        consoles.append(c)
        if not a.bench and c.token_in_address != c.token:
            fail(f"the operator's address does not hold the token file's token: {c.token_in_address}")
        samples = a.bench or 2
        poll = connect(c.port)  # one keep-alive connection for the polls
        # A reader too slow for any answer (checked once its deadline has passed, below).
        slow = None
        hung = None
        if not a.bench:
            if a.fake_plugin:  # checked at the end, long after the device's grace
                hung = start_device_hangs(a.cli, a.source, a.work, a.fake_plugin, consoles)
            if request(c.port, "GET", "/vendor/chart.js")[0] == 200:
                slow = SlowReader(c.port)
            else:
                print("  (Chart.js is not installed: the slow reader's check is skipped)")
            reads_need_the_token(c)

        # --- STOP under load
        print("STOP under load (ms):")
        results = {}
        results["none"] = report("no other connection", measure_stop(c, samples, poll=poll))
        # (the last: the review of issue 33's attack, no token needed: the
        # participant's port full of clients that pipeline requests and never
        # read an answer; the operator's port has connections of its own)
        for make in (lambda: streams(c, 50), lambda: idle(c, 200), lambda: slowloris(c, 200),
                     lambda: pipelined(c.participant_port, 520, "/participant", "520 pipelining participant conns")):
            load = make()
            try:
                results[load.name] = report(load.name, measure_stop(c, samples, load, poll))
                if load.name.endswith("participant conns") and not a.bench:
                    # The port under attack still serves a newcomer (it takes
                    # the slot of the longest unread answer), and holds no more
                    # than its own 128: the rest were dropped (reset).
                    expect("/participant under attack", request(c.participant_port, "GET", "/participant"), 200)
                    if resets(load) < 520 - 128:
                        fail(f"520 participant connections: {resets(load)} dropped, expected at least 392 past the "
                             "participant port's cap of 128")
                if load.name.endswith("slowloris connections") and not a.bench:
                    # The head deadline (5 s from a request's first byte): each
                    # is answered 408 and closed, however it trickles.
                    wait_for("the head deadline", lambda: time.monotonic() - load.started > 4.5, 10)
                    trickle(load)
                    time.sleep(max(0.0, load.started + 6.5 - time.monotonic()))  # the deadline and 1.5 s
                    closed = 0
                    for s in load.socks:
                        s.settimeout(0.05)
                        try:
                            data = s.recv(4096)
                        except OSError:
                            data = b""
                        if data.startswith(b"HTTP/1.1 408") and b"not complete within 5000 ms" in data:
                            closed += 1
                    if closed != len(load.socks):
                        fail(f"{len(load.socks) - closed} slowloris connections were not cut at the head deadline (408)")
            finally:
                load.close()
        if a.bench:
            load = pipelined(c.port, 400, "/", "400 pipelining operator conns")
            report(load.name, measure_stop(c, samples, load))
            return 0
        for name, r in results.items():
            check_bound(name, r)

        # A flood of stream requests: the operator's port's cap (64) refuses
        # the rest by name, STOP and status still answered.
        load = Load("stream flood")
        refused = 0
        for _ in range(100):
            s = connect(c.port)
            s.sendall(f"GET /events/operator HTTP/1.1\r\nHost: 127.0.0.1:{c.port}\r\nX-HapticLab-Token: {c.token}\r\n\r\n"
                      .encode())
            load.socks.append(s)
        for s in load.socks:
            s.settimeout(5)
            head = s.recv(4096)
            if head.startswith(b"HTTP/1.1 503"):
                refused += 1
                if b"64 streams are open on the operator's port" not in head + s.recv(4096):
                    fail(f"a refused stream does not name the cap: {head[:300]!r}")
        if refused != 100 - 64:
            fail(f"100 stream requests: {refused} refused, expected 36 past the cap of 64")
        check_bound("a stream flood", report("100 stream requests", measure_stop(c, 1, load, poll)))
        load.close()
        # More connections than the operator's table holds (384): the oldest
        # idle ones (the poll's among them) are dropped, STOP is served.
        load = idle(c, 400)
        check_bound("a full connection table", report("400 idle connections", measure_stop(c, 1, load)))
        load.socks[0].settimeout(2)
        try:
            dropped = load.socks[0].recv(1) == b""
        except OSError:
            dropped = True
        if not dropped:
            fail("with the connection table full, the oldest idle connection was not dropped")
        load.close()
        poll.close()
        poll = connect(c.port)
        # Streams: the participant's port has its own cap (16); 64 streams
        # there leave the operator's page its stream.
        load = Load("64 participant streams")
        refused = 0
        for _ in range(64):
            s = connect(c.participant_port)
            s.sendall(f"GET /events/participant HTTP/1.1\r\nHost: 127.0.0.1:{c.participant_port}\r\n\r\n".encode())
            load.socks.append(s)
        for s in load.socks:
            s.settimeout(5)
            head = s.recv(4096)
            if head.startswith(b"HTTP/1.1 503"):
                refused += 1
                if b"16 streams are open on the participant's port" not in head + s.recv(4096):
                    fail(f"a refused participant stream does not name its port's cap: {head[:300]!r}")
        if refused != 64 - 16:
            fail(f"64 participant streams: {refused} refused, expected 48 past the participant port's cap of 16")
        op = connect(c.port)
        op.sendall(f"GET /events/operator HTTP/1.1\r\nHost: 127.0.0.1:{c.port}\r\nX-HapticLab-Token: {c.token}\r\n\r\n"
                   .encode())
        op.settimeout(5)
        head = op.recv(4096)
        if not head.startswith(b"HTTP/1.1 200") or b"text/event-stream" not in head:
            fail(f"the operator's stream with the participant's port full of streams: {head[:300]!r}")
        op.close()
        load.close()
        stop_while_the_control_thread_waits(c, db, poll)
        if slow is not None:
            # The slow reader: cut at its answer's deadline (10 s and 0.2 s
            # for 200 kB, from when the answer was ready), reset; before,
            # every byte it took moved the deadline on.
            wait_for("the slow reader cut at its answer's deadline", lambda: slow.closed_after_s is not None,
                     max(0.0, 20 - (time.monotonic() - slow.started)))
            print(f"  a reader taking 200 kB answers at about 10 kB/s: closed after {slow.closed_after_s:.1f} s "
                  f"({slow.received} bytes read)")
            if slow.closed_after_s < 9.5:
                fail(f"the slow reader was closed after {slow.closed_after_s:.1f} s, before its answer's deadline")
            slow.close()
        # The operator's port full of pipelining clients (no token: the
        # page's shell), every one with an answer it does not read (no idle
        # connection left to drop, not even the polls'): a new connection
        # takes the slot of the longest unread answer, so STOP is served.
        poll.close()
        load = pipelined(c.port, 400, "/", "400 pipelining operator conns")
        try:
            time.sleep(0.5)  # each has its answers waiting
            check_bound(load.name, report(load.name, measure_stop(c, samples, load)))
            expect("/ under attack", request(c.port, "GET", "/"), 200)
        finally:
            load.close()
        poll = connect(c.port)

        # --- Host, origins, headers
        for port in (c.port, c.participant_port):
            expect("Host evil.example", request(port, "GET", "/participant" if port != c.port else "/api/status",
                                                host=f"evil.example:{port}"), 421, "evil.example")
        expect("Host without the port", request(c.port, "GET", "/api/study", host="127.0.0.1"), 421)
        expect("Host localhost", request(c.port, "GET", "/api/status", host=f"localhost:{c.port}", token=c.token), 200)
        for path in ("/api/status", "/api/study", "/events/operator", "/", "/api/tuning", "/results/report.html"):
            expect(f"{path} on the participant's port", request(c.participant_port, "GET", path), 404)
        for path in ("/participant", "/events/participant"):
            expect(f"{path} on the operator's port", request(c.port, "GET", path), 404)
        status, headers, page = request(c.participant_port, "GET", "/participant")
        if status != 200 or "/participant.js" not in page:
            fail(f"the participant's page on its port: {status} {page[:200]}")
        status, headers, _ = request(c.port, "GET", "/")
        for name, value in (("x-frame-options", "DENY"), ("x-content-type-options", "nosniff"),
                            ("content-security-policy", "script-src 'self'")):
            if value not in headers.get(name, ""):
                fail(f"the operator's page lacks {name}: {value}: {headers}")
        if "'unsafe-inline'" in headers["content-security-policy"]:
            fail("the page's CSP allows inline script or style")

        # --- bodies
        t0 = time.monotonic()
        expect("Content-Length 100 MB", request(c.port, "POST", "/api/session/note", token=c.token, raw_body=b"",
                                                extra=b"Content-Length: 100000000\r\n"), 413, "100000000 bytes")
        if time.monotonic() - t0 > LOADED_BOUND_S:
            fail(f"an oversized Content-Length was refused after {time.monotonic() - t0:.1f} s, not at once")
        chunk = b"%x\r\n" % 65536 + b"a" * 65536 + b"\r\n"
        s = connect(c.port)
        s.sendall(f"POST /api/session/stop HTTP/1.1\r\nHost: 127.0.0.1:{c.port}\r\nTransfer-Encoding: chunked\r\n\r\n"
                  .encode() + chunk)
        r = read_response(s, 5)
        s.close()
        expect("a chunked body without the token", r, 403, "X-HapticLab-Token")
        s = connect(c.port)
        s.sendall(f"POST /api/session/note HTTP/1.1\r\nHost: 127.0.0.1:{c.port}\r\nX-HapticLab-Token: {c.token}\r\n"
                  "Transfer-Encoding: chunked\r\n\r\n".encode() + (b"%x\r\n" % 9000) + b"a" * 9000 + b"\r\n"
                  + (b"%x\r\n" % 9000))
        r = read_response(s, 5)
        s.close()
        expect("a chunked body past 16 kB", r, 413, "18000 bytes")
        # curl's "Expect: 100-continue" (a body over 1 kB) is answered at once.
        s = connect(c.port)
        body = json.dumps({"text": "x" * 2000}).encode()
        s.sendall(f"POST /api/session/note HTTP/1.1\r\nHost: 127.0.0.1:{c.port}\r\nX-HapticLab-Token: {c.token}\r\n"
                  f"Expect: 100-continue\r\nContent-Length: {len(body)}\r\n\r\n".encode())
        s.settimeout(0.5)
        if not s.recv(4096).startswith(b"HTTP/1.1 100 Continue\r\n\r\n"):
            fail("Expect: 100-continue was not answered")
        s.sendall(body)
        expect("the note after 100 Continue", read_response(s, 5), 409, "no session is running")
        s.close()
        expect("STOP with no body at all", request(c.port, "POST", "/api/session/stop", token=c.token), 200,
               "nothing was running")
        expect("STOP with Content-Length: 0", request(c.port, "POST", "/api/session/stop", token=c.token,
                                                      raw_body=b"", extra=b"Content-Length: 0\r\n"), 200)
        chunked_stop = b"2\r\n{}\r\n0\r\n\r\n"
        expect("STOP with a chunked {}", request(c.port, "POST", "/api/session/stop", token=c.token, raw_body=chunked_stop,
                                                 extra=b"Transfer-Encoding: chunked\r\n"), 200)
        for path, body, words in (
                ("/api/session/pause", {"paused": "yes"}, "paused: a string (\\\"yes\\\"), must be true or false"),
                ("/api/results/export", {"every": 4294967297}, "every: 4294967297, must be a whole number, 1..1000000"),
                ("/api/results/export", {"every": 18446744073709551617}, "every:"),
                ("/api/results/export", {"every": "10"}, "every: a string"),
                ("/api/results/export", {"gzip": 1}, "gzip: a number (1), must be true or false"),
                ("/api/session/rest", {"seconds": "120"}, "seconds: a string"),
                ("/api/session/note", {"text": "ab\u0000cd"}, "NUL character (U+0000) at character 3"),
                ("/api/session/note", {"text": "\u00e9" * 2001}, "2001 characters (4002 bytes), must be 1..2000"),
                ("/api/session/abort", {"reason": "x", "trial_id": 1.5}, "trial_id: a number with a fraction"),
                ("/api/session/start", {"participant": "S1", "step": "no"}, "step: a string"),
                # A misspelt field would be ignored and its default taken (step mode off).
                ("/api/session/start", {"participant": "S1", "stepp": True},
                 "unknown field 'stepp' (POST /api/session/start takes participant, step"),
                ("/api/session/next", {"force": True}, "takes no field")):
            expect(f"{path} {json.dumps(body)[:60]}", request(c.port, "POST", path, body, token=c.token), 400, words)
        # A field given twice: the parser would keep the last (S2's session started).
        twice = b'{"participant": "S1", "participant": "S2"}'
        expect("a field given twice", request(c.port, "POST", "/api/session/start", token=c.token, raw_body=twice,
                                              extra=f"Content-Length: {len(twice)}\r\n".encode()),
               400, "the field 'participant' is given twice")
        for path, body in (("/api/session/next", None), ("/api/session/pause", {"paused": True}),
                           ("/api/session/rest", {"seconds": 10}), ("/api/session/end-training", None),
                           ("/api/session/note", {"text": "x"}), ("/api/session/abort", {"reason": "x"})):
            expect(f"{path} with no session", request(c.port, "POST", path, body, token=c.token), 409, "no session")

        # --- every action stored before its 200, in step mode: before the
        # first trial, during it, between trials, then STOP
        expect("start in step mode", request(c.port, "POST", "/api/session/start", {"participant": "S1", "step": True},
                                             token=c.token), 200)
        wait_for("the wait for Next", lambda: status_of(c, poll).get("waiting_for_next"), 30)
        before = len(actions(db))
        for path, body in (("note", {"text": "before the first trial"}), ("pause", {"paused": True}),
                           ("pause", {"paused": False}), ("end-training", None),
                           ("note", {"text": "a second note, \u00e9" * 1})):
            expect(path, request(c.port, "POST", "/api/session/" + path, body, token=c.token), 200)
        # Each is in the file when its answer came (read right after).
        got = actions(db)[before:]
        if [r[3] for r in got] != ["operator_note", "operator_pause", "operator_resume", "operator_end_training",
                                   "operator_note"] or any(r[0] is None or r[1] is not None for r in got):
            fail(f"the actions before the first trial, as stored: {got}")
        # A 1 s rest in step mode goes on by itself (docs/console.md).
        expect("rest", request(c.port, "POST", "/api/session/rest", {"seconds": 1}, token=c.token), 200)
        wait_for("the trial after the rest, without Next", lambda: status_of(c, poll).get("phase") == "trial", 20)
        trial_id = status_of(c, poll)["trial_id"]
        expect("a note during the trial", request(c.port, "POST", "/api/session/note", {"text": "\u00e9" * 2000},
                                                  token=c.token), 200)
        expect("an abort", request(c.port, "POST", "/api/session/abort", {"reason": "test", "trial_id": trial_id},
                                   token=c.token), 200)
        wait_for("between trials, waiting for Next", lambda: status_of(c, poll).get("waiting_for_next"), 20)
        expect("a note between trials", request(c.port, "POST", "/api/session/note", {"text": "between"},
                                                token=c.token), 200)
        stopped = expect("STOP between trials", request(c.port, "POST", "/api/session/stop", token=c.token), 200)
        if "between trials" not in stopped["stopped"]:
            fail(f"STOP's answer does not say what it stopped: {stopped}")
        if not stopped["recorded"]:  # answered before its record was in (a busy machine): it says so
            wait_for("STOP's record", lambda: status_of(c, poll).get("last_stop", {}).get("recorded") == "stored", 15)
        got = actions(db)[before + 5:]
        kinds = [(r[3], r[1] == trial_id, r[4][:12]) for r in got]
        if kinds != [("operator_rest", False, "1 s"), ("operator_resume", False, "rest over"),
                     ("operator_note", True, "\u00e9" * 12), ("operator_abort", True, "test"),
                     ("operator_note", False, "between"), ("operator_stop", False, "session S1, ")] \
                or got[2][2] is None or len(got[2][4]) != 2000:
            fail(f"the actions of the step session, as stored: {kinds}")
        wait_for("the session's end", lambda: not status_of(c, poll).get("running"), 20)
        poll.close()

        # --- kill -9: a note and a pause during a trial are in the file
        expect("start", request(c.port, "POST", "/api/session/start", {"participant": "S1"}, token=c.token), 200)
        wait_for("a running trial", lambda: status_of(c).get("phase") == "trial", 30)
        running = status_of(c)["trial_id"]
        expect("note", request(c.port, "POST", "/api/session/note", {"text": "before the kill"}, token=c.token), 200)
        expect("pause", request(c.port, "POST", "/api/session/pause", {"paused": True}, token=c.token), 200)
        c.proc.send_signal(signal.SIGKILL)
        c.proc.wait()
        last = actions(db)[-2:]
        if [(r[1], r[3], r[4]) for r in last] != [(running, "operator_note", "before the kill"),
                                                    (running, "operator_pause", "")]:
            fail(f"after kill -9 the running trial's note and pause are not in the database: {last}")
        check = subprocess.run([a.cli, "study", "check", "--db", db], capture_output=True, text=True)
        if check.returncode != 0:
            fail(f"study check after the console's kill: {check.stdout}{check.stderr}")
        out = os.path.join(a.work, "export")
        subprocess.run([a.cli, "export", "--db", db, "--format", "csv", "--one-file", "--out", out], check=True, capture_output=True)
        exported = open(os.path.join(out, "operator_actions.csv")).read()
        if "before the kill" not in exported or "operator_stop" not in exported:
            fail(f"the export's operator_actions.csv: {exported[:500]}")
        if hung:
            check_device_hangs(hung, consoles)
            ctrl_c_while_a_device_call_hangs(a.cli, a.source, a.work, a.fake_plugin, consoles)
        free_trial_goes_on_after_a_host_stall(a.cli, a.source, a.work, consoles)
        stop_during_training(a.cli, a.source, a.work, consoles)
    finally:
        for c in consoles:
            c.kill()
    print("console server: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
