#!/usr/bin/env python3
"""The demo (sim_exploration.launch, running) and gpatlas_bench, at the same configuration, object,
strategy and seed, run one exploration: the same first actions (each one's contact count and the
planner's variance), then a run of about the same length with about the same final shape. On the
procedural mug at the defaults the two part at action 8 (a cause not yet found: the probe's
observations cross ROS messages and tf in one, not in the other), so the opening is compared
up to action 5."""
import csv
import json
import os
import shutil
import subprocess
import tempfile
import time
import unittest

import rospy

SAME_FIRST_ACTIONS = 5
VARIANCE_TOLERANCE = 1e-3
ACTIONS_RELATIVE_TOLERANCE = 0.35
# Past the divergence they are two explorations of one object, which differ as runs with
# different seeds do: the bench's atlas_poke runs of the mug over seeds 0-2 end between 5.9 and
# 7.0 mm predicted->truth. Wider than that spread, a difference means that one pipeline's shape
# is off.
RMSE_TOLERANCE_M = 0.002


class BenchMatchesDemoTest(unittest.TestCase):
    def test_same_exploration(self):
        results = rospy.get_param("~results_dir")
        report_path = os.path.join(results, "report.json")
        deadline = time.time() + 300.0
        while not os.path.exists(report_path) and time.time() < deadline:
            time.sleep(1.0)
        self.assertTrue(os.path.exists(report_path), "the demo wrote no report.json in 300 s")
        time.sleep(1.0)  # written in one go, but give the file system a moment
        with open(report_path) as f:
            demo = json.load(f)

        out = tempfile.mkdtemp(prefix="gpatlas_bench_vs_demo_")
        try:
            # No object, strategy or seed given: the config's, as the demo.
            proc = subprocess.run(["rosrun", "probe_sim", "gpatlas_bench", "--no-reachability", "--no-plot",
                                   "--curve-every", "0", "--out", out], capture_output=True, text=True, timeout=300)
            self.assertEqual(proc.returncode, 0, proc.stdout + proc.stderr)
            with open(os.path.join(out, "runs.csv")) as f:
                runs = list(csv.DictReader(f))
            with open(os.path.join(out, "history.csv")) as f:
                bench_history = [h for h in csv.DictReader(f) if h["action"] != "0"]
        finally:
            shutil.rmtree(out, ignore_errors=True)
        self.assertEqual(len(runs), 1, runs)
        bench = runs[0]
        summary = "demo: %s after %d actions, %s; bench: %s after %s actions, %s / %s" % (
            demo["status"], demo["actions"], demo["final_metrics"], bench["status"], bench["actions"],
            bench["rmse_pred_to_gt_m"], bench["rmse_gt_to_pred_m"])
        print(summary)
        # Past the divergence one run may converge where the other stops after failed touches.
        self.assertFalse(demo["status"].startswith("error"), summary)
        self.assertFalse(bench["status"].startswith("error"), summary)
        self.assertEqual(bench["object"], "mug", summary)
        self.assertEqual(bench["strategy"], demo["settings"]["strategy"], summary)
        demo_history = demo["history"]
        self.assertGreaterEqual(min(len(demo_history), len(bench_history)), SAME_FIRST_ACTIONS, summary)
        for d, b in zip(demo_history[:SAME_FIRST_ACTIONS], bench_history[:SAME_FIRST_ACTIONS]):
            self.assertEqual(d["contacts_total"], int(b["contacts_total"]), "action %d: %s" % (d["action"], summary))
            self.assertAlmostEqual(d["max_evaluated_variance"], float(b["max_evaluated_variance"]),
                                   delta=VARIANCE_TOLERANCE, msg="action %d: %s" % (d["action"], summary))
        self.assertLessEqual(abs(int(bench["actions"]) - demo["actions"]),
                             ACTIONS_RELATIVE_TOLERANCE * max(int(bench["actions"]), demo["actions"]), summary)
        for key in ("rmse_pred_to_gt_m", "rmse_gt_to_pred_m"):
            self.assertLessEqual(abs(float(bench[key]) - demo["final_metrics"][key]), RMSE_TOLERANCE_M,
                                 "%s: %s" % (key, summary))


if __name__ == "__main__":
    import rostest

    rospy.init_node("bench_matches_demo_test")
    rostest.rosrun("probe_sim_ros", "bench_matches_demo", BenchMatchesDemoTest)
