#!/usr/bin/env python3
"""scripts/slurm_bench.sh through a real Slurm: a single-node cluster (munged, slurmctld, slurmd
on this machine, as root, in a temporary folder) runs a sweep as a job array of two shards and a
merge job after them; the merge equals a one-process run of the same sweep."""
import csv
import os
import shutil
import socket
import subprocess
import tempfile
import time
import unittest

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "..", "scripts", "slurm_bench.sh")
BENCH_ARGS = ["--object", "procedural:sphere", "--size-m", "0.1", "--strategy", "atlas_poke,random", "--seeds", "0",
              "--max-actions", "2", "--set", "view/max_surface_points=200",
              "--no-reachability", "--no-plot"]
RUNS_TIMING = {"wall_s", "plan_ms_median", "update_ms_median", "approach_plan_ms_median"}


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def runs_without_timing(folder):
    with open(os.path.join(folder, "runs.csv")) as f:
        return [{k: v for k, v in r.items() if k not in RUNS_TIMING} for r in csv.DictReader(f)]


class SlurmCluster:
    """munged, slurmctld and slurmd in the foreground, their state and logs under `root`."""

    def __init__(self, root):
        self.root = root
        self.daemons = []
        self.conf = os.path.join(root, "slurm.conf")
        socket_path = os.path.join(root, "munge.socket")
        for d in ("state", "spool", "log"):
            os.makedirs(os.path.join(root, d))
        host = socket.gethostname()
        with open(self.conf, "w") as f:
            f.write("\n".join([
                "ClusterName=gpatlas_test", "SlurmctldHost=%s" % host, "SlurmUser=root", "SlurmdUser=root",
                "AuthType=auth/munge", "AuthInfo=socket=%s" % socket_path,
                "StateSaveLocation=%s/state" % root, "SlurmdSpoolDir=%s/spool" % root,
                "SlurmctldPidFile=%s/slurmctld.pid" % root, "SlurmdPidFile=%s/slurmd.pid" % root,
                "SlurmctldPort=%d" % free_port(), "SlurmdPort=%d" % free_port(),
                "SlurmctldLogFile=%s/log/slurmctld.log" % root, "SlurmdLogFile=%s/log/slurmd.log" % root,
                "ProctrackType=proctrack/linuxproc", "TaskPlugin=task/none", "MpiDefault=none",
                "SchedulerType=sched/backfill", "SelectType=select/cons_tres", "SelectTypeParameters=CR_Core",
                "JobAcctGatherType=jobacct_gather/none", "AccountingStorageType=accounting_storage/none",
                "ReturnToService=2",
                "NodeName=%s CPUs=%d RealMemory=1000 State=UNKNOWN" % (host, os.cpu_count() or 1),
                "PartitionName=test Nodes=%s Default=YES MaxTime=INFINITE State=UP" % host, ""]))
        self.env = dict(os.environ, SLURM_CONF=self.conf)
        # -f: munged refuses to run as root, or with a key it did not make, unless forced.
        self.start(["munged", "-F", "-f", "--socket=" + socket_path, "--pid-file=%s/munged.pid" % root,
                    "--log-file=%s/log/munged.log" % root, "--seed-file=%s/munge.seed" % root])
        time.sleep(1)
        self.start(["slurmctld", "-D", "-f", self.conf])
        time.sleep(1)
        self.start(["slurmd", "-D", "-f", self.conf])
        deadline = time.time() + 30
        while time.time() < deadline:
            info = subprocess.run(["sinfo", "-h", "-o", "%t"], env=self.env, capture_output=True, text=True)
            if info.stdout.strip() == "idle":
                return
            time.sleep(0.5)
        self.stop()
        raise RuntimeError("the single-node cluster did not come up: sinfo says %r %r\n%s" % (
            info.stdout, info.stderr, self.logs()))

    def start(self, command):
        log = open(os.path.join(self.root, "log", command[0] + ".out"), "w")
        self.daemons.append(subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, env=os.environ))

    def logs(self):
        text = ""
        for name in sorted(os.listdir(os.path.join(self.root, "log"))):
            with open(os.path.join(self.root, "log", name)) as f:
                text += "--- %s\n%s" % (name, f.read()[-2000:])
        return text

    def sbatch(self, *args):
        proc = subprocess.run(["sbatch", "--parsable", *args], env=self.env, capture_output=True, text=True,
                              cwd=self.root, timeout=900)
        return proc

    def stop(self):
        for daemon in reversed(self.daemons):
            daemon.terminate()
            try:
                daemon.wait(timeout=20)
            except subprocess.TimeoutExpired:
                daemon.kill()
                daemon.wait()
        self.daemons = []


@unittest.skipUnless(shutil.which("slurmctld") and shutil.which("munged"),
                     "Slurm and munge are not installed (scripts/install_deps.sh installs them)")
class SlurmBenchTest(unittest.TestCase):
    def setUp(self):
        if os.geteuid() != 0:
            self.skipTest("a single-node Slurm needs root (slurmd starts the jobs as their user)")
        self.tmp = tempfile.mkdtemp(prefix="gpatlas_bench_slurm_")
        self.cluster = SlurmCluster(os.path.join(self.tmp, "cluster"))

    def tearDown(self):
        self.cluster.stop()
        shutil.rmtree(self.tmp, ignore_errors=True)

    def test_a_job_array_and_a_merge_job_give_a_one_process_run(self):
        sweep = os.path.join(self.tmp, "sweep")
        array = self.cluster.sbatch("--array=1-2", SCRIPT, *BENCH_ARGS, "--out", sweep)
        self.assertEqual(array.returncode, 0, array.stdout + array.stderr)
        job = array.stdout.strip().split(";")[0]
        one = os.path.join(self.tmp, "one")
        alone = subprocess.run(["rosrun", "probe_sim", "gpatlas_bench", *BENCH_ARGS, "--out", one],
                               capture_output=True, text=True, timeout=600)
        self.assertEqual(alone.returncode, 0, alone.stdout + alone.stderr)
        # --wait: sbatch returns when the merge job ends, with its exit code.
        merge = self.cluster.sbatch("--wait", "--dependency=afterany:" + job, SCRIPT, "--merge", "--no-plot",
                                    "--out", sweep)
        outputs = ""
        for name in sorted(os.listdir(self.cluster.root)):
            if name.startswith("slurm-"):
                with open(os.path.join(self.cluster.root, name)) as f:
                    outputs += "--- %s\n%s" % (name, f.read()[-3000:])
        self.assertEqual(merge.returncode, 0, merge.stdout + merge.stderr + outputs + self.cluster.logs())
        self.assertIn("merged 2 run(s) of 2 shard folder(s)", outputs)
        for k in (1, 2):
            self.assertTrue(os.path.exists(os.path.join(sweep, "shard_%d_of_2" % k, "shard.txt")), outputs)
        self.assertEqual(runs_without_timing(sweep), runs_without_timing(one))
        self.assertTrue(os.path.exists(os.path.join(sweep, "summary.md")))


if __name__ == "__main__":
    unittest.main()
