"""A between-group design in the real console (issue 38 §1): the operator's
/api/study gives each participant's group, next phase and due date, and the
operator's page shows them in headless Chromium; the participant's port,
while a training sitting runs on the group's setting, serves nothing that
names that setting or the group (blinding).

usage: console_group_blinding_test.py HAPTICLAB_CLI SOURCE_DIR WORK_DIR
"""
import json
import os
import shutil
import socket
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from console_server_test import Console, expect, fail, request, status_of, wait_for  # noqa: E402

TRAINING = "No Force Feedback"
GROUP = "trained without force"


def participant_stream(port, seconds):
    """What /events/participant sends in `seconds`."""
    s = socket.create_connection(("127.0.0.1", port), timeout=5)
    s.sendall(f"GET /events/participant HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode())
    s.settimeout(0.2)
    data = b""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        try:
            chunk = s.recv(65536)
        except socket.timeout:
            continue
        if not chunk:
            break
        data += chunk
    s.close()
    return data.decode("utf-8", "replace")


def shown_on_page(c, code):
    """The operator's page, rendered by headless Chromium, shows the
    participant's group, sittings and next phase (skipped, with the reason,
    where Chromium is missing)."""
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "testing"))
    import headless_chromium
    driver = headless_chromium.start()
    if driver is None:
        print("skip (page only): Chromium is missing; the API was checked")
        return
    try:
        driver.get(f"http://127.0.0.1:{c.port}/#token={c.token}")
        end = time.monotonic() + 20
        body = ""
        while time.monotonic() < end and "sittings" not in body:
            time.sleep(0.2)
            body = driver.find_element("id", "study-body").text
        want = f"group {GROUP}; sittings 1 of 3 done; next: training 1, due"
        if want not in body:
            fail(f"the operator's page does not show {want!r}: {body[:400]!r}")
    finally:
        driver.quit()


def main():
    cli, source, work = sys.argv[1:4]
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    settings = os.path.join(source, "examples/settings")
    protocol = os.path.join(work, "groups.json")
    with open(protocol, "w") as f:
        json.dump({"study": "console blinding", "tasks": ["clip"],
                   "settings": [f"{settings}/high_fidelity.json", f"{settings}/no_force_feedback.json"],
                   "groups": [{"name": GROUP, "training": TRAINING, "size": 1}, {"name": "control", "training": None, "size": 1}],
                   "phases": [{"phase": "pre_test", "setting": "High Fidelity", "trials": {"clip": 1}},
                              {"phase": "training", "sessions": 1, "trials": {"clip": 2}},
                              {"phase": "post_test", "setting": "High Fidelity", "trials": {"clip": 1}}],
                   "participants": ["B1", "B2"], "seed": 3}, f)
    db = os.path.join(work, "study.db")
    subprocess.run([cli, "study", "create", "--protocol", protocol, "--db", db], check=True, capture_output=True)
    shown = json.loads(subprocess.run([cli, "study", "show", "--json", "--db", db], check=True,
                                      capture_output=True, text=True).stdout)
    code = next(p["code"] for p in shown["participants"] if p["group"] == GROUP)
    # The pre-test, so that the console's session is the training sitting.
    subprocess.run([cli, "session", "run", "--training-trials", "0", "--db", db, "--participant", code],
                   check=True, capture_output=True)
    c = Console(cli, db)
    try:
        study = expect("/api/study", request(c.port, "GET", "/api/study", token=c.token), 200)
        mine = next(p for p in study["participants"] if p["code"] == code)
        if mine.get("group") != GROUP or mine.get("next_phase") != "training" or "next_due_utc" not in mine:
            fail(f"the operator's /api/study does not give the group, phase and due date: {json.dumps(mine)[:300]}")
        shown_on_page(c, code)
        expect("start", request(c.port, "POST", "/api/session/start", {"participant": code}, token=c.token), 200)
        wait_for("the training sitting's trial", lambda: TRAINING in json.dumps(status_of(c)), 30)
        seen = participant_stream(c.participant_port, 1.5)
        for path in ("/participant", "/participant.js"):
            r = request(c.participant_port, "GET", path)
            seen += r[2] if isinstance(r[2], str) else json.dumps(r[2])
        if "data:" not in seen:
            fail("the participant stream sent nothing: the check would prove nothing")
        for secret in (TRAINING, GROUP, "High Fidelity", "control"):
            if secret in seen:
                fail(f"the participant's port served {secret!r}")
        print("ok: operator sees group, phase and due date; the participant's port names neither setting nor group")
    finally:
        c.kill()
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
