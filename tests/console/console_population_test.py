"""The console's sessions run on the rig of `session run`: simulated
participants drawn from the same population (the shipped fitted one by
default, or --population) and the loop at the same rate (--rate-hz): one
participant's session through the console and through `session run`, both
at 500 Hz, log the same samples, bit for bit; with `--population unfitted`
the console's differ (so the comparison can tell them apart). Before, the
console left the population at the unfitted model's defaults and the rate
at 1000 Hz, and a study run partly from the console mixed two participant
models (or two rates) without a word.

usage: console_population_test.py HAPTICLAB_CLI SOURCE_DIR WORK_DIR
"""
import filecmp
import json
import os
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from console_server_test import Console, expect, fail, request, status_of, wait_for  # noqa: E402


def samples(cli, db, out):
    """The study's trials exported as CSV: {file name: path} of the samples files."""
    subprocess.run([cli, "export", "--db", db, "--format", "csv", "--out", out], check=True, capture_output=True)
    files = {n: os.path.join(out, n) for n in os.listdir(out) if n.endswith("_samples.csv")}
    if not files:
        fail(f"{db}: no trial was exported")
    return files


def same(a, b):
    return a.keys() == b.keys() and all(filecmp.cmp(a[n], b[n], shallow=False) for n in a)


def console_session(cli, db, *extra):
    c = Console(cli, db, *extra, clock="virtual")
    try:
        tuning = expect("/api/tuning", request(c.port, "GET", "/api/tuning", token=c.token), 200)
        if tuning.get("rate_Hz") != 500:
            fail(f"the free trial's rate is not the console's --rate-hz 500: {tuning.get('rate_Hz')}")
        expect("start", request(c.port, "POST", "/api/session/start", {"participant": "P1"}, token=c.token), 200)
        wait_for("the session's end", lambda: not status_of(c).get("running"), 60)
    finally:
        c.kill()


def main():
    cli, source, work = sys.argv[1:4]
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    settings = os.path.join(source, "examples/settings")
    protocol = os.path.join(work, "protocol.json")
    with open(protocol, "w") as f:
        json.dump({"study": "console population", "tasks": ["clip"], "repetitions": {"clip": 1},
                   "settings": [f"{settings}/high_fidelity.json", f"{settings}/no_force_feedback.json"],
                   "participants": ["P1"], "training_trials": 0, "design": {"type": "complete"}, "seed": 11}, f)
    dbs = {}
    for name in ("cli", "console", "unfitted"):
        dbs[name] = os.path.join(work, name + ".db")
        subprocess.run([cli, "study", "create", "--protocol", protocol, "--db", dbs[name]], check=True,
                       capture_output=True)
    subprocess.run([cli, "session", "run", "--db", dbs["cli"], "--participant", "P1", "--clock", "virtual",
                    "--rate-hz", "500"], check=True, capture_output=True)
    console_session(cli, dbs["console"], "--rate-hz", "500")
    console_session(cli, dbs["unfitted"], "--rate-hz", "500", "--population", "unfitted")
    exported = {name: samples(cli, db, os.path.join(work, name + "-export")) for name, db in dbs.items()}
    if len(exported["cli"]) != 2:
        fail(f"expected the two trials of P1, exported {sorted(exported['cli'])}")
    if not same(exported["cli"], exported["console"]):
        fail("the console's session (--rate-hz 500) logged other samples than `session run --rate-hz 500` for the "
             "same participant and study")
    if same(exported["cli"], exported["unfitted"]):
        fail("--population unfitted changed nothing in the console's session: the comparison proves nothing")
    print("ok: the console's sessions run at --rate-hz and draw from `session run`'s population; --population "
          "reaches them")
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
