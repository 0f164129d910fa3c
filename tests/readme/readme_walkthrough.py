#!/usr/bin/env python3
"""Runs the README's walk-through as a new user would: every `sh` block from
"## Walk-through" up to "## Conventions", in order, in an empty folder that
holds only `build/` and `examples/` (as a fresh clone after scripts/demo.sh).

A few commands cannot run as written in CI; each gets one rewrite below, with
its reason. A rewrite whose text no longer appears in the README fails the
test, so the table cannot drift from the README silently.

    readme_walkthrough.py --source-dir SRC --build-dir BUILD [--work-dir DIR]
"""
import argparse
import os
import re
import shlex
import shutil
import socket
import subprocess
import sys
import tempfile
import time


def free_udp_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def rewrites():
    port = str(free_udp_port())
    return [
        # (text in the README, what CI runs instead, why)
        ("--clock wall", "--clock virtual",
         "real time takes about 30 minutes per participant"),
        ("device check --device plugin:/opt/lab/libmydevice.so --seconds 2",
         "device check --device plugin:build/plugins/hapticlab_sim_device.so --seconds 2 --rate-tolerance 0.5",
         "the check's wall-clock rate is the CI machine's, busy with other tests: 721 Hz of 1000 was seen "
         "once under load; the plugin is checked, not the machine (as tests/app/device_check_test.cc does)"),
        ("plugin:/opt/lab/libmydevice.so", "plugin:build/plugins/hapticlab_sim_device.so",
         "the lab's own driver: the shipped simulated workstation stands in"),
        (" --device-option port=/dev/ttyUSB0", "",
         "an option of the lab's own driver"),
        ("--seconds 10", "--seconds 1",
         "bench loop measures in wall-clock time; 1 s shows it runs"),
        ("--port 5000", "--port " + port, "port 5000 may be taken on a CI machine"),
        ("127.0.0.1:5000", "127.0.0.1:" + port, "the same free port"),
        ("--participants 3,5,8 --studies 200", "--participants 3 --studies 2 --rate-hz 250",
         "plan power's 600 studies take about half an hour on 2 cores; 2 at a quarter of "
         "the rate (18 s at 1 kHz) show it runs"),
        ("--participants 8,16 --studies 40", "--participants 2 --studies 1 --rate-hz 250",
         "the device comparison's 960 simulated participants take about 20 minutes on 2 cores; "
         "one study of 2 at a quarter of the rate shows it runs"),
        ("--studies 40 --participants 8,16", "--studies 1 --participants 2",
         "the transfer design's 80 studies take about 12 minutes on 2 cores; one of 2 per group shows it runs"),
        ("--participants 100 --out calibration/",
         "--participants 2 --out calibration/ && test -s calibration/calibration.inputs.json",
         "plan calibrate's 100 participants take about two minutes on 2 cores; 2 show it runs "
         "(and the table's record of what it was made from is written)"),
        ("plan calibrate --fit --out calibration/",
         "plan calibrate --fit --fit-studies 1 --rate-hz 150 --out calibration-fit/; "
         "test $? -eq 1 && test -f calibration-fit/fit_summary.json && test ! -e calibration-fit/population.json",
         "the fit's 432 studies take about 8 minutes on 2 cores; 9 studies at 150 Hz run every step in about "
         "10 s and must refuse to converge (exit 1, diagnostics written, no population)"),
        ("stability map --out stability-map",
         "stability map --rates 1000 --stiffness 2000 --effects translation.inertia.mass_kg --out stability-map",
         "the whole map takes about 20 s, minutes under the sanitizers; one parameter shows it runs"),
    ]


def walkthrough_commands(readme_text):
    """The `sh` blocks' commands between the two headings, continuation lines
    joined and trailing comments dropped, in README order."""
    start = readme_text.index("\n## Walk-through")
    end = readme_text.index("\n## Conventions")
    section = readme_text[start:end]
    commands = []
    for block in re.findall(r"```sh\n(.*?)```", section, flags=re.S):
        block = re.sub(r"\\\n\s*", " ", block)
        for line in block.splitlines():
            # A comment starts at " #" after the command (no '#' in our arguments).
            line = re.sub(r"\s+#.*$", "", line).strip()
            if line:
                commands.append(line)
    return commands


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--source-dir", required=True)
    parser.add_argument("--build-dir", required=True)
    parser.add_argument("--work-dir")
    args = parser.parse_args()

    with open(os.path.join(args.source_dir, "README.md"), encoding="utf-8") as f:
        commands = walkthrough_commands(f.read())
    if len(commands) < 20:
        sys.exit(f"found only {len(commands)} commands in the README walk-through; "
                 "did its headings change?")

    table = rewrites()
    used = set()
    runnable = []
    for command in commands:
        original = command
        for i, (text, replacement, _why) in enumerate(table):
            if text in command:
                command = command.replace(text, replacement)
                used.add(i)
        runnable.append((original, command))
    stale = [table[i] for i in range(len(table)) if i not in used]
    if stale:
        sys.exit("README changed: these rewrites no longer apply; update "
                 "tests/readme/readme_walkthrough.py: " + "; ".join(t[0] for t in stale))
    for bad in ("[", "]", "<", ">", "PATH", "FILE"):
        for original, command in runnable:
            words = shlex.split(command)
            if any(w.startswith(bad) or w.endswith(bad) or w == bad for w in words):
                sys.exit(f"README command has a placeholder ({bad!r}) a reader cannot paste: {original}")

    work = args.work_dir or tempfile.mkdtemp(prefix="readme_walkthrough_")
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    os.symlink(os.path.abspath(args.build_dir), os.path.join(work, "build"))
    os.symlink(os.path.join(os.path.abspath(args.source_dir), "examples"),
               os.path.join(work, "examples"))

    background = []
    failures = 0
    failed = []  # named again at the end, where a CI log's tail shows them
    try:
        for original, command in runnable:
            shown = command if command == original else f"{command}    (README: {original})"
            print(f"$ {shown}", flush=True)
            started = time.monotonic()
            if command.endswith("&"):
                # A server the next commands use: started, and waited for until
                # it prints its first line (it says where it listens).
                proc = subprocess.Popen(command[:-1], shell=True, cwd=work,
                                        stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                        text=True, start_new_session=True)
                background.append(proc)
                first = proc.stdout.readline()
                print("  " + first.rstrip(), flush=True)
                if proc.poll() is not None:
                    print(f"  FAILED: the server exited with {proc.returncode}")
                    failures += 1
                    failed.append(f"$ {command} (exited {proc.returncode}: {first.strip()[:200]})")
                continue
            result = subprocess.run(["bash", "-c", command], cwd=work, capture_output=True,
                                    text=True, timeout=300)
            took = time.monotonic() - started
            tail = (result.stdout + result.stderr).strip().splitlines()[-3:]
            for line in tail:
                print("  " + line)
            print(f"  -> exit {result.returncode} after {took:.1f} s", flush=True)
            if result.returncode != 0:
                failures += 1
                print("  FAILED; its whole output:\n" + result.stdout + result.stderr)
                said = (tail[-1] if tail else "")[:200]
                failed.append(f"$ {command} (exit {result.returncode} after {took:.1f} s: {said})")
    finally:
        for proc in background:
            os.killpg(proc.pid, 2)
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, 9)
                proc.wait()
    for line in failed:
        print("FAILED " + line)
    print(f"{len(runnable)} README commands run, {failures} failed")
    if not args.work_dir:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
