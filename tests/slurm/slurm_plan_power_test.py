"""`plan power` on a real Slurm cluster (issue 36 §3), through the scripts a
lab uses: scripts/slurm/submit_plan_power.sh submits a job array of 3
shards (plan_power.sbatch) and the merge that waits for it
(plan_merge.sbatch, --dependency=afterok). The merged files must equal a
one-machine run of the same plan byte for byte. Then one shard is cancelled
with scancel half-way (the merge after it is cancelled too, its dependency
never met); resubmitted alone (sbatch --array=1), it resumes from the
studies it stored, and the merge, submitted again, gives the same files.

The cluster is private (tests/slurm/single_node_slurm.py). When it cannot
start here, the test says why and is skipped (exit 77), never passed.

usage: slurm_plan_power_test.py HAPTICLAB_CLI SOURCE_DIR WORK_DIR
"""
import os
import shutil
import sqlite3
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from single_node_slurm import SingleNodeSlurm, SlurmUnavailable  # noqa: E402

SKIP = 77


def fail(message):
    print("FAIL: " + message, flush=True)
    sys.exit(1)


def stored(db):
    try:
        with sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=2) as c:
            return c.execute("SELECT count(*) FROM study").fetchone()[0]
    except sqlite3.Error:
        return 0


def read(path):
    with open(path, "rb") as f:
        return f.read()


def same_files(one, merged, what):
    names = [n for n in os.listdir(one) if n.endswith((".csv", ".md", ".svg"))]
    if "power.csv" not in names or not any(n.endswith(".svg") for n in names):
        fail(f"the one-machine run wrote no power.csv or figure: {sorted(os.listdir(one))}")
    for n in sorted(names):
        if not os.path.exists(os.path.join(merged, n)):
            fail(f"{what}: {n} is missing from {merged}")
        if read(os.path.join(one, n)) != read(os.path.join(merged, n)):
            fail(f"{what}: {n} differs from the one-machine run's")
    print(f"  {what}: {', '.join(sorted(names))} equal the one-machine run's, byte for byte")


def wait_for(what, predicate, timeout_s):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.05)
    fail(f"timed out after {timeout_s} s waiting for {what}")


def main():
    cli, source, work = (os.path.abspath(a) for a in sys.argv[1:4])
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    settings = os.path.join(source, "examples", "settings")
    protocol = os.path.join(work, "tiny.json")
    with open(protocol, "w") as f:
        f.write('{"study": "tiny", "tasks": ["clip"], "repetitions": {"clip": 2}, "settings": ["%s", "%s"], '
                '"participants": ["A", "B"], "design": {"type": "complete"}, "seed": 5}'
                % (os.path.join(settings, "high_fidelity.json"), os.path.join(settings, "no_force_feedback.json")))
    # 24 studies: 8 per shard, so one can be cut short with studies left.
    plan = ["--protocol", protocol, "--participants", "2", "--studies", "24", "--rate-hz", "1000"]

    try:
        cluster = SingleNodeSlurm(os.path.join(work, "cluster"))
        cluster.start()
    except SlurmUnavailable as e:
        print(f"SKIPPED: a single-node Slurm cluster cannot start on this machine: {e}", flush=True)
        return SKIP
    try:
        t0 = time.monotonic()
        one = os.path.join(work, "one")
        r = subprocess.run([cli, "plan", "power"] + plan + ["--out", one], capture_output=True, text=True)
        if r.returncode != 0:
            fail(f"the one-machine run failed: {r.stdout}{r.stderr}")
        print(f"one machine: 24 studies in {time.monotonic() - t0:.1f} s")

        submit = os.path.join(source, "scripts", "slurm", "submit_plan_power.sh")
        env = dict(cluster.env, HAPTICLAB=cli,
                   # one CPU per shard: on this node of 2 CPUs two shards run at once
                   HAPTICLAB_CPUS_PER_SHARD="1")

        def submit_plan(out):
            r = subprocess.run([submit, "3", out] + plan, env=env, capture_output=True, text=True, cwd=work)
            if r.returncode != 0:
                fail(f"submit_plan_power.sh failed: {r.stdout}{r.stderr}")
            words = r.stdout.split()
            return words[words.index("array") + 2], words[words.index("merge") + 2]

        # --- 1. the array and its merge, untouched
        t0 = time.monotonic()
        out = os.path.join(work, "cluster-run")
        array, merge = submit_plan(out)
        cluster.wait([array, merge], 600)
        for job in [f"{array}_{i}" for i in range(3)] + [merge]:
            state = cluster.job_state(job)
            if state != "COMPLETED":
                fail(f"job {job} ended {state}; logs in {out}")
        print(f"Slurm: array {array} of 3 shards and merge {merge} after it, in {time.monotonic() - t0:.1f} s")
        same_files(one, os.path.join(out, "merged"), "merged from the array")

        # --- 2. a shard cancelled half-way, resubmitted alone
        out = os.path.join(work, "cancelled-run")
        array, merge = submit_plan(out)
        db = os.path.join(out, "shard-1", "plan_power.db")
        wait_for("shard 1's first stored study", lambda: stored(db) >= 1, 300)
        # scancel: SIGTERM, then SIGKILL after KillWait (2 s here). plan power
        # finishes the studies it is running (2 per CPU), commits them and
        # stops: 8 studies a shard leave some for the resubmitted one.
        cluster.run(["scancel", f"{array}_1"])
        cluster.wait([array, merge], 600)
        kept = stored(db)
        if kept >= 8:
            fail(f"shard 1 stored all {kept} of its studies before scancel took effect: nothing left to resume")
        if cluster.job_state(f"{array}_1") not in ("CANCELLED", "FAILED"):
            fail(f"shard 1 ended {cluster.job_state(f'{array}_1')}, not CANCELLED or FAILED (killed)")
        if os.path.exists(os.path.join(out, "merged", "power.csv")):
            fail("the merge ran although a shard was cancelled (afterok)")
        print(f"  shard 1 cancelled ({cluster.job_state(f'{array}_1')}) with {kept} of its 8 studies stored; "
              "the merge did not run")
        script = os.path.join(source, "scripts", "slurm", "plan_power.sbatch")
        again = cluster.sbatch(["--array=1", "--cpus-per-task=1", f"--output={out}/shard-1-again.log",
                                "--export=ALL,HAPTICLAB=" + cli, script, "3", out] + plan)
        merge2 = cluster.sbatch([f"--dependency=afterok:{again}", f"--output={out}/merge-again.log",
                                 "--export=ALL,HAPTICLAB=" + cli,
                                 os.path.join(source, "scripts", "slurm", "plan_merge.sbatch"), "3", out])
        cluster.wait([again, merge2], 600)
        log = read(os.path.join(out, "shard-1-again.log")).decode(errors="replace")
        if f"{kept} of 8 studies already in" not in log:
            fail(f"the resubmitted shard did not resume from its {kept} stored studies:\n{log}")
        if cluster.job_state(merge2) != "COMPLETED":
            fail(f"the merge after the resubmitted shard ended {cluster.job_state(merge2)}:\n"
                 + read(os.path.join(out, "merge-again.log")).decode(errors="replace"))
        print(f"  resubmitted: shard 1 resumed from {kept} stored studies")
        same_files(one, os.path.join(out, "merged"), "merged after the resubmitted shard")
    finally:
        cluster.stop()
    print("PASS")
    return 0


if __name__ == "__main__":
    sys.exit(main())
