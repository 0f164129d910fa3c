#!/usr/bin/env python3
"""After a failed ctest run: each failed test's last lines of output, again,
at the very end of the log.

ctest --output-on-failure prints a failed test's output when it ends, which
under -j lies hundreds of lines above the summary; a CI page that keeps only
the log's tail then shows which test failed but not why. This prints, for
each test of Testing/Temporary/LastTestsFailed.log, LINES lines of its
output as ctest stored them in Testing/Temporary/LastTest.log: from its
first GoogleTest failure ("file:line: Failure") when it has one, else the
last.

usage: ctest_recap.py BUILD_DIR [LINES]
"""
import os
import re
import sys


def outputs(log_text):
    """{test name: its output} from a LastTest.log."""
    found = {}
    pattern = re.compile(r"^\d+/\d+ Test: (.+?)\n.*?^Output:\n-+\n(.*?)^<end of output>", re.S | re.M)
    for m in pattern.finditer(log_text):
        found[m.group(1)] = m.group(2)
    return found


def main():
    build = sys.argv[1]
    lines = int(sys.argv[2]) if len(sys.argv) > 2 else 8
    temporary = os.path.join(build, "Testing", "Temporary")
    try:
        with open(os.path.join(temporary, "LastTestsFailed.log")) as f:
            failed = [line.split(":", 1)[1].strip() for line in f if ":" in line]
        with open(os.path.join(temporary, "LastTest.log"), errors="replace") as f:
            told = outputs(f.read())
    except OSError as e:
        print(f"ctest recap: cannot read ctest's logs in {temporary}: {e}")
        return 0
    for name in failed:
        text = told.get(name)
        if text is None:
            print(f"==> {name} failed; ctest stored no output for it")
            continue
        out = text.rstrip("\n").splitlines()
        # GoogleTest ends with its summary; what failed is at "file:line:
        # Failure" and the lines after it.
        at = next((i for i, line in enumerate(out) if line.endswith(": Failure")), None)
        if at is not None:
            shown, what = out[at:at + lines], "its first failure"
        else:
            shown, what = out[-lines:], f"the last {min(lines, len(out))} lines of its output"
        print(f"==> {name} failed; {what}:")
        for line in shown:
            print("    " + line[:600])
    return 0


if __name__ == "__main__":
    sys.exit(main())
