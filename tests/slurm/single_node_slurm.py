"""A real, private, single-node Slurm cluster for tests: its own munge
daemon and key, slurmctld and slurmd on free ports, all state under one
folder, nothing of the machine's own Slurm or munge configuration read or
changed. Debian's slurm-wlm and munge packages provide the daemons
(scripts/setup.sh installs them with the test suite's packages).

    with SingleNodeSlurm(work_dir) as cluster:
        job = cluster.sbatch(["--array=0-2", "script.sbatch", ...])
        cluster.wait([job])

When the cluster cannot start on this machine, SlurmUnavailable says why
(the caller skips the test with that reason; it never passes it).
"""
import os
import shutil
import socket
import subprocess
import time


class SlurmUnavailable(Exception):
    pass


def _free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class SingleNodeSlurm:
    def __init__(self, work_dir, cpus=None):
        self.dir = os.path.abspath(work_dir)
        self.cpus = cpus or os.cpu_count() or 1
        self.conf = os.path.join(self.dir, "slurm.conf")
        self.env = dict(os.environ, SLURM_CONF=self.conf)
        self._munged = None
        self._daemons_started = False

    # --- start and stop
    def __enter__(self):
        try:
            self.start()
        except BaseException:
            self.stop()
            raise
        return self

    def __exit__(self, *exc):
        self.stop()

    def start(self):
        for tool in ("munged", "slurmctld", "slurmd", "sbatch", "squeue", "scontrol", "scancel"):
            if not shutil.which(tool, path=os.environ.get("PATH", "") + ":/usr/sbin:/sbin"):
                raise SlurmUnavailable(f"{tool} is not installed (Debian packages slurm-wlm and munge)")
        if os.geteuid() != 0:
            raise SlurmUnavailable("slurmd runs jobs as their user only when started as root; this test runs as "
                                   f"uid {os.geteuid()}")
        shutil.rmtree(self.dir, ignore_errors=True)
        munge_dir = os.path.join(self.dir, "munge")
        for d in ("munge", "socket", "state", "spool", "log"):
            os.makedirs(os.path.join(self.dir, d), exist_ok=True)
        os.chmod(munge_dir, 0o700)
        # munged wants the socket's folders searchable by everyone (0755).
        os.chmod(self.dir, 0o755)
        os.chmod(os.path.join(self.dir, "socket"), 0o755)
        key = os.path.join(munge_dir, "munge.key")
        with open(key, "wb") as f:
            f.write(os.urandom(1024))
        os.chmod(key, 0o400)
        self.munge_socket = os.path.join(self.dir, "socket", "munge.socket")
        munged = shutil.which("munged", path="/usr/sbin:/sbin:" + os.environ.get("PATH", ""))
        self._munged = subprocess.Popen(
            [munged, "--foreground", "--socket=" + self.munge_socket, "--key-file=" + key,
             "--pid-file=" + os.path.join(munge_dir, "munged.pid"),
             "--log-file=" + os.path.join(munge_dir, "munged.log"),
             "--seed-file=" + os.path.join(munge_dir, "munged.seed")],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        self._wait_for(lambda: os.path.exists(self.munge_socket), 10,
                       lambda: "munged did not start: " + self._munged_error())
        ctld_port, d_port = _free_port(), _free_port()
        with open(self.conf, "w") as f:
            f.write(f"""# A private single-node cluster for HapticLab's tests (tests/slurm/single_node_slurm.py)
ClusterName=hapticlab-test
SlurmctldHost=localhost
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket={self.munge_socket}
CredType=cred/munge
SlurmctldPort={ctld_port}
SlurmdPort={d_port}
StateSaveLocation={self.dir}/state
SlurmdSpoolDir={self.dir}/spool/%n
SlurmctldPidFile={self.dir}/slurmctld.pid
SlurmdPidFile={self.dir}/slurmd.pid
SlurmctldLogFile={self.dir}/log/slurmctld.log
SlurmdLogFile={self.dir}/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
# A job's steps are killed at once when cancelled (no 30 s grace).
KillWait=2
NodeName=localhost NodeHostname={socket.gethostname()} CPUs={self.cpus} RealMemory=1000 State=UNKNOWN
PartitionName=test Nodes=localhost Default=YES MaxTime=INFINITE State=UP
""")
        for daemon in ("slurmctld", "slurmd"):
            args = [shutil.which(daemon, path="/usr/sbin:/sbin:" + os.environ.get("PATH", "")), "-f", self.conf]
            if daemon == "slurmd":
                args += ["-N", "localhost"]
            r = subprocess.run(args, env=self.env, capture_output=True, text=True, timeout=30)
            self._daemons_started = True
            if r.returncode != 0:
                raise SlurmUnavailable(f"{daemon} did not start (exit {r.returncode}): {r.stderr.strip()} "
                                       f"{self._log_tail(daemon)}")
        self._wait_for(self._node_idle, 30, lambda: "the node did not come up idle: " +
                       self.run(["sinfo", "-N", "-h", "-o", "%N %T %E"], check=False) + self._log_tail("slurmd"))

    def stop(self):
        if self._daemons_started:
            subprocess.run(["scancel", "--user=root"], env=self.env, capture_output=True, timeout=10)
            subprocess.run(["scontrol", "shutdown"], env=self.env, capture_output=True, timeout=20)
            for pidfile in ("slurmd.pid", "slurmctld.pid"):
                self._kill_pidfile(os.path.join(self.dir, pidfile))
            self._daemons_started = False
        if self._munged is not None:
            self._munged.terminate()
            try:
                self._munged.wait(5)
            except subprocess.TimeoutExpired:
                self._munged.kill()
                self._munged.wait()
            self._munged = None

    # --- jobs
    def run(self, args, check=True):
        r = subprocess.run(args, env=self.env, capture_output=True, text=True, timeout=60)
        if check and r.returncode != 0:
            raise RuntimeError(f"{' '.join(args)}: exit {r.returncode}: {r.stderr.strip()}")
        return r.stdout.strip()

    def sbatch(self, args):
        """Submits; returns the job id (an array's base id)."""
        return self.run(["sbatch", "--parsable"] + list(args)).split(";")[0]

    def states(self, job):
        """{array task id or job id: state} of a job still known to slurmctld."""
        out = self.run(["squeue", "-h", "-j", job, "-o", "%i %T"], check=False)
        return dict(line.split() for line in out.splitlines() if line.strip())

    def job_state(self, job_id):
        """COMPLETED, FAILED, CANCELLED, RUNNING, PENDING, ... of one job or array task ("123_1")."""
        out = self.run(["scontrol", "-o", "show", "job", job_id], check=False)
        for field in out.split():
            if field.startswith("JobState="):
                return field.split("=", 1)[1]
        return "UNKNOWN"

    def wait(self, jobs, timeout_s):
        """Until none of `jobs` is pending or running; the states of every task then."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if not any(self.states(j) for j in jobs):
                return
            time.sleep(0.5)
        raise RuntimeError(f"jobs {jobs} still queued or running after {timeout_s} s: "
                           + "; ".join(f"{j}: {self.states(j)}" for j in jobs))

    # --- helpers
    def _node_idle(self):
        out = self.run(["sinfo", "-N", "-h", "-o", "%T"], check=False)
        return out.strip().lower().startswith("idle")

    @staticmethod
    def _wait_for(predicate, timeout_s, why):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if predicate():
                return
            time.sleep(0.1)
        raise SlurmUnavailable(why())

    def _munged_error(self):
        if self._munged.poll() is not None:
            return f"exit {self._munged.returncode}: {self._munged.stderr.read().strip()}"
        return "no socket after 10 s"

    def _log_tail(self, daemon):
        try:
            with open(os.path.join(self.dir, "log", daemon + ".log")) as f:
                return " | log: " + " / ".join(f.read().splitlines()[-4:])
        except OSError:
            return ""

    @staticmethod
    def _kill_pidfile(path):
        try:
            with open(path) as f:
                pid = int(f.read().strip())
        except (OSError, ValueError):
            return
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                return
            time.sleep(0.1)
        try:
            os.kill(pid, 9)
        except ProcessLookupError:
            pass
