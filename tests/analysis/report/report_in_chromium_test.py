#!/usr/bin/python3
"""The report of a real study, checked in headless Chromium
(check_report_html.py): a thesis_quick study, one participant's session on
the simulated rig, `hapticlab analyze` with its figures, then no duplicate
ids, no clipped SVG text, figures as wide as the column; screenshots in
WORK_DIR/shots. Exit 77 (ctest: skipped) when Chromium or Selenium is
missing.

usage: report_in_chromium_test.py HAPTICLAB_CLI SOURCE_DIR WORK_DIR
"""
import os
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import check_report_html  # noqa: E402


def run(*args):
    done = subprocess.run(list(args), capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{' '.join(args)} exited {done.returncode}:\n{done.stdout}{done.stderr}")


def main():
    cli, source, work = sys.argv[1:4]
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    db = os.path.join(work, "study.db")
    run(cli, "study", "create", "--protocol", os.path.join(source, "examples/protocols/thesis_quick.json"), "--db", db)
    run(cli, "session", "run", "--db", db, "--participant", "S1", "--training-trials", "0")
    run(cli, "session", "run", "--db", db, "--participant", "S2", "--training-trials", "0")
    run(cli, "analyze", "--db", db, "--out", os.path.join(work, "report"), "--no-ks")
    sys.argv = [sys.argv[0], os.path.join(work, "report", "report.html"), os.path.join(work, "shots")]
    return check_report_html.main()


if __name__ == "__main__":
    sys.exit(main())
