#!/usr/bin/env python3
"""gpatlas_bench --shard K/N and --merge: merged shards give a one-process run's tables, row for
row, and a merge refuses folders that do not make one sweep."""
import csv
import os
import shutil
import subprocess
import tempfile
import unittest

# Two objects, two strategies, one seed: four jobs, so that two shards each run two.
BENCH_ARGS = ["--object", "procedural:sphere", "--object", "procedural:box", "--size-m", "0.1",
              "--strategy", "atlas_poke,random", "--seeds", "0", "--max-actions", "3",
              "--set", "view/max_surface_points=200", "--no-plot"]
JOBS = [("sphere", "atlas_poke", "0"), ("sphere", "random", "0"), ("box", "atlas_poke", "0"), ("box", "random", "0")]

# The wall-clock columns: the only ones that may differ between two runs of the same job.
RUNS_TIMING = {"wall_s", "plan_ms_median", "update_ms_median", "approach_plan_ms_median"}
HISTORY_TIMING = {"plan_ms", "probe_ms", "update_ms", "approach_ms", "approach_plan_ms", "measure_ms"}


def bench(*args, **kwargs):
    return subprocess.Popen(["rosrun", "probe_sim", "gpatlas_bench", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kwargs)


def finish(proc):
    out, err = proc.communicate(timeout=600)
    return proc.returncode, out, err


def read_csv(path):
    with open(path) as f:
        reader = csv.DictReader(f)
        return reader.fieldnames, list(reader)


def timing_columns(header):
    return {c for c in header if c == "wall_s" or c.endswith("_ms") or c.endswith("_ms_median")}


def without(rows, columns):
    return [{k: v for k, v in r.items() if k not in columns} for r in rows]


def summary_without_timing(path):
    # The planning-time lines ("- atlas_poke: median 21.2 ms over 12 plans; ...") are wall-clock.
    with open(path) as f:
        return [line for line in f.read().splitlines() if not (line.startswith("- ") and " ms" in line)]


class BenchShardsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.mkdtemp(prefix="gpatlas_bench_shards_")
        # The scene as a file of the sweep's own, which a test edits between two shards.
        cls.scene = os.path.join(cls.tmp, "simulation.yaml")
        shutil.copyfile(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config", "simulation.yaml"),
                        cls.scene)
        cls.args = BENCH_ARGS + ["--simulation", cls.scene]
        cls.one = os.path.join(cls.tmp, "one")
        cls.shards = [os.path.join(cls.tmp, "shard_%d" % k) for k in (1, 2)]
        # Both shards at once, one worker each, then the one-process run on two workers.
        procs = [bench(*cls.args, "--shard", "%d/2" % k, "--out", folder)
                 for k, folder in zip((1, 2), cls.shards)]
        cls.shard_results = [finish(p) for p in procs]
        cls.one_result = finish(bench(*cls.args, "--jobs", "2", "--out", cls.one))

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def merge(self, *folders, out=None):
        out = out or tempfile.mkdtemp(dir=self.tmp, prefix="merged_")
        return out, finish(bench("--merge", *folders, "--out", out, "--no-plot"))

    def test_merged_shards_equal_a_one_process_run(self):
        for rc, out, err in self.shard_results + [self.one_result]:
            self.assertEqual(rc, 0, out + err)
        # Shard K of 2 ran the jobs j with j % 2 == K - 1, in job order.
        for k, folder in enumerate(self.shards):
            _, rows = read_csv(os.path.join(folder, "runs.csv"))
            self.assertEqual([(r["object"], r["strategy"], r["seed"]) for r in rows], JOBS[k::2])
        merged, (rc, out, err) = self.merge(*reversed(self.shards))
        self.assertEqual(rc, 0, out + err)
        self.assertIn("merged 4 run(s)", out)
        for name, timing in (("runs.csv", RUNS_TIMING), ("history.csv", HISTORY_TIMING)):
            header_one, rows_one = read_csv(os.path.join(self.one, name))
            header_merged, rows_merged = read_csv(os.path.join(merged, name))
            self.assertEqual(header_merged, header_one)
            self.assertEqual(timing_columns(header_one), timing, name)
            self.assertEqual(len(rows_merged), len(rows_one), name)
            for i, (a, b) in enumerate(zip(without(rows_one, timing), without(rows_merged, timing))):
                self.assertEqual(a, b, "%s row %d" % (name, i + 1))
        _, rows = read_csv(os.path.join(merged, "runs.csv"))
        self.assertEqual([(r["object"], r["strategy"], r["seed"]) for r in rows], JOBS)
        with open(os.path.join(self.one, "reachability.csv")) as a, open(os.path.join(merged, "reachability.csv")) as b:
            reach = a.read()
            self.assertEqual(b.read(), reach)
        self.assertEqual(len(reach.splitlines()), 1 + len(JOBS))
        self.assertEqual(summary_without_timing(os.path.join(merged, "summary.md")),
                         summary_without_timing(os.path.join(self.one, "summary.md")))
        self.assertIn("| **mean** |", "\n".join(summary_without_timing(os.path.join(merged, "summary.md"))))
        with open(os.path.join(merged, "summary.md")) as f:
            self.assertNotIn("Incomplete", f.read())

    def test_a_missing_shard_is_named_and_the_rest_merged(self):
        merged, (rc, out, err) = self.merge(self.shards[0])
        self.assertEqual(rc, 1, out + err)
        self.assertIn("2 of 4 jobs are missing", err)
        self.assertIn("job 1 (sphere random seed 0, shard 2/2)", err)
        self.assertIn("job 3 (box random seed 0, shard 2/2)", err)
        _, rows = read_csv(os.path.join(merged, "runs.csv"))
        self.assertEqual([(r["object"], r["strategy"], r["seed"]) for r in rows], JOBS[0::2])
        # summary.md, which is what gets read, says its tables lack them.
        with open(os.path.join(merged, "summary.md")) as f:
            summary = f.read()
        self.assertIn("**Incomplete:** 2 of 4 jobs are missing", summary)
        self.assertIn("- job 1 (sphere random seed 0, shard 2/2)", summary)
        self.assertIn("- job 3 (box random seed 0, shard 2/2)", summary)
        self.assertNotIn("job 0 (", summary)

    def test_a_scene_edited_between_shards_is_refused(self):
        # Shard 2 again, on the same --simulation path, the object moved 2 cm: another sweep.
        with open(self.scene) as f:
            scene = f.read()
        self.assertIn("object_position_xy_m: [0.7, 0.0]", scene)
        moved = os.path.join(self.tmp, "shard_2_moved")
        try:
            with open(self.scene, "w") as f:
                f.write(scene.replace("object_position_xy_m: [0.7, 0.0]", "object_position_xy_m: [0.72, 0.0]", 1))
            rc, out, err = finish(bench(*self.args, "--shard", "2/2", "--out", moved))
        finally:
            with open(self.scene, "w") as f:
                f.write(scene)
        self.assertEqual(rc, 0, out + err)
        merged, (rc, out, err) = self.merge(self.shards[0], moved)
        self.assertEqual(rc, 2, out + err)
        self.assertIn("different settings", err)
        self.assertIn("'files ", err)
        self.assertFalse(os.path.exists(os.path.join(merged, "runs.csv")))

    def test_a_merge_refuses_what_is_not_one_sweep(self):
        changed = os.path.join(self.tmp, "changed")
        shutil.copytree(self.shards[1], changed)
        with open(os.path.join(changed, "shard.txt")) as f:
            text = f.read()
        with open(os.path.join(changed, "shard.txt"), "w") as f:
            f.write(text.replace("arg 3\n", "arg 4\n", 1))
        incomplete = os.path.join(self.tmp, "incomplete")
        shutil.copytree(self.shards[1], incomplete)
        os.remove(os.path.join(incomplete, "history.csv"))
        cases = [
            ((self.shards[0], self.shards[1], self.shards[0]), "present twice"),
            ((self.shards[0], os.path.join(self.tmp, "no_such_shard")), "missing folder"),
            ((self.shards[0], incomplete), "missing file " + os.path.join(incomplete, "history.csv")),
            ((self.shards[0], changed), "different settings"),
            ((self.one,), "missing file " + os.path.join(self.one, "shard.txt")),
        ]
        for folders, message in cases:
            merged, (rc, out, err) = self.merge(*folders)
            self.assertEqual(rc, 2, (folders, out, err))
            self.assertIn(message, err, folders)
            self.assertFalse(os.path.exists(os.path.join(merged, "runs.csv")), folders)

    def test_bad_shard_values_are_refused(self):
        for value in ("0/2", "3/2", "2", "a/b", "1/0", "1/2/3", "-1/2", ""):
            rc, out, err = finish(bench("--shard", value, "--out", os.path.join(self.tmp, "bad")))
            self.assertEqual(rc, 2, value)
            self.assertIn("--shard needs K/N with 1 <= K <= N", err, value)
        rc, out, err = finish(bench("--merge", *self.shards, "--object", "procedural:box",
                                    "--out", os.path.join(self.tmp, "bad")))
        self.assertEqual(rc, 2)
        self.assertIn("--merge runs nothing", err)


if __name__ == "__main__":
    unittest.main()
