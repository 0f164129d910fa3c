"""scripts/ctest_recap.py against a real ctest run: a small project with a
passing test and three failing ones (one a crash, one a GoogleTest
failure above its summary), run by ctest -j2 as scripts/test.sh runs the
suite; the recap names each failed test with its last lines (a GoogleTest
one with its failure), and not the passing one.

usage: ctest_recap_test.py SOURCE_DIR WORK_DIR
"""
import os
import shutil
import subprocess
import sys

PROJECT = """cmake_minimum_required(VERSION 3.16)
project(recap NONE)
enable_testing()
add_test(NAME quiet_pass COMMAND sh -c "echo all fine here")
add_test(NAME slow_fail COMMAND sh -c "for i in $(seq 1 40); do echo noise $i; done; echo 'FAIL: timed out after 60 s waiting for the plots'; exit 1")
add_test(NAME crash COMMAND sh -c "echo before the crash; kill -SEGV $$")
add_test(NAME gtest_fail COMMAND sh -c "echo '[ RUN      ] A.B'; echo 'a_test.cc:12: Failure'; echo 'Expected equality of these values:'; echo '  reasons[0]'; for i in 1 2 3 4 5 6 7 8 9; do echo summary $i; done; exit 1")
"""


def fail(message):
    sys.exit("FAIL: " + message)


def main():
    source, work = sys.argv[1:3]
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    with open(os.path.join(work, "CMakeLists.txt"), "w") as f:
        f.write(PROJECT)
    build = os.path.join(work, "build")
    subprocess.run(["cmake", "-S", work, "-B", build], check=True, capture_output=True)
    run = subprocess.run(["ctest", "--test-dir", build, "--output-on-failure", "-j2"], capture_output=True, text=True)
    if run.returncode == 0:
        fail("the failing project's ctest run passed")
    recap = subprocess.run([sys.executable, os.path.join(source, "scripts", "ctest_recap.py"), build],
                           capture_output=True, text=True)
    out = recap.stdout
    if recap.returncode != 0:
        fail(f"the recap exited {recap.returncode}: {recap.stderr}")
    lines = out.splitlines()
    heads = [l for l in lines if l.startswith("==> ")]
    if sorted(heads) != ["==> crash failed; the last 1 lines of its output:",
                         "==> gtest_fail failed; its first failure:",
                         "==> slow_fail failed; the last 8 lines of its output:"]:
        fail(f"the recap's headings: {heads}\n{out}")
    if "    a_test.cc:12: Failure\n    Expected equality of these values:\n      reasons[0]\n    summary 1" not in out \
            or "summary 6" in out:
        fail(f"the recap does not show the GoogleTest failure and the 7 lines after it:\n{out}")
    if "FAIL: timed out after 60 s waiting for the plots" not in out or "noise 34" not in out or "noise 33" in out:
        fail(f"the recap is not slow_fail's last 8 lines:\n{out}")
    if "all fine here" in out:
        fail(f"the recap shows the passing test:\n{out}")
    print("ctest recap: the failed tests' last lines, and only theirs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
