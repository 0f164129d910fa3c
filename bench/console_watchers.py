#!/usr/bin/env python3
"""Does watching the console slow the haptic loop? A wall-clock session run
from `hapticlab console` in step mode; trials alternate between nobody
watching and two headless Chromium windows on the live page (plots drawing
at 30 Hz), and each trial's loop period p50/p99/max comes from the study
database (loop_timing). Issue 17; the figures are in BENCHMARKS.md.

usage: console_watchers.py HAPTICLAB_CLI SOURCE_DIR WORK_DIR [--trials N]
"""
import argparse
import json
import os
import re
import shutil
import sqlite3
import subprocess
import sys
import time
import urllib.request


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("cli")
    ap.add_argument("source")
    ap.add_argument("work")
    ap.add_argument("--trials", type=int, default=6)
    ap.add_argument("--realtime", action="store_true", help="the console's loop with SCHED_FIFO (console --realtime)")
    a = ap.parse_args()
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    shutil.rmtree(a.work, ignore_errors=True)
    os.makedirs(a.work)
    db = os.path.join(a.work, "study.db")
    subprocess.run([a.cli, "study", "create", "--protocol", os.path.join(a.source, "examples/protocols/thesis_quick.json"),
                    "--db", db], check=True, capture_output=True)
    proc = subprocess.Popen([a.cli, "console", "--db", db, "--port", "0", "--clock", "wall", "--training-trials", "0"]
                            + (["--realtime"] if a.realtime else []),
                            stdout=subprocess.PIPE, text=True)
    line = ""
    while "console: http://" not in line:
        line = proc.stdout.readline()
    url = re.search(r"http://[0-9.]+:[0-9]+/", line).group(0)
    token = open(db + ".console-token").read().strip()

    def post(path, body):
        req = urllib.request.Request(url + path, data=json.dumps(body).encode(), method="POST",
                                     headers={"X-HapticLab-Token": token})
        urllib.request.urlopen(req).read()

    def status():
        return json.loads(urllib.request.urlopen(url + "api/status").read())

    def browser():
        o = webdriver.ChromeOptions()
        for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1200,900"):
            o.add_argument(arg)
        d = webdriver.Chrome(service=Service(shutil.which("chromedriver") or "/usr/bin/chromedriver"), options=o)
        d.get(url)
        d.execute_script("document.querySelector('nav button[data-page=live]').click()")
        return d

    rows = []
    try:
        post("api/session/start", {"participant": "S1", "step": True})
        for k in range(a.trials):
            watchers = 2 if k % 2 else 0
            drivers = [browser() for _ in range(watchers)]
            before = status().get("last_trial_number", 0)
            post("api/session/next", {})
            while status().get("last_trial_number", 0) == before:
                time.sleep(0.2)
            for d in drivers:
                d.quit()
            rows.append(watchers)
        post("api/session/stop", {})
    finally:
        proc.terminate()
        proc.wait()
    conn = sqlite3.connect(db)
    timing = conn.execute("SELECT l.p50_period_s, l.p99_period_s, l.max_period_s, l.overruns, l.count FROM loop_timing l "
                          "JOIN trial t ON t.id = l.trial_id WHERE t.status IN ('complete', 'aborted') "
                          "ORDER BY t.started_unix_s").fetchall()
    print("| trial | watching browsers | updates | p50 period | p99 period | max period | overruns |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for k, (w, t) in enumerate(zip(rows, timing), 1):
        print(f"| {k} | {w} | {t[4]} | {1e6 * t[0]:.1f} µs | {1e6 * t[1]:.1f} µs | {1e6 * t[2]:.1f} µs | {t[3]} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
