#!/usr/bin/env python3
"""The demo (sim_exploration.launch, running) and gpatlas_bench, at the same configuration, object,
strategy and seed: the same number of actions within one, and final RMSEs within 0.5 mm in both
directions. The two differ only where the arithmetic does (float32 clouds, tf)."""
import csv
import json
import os
import shutil
import subprocess
import tempfile
import time
import unittest

import rospy

ACTIONS_TOLERANCE = 1
RMSE_TOLERANCE_M = 0.0005


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
        finally:
            shutil.rmtree(out, ignore_errors=True)
        self.assertEqual(len(runs), 1, runs)
        bench = runs[0]
        summary = "demo: %s after %d actions, %s; bench: %s after %s actions, %s / %s" % (
            demo["status"], demo["actions"], demo["final_metrics"], bench["status"], bench["actions"],
            bench["rmse_pred_to_gt_m"], bench["rmse_gt_to_pred_m"])
        print(summary)
        self.assertFalse(demo["status"].startswith("error"), summary)
        self.assertEqual(bench["status"], demo["status"], summary)
        self.assertEqual(bench["object"], "mug", summary)
        self.assertEqual(bench["strategy"], demo["settings"]["strategy"], summary)
        self.assertLessEqual(abs(int(bench["actions"]) - demo["actions"]), ACTIONS_TOLERANCE, summary)
        for key in ("rmse_pred_to_gt_m", "rmse_gt_to_pred_m"):
            self.assertLessEqual(abs(float(bench[key]) - demo["final_metrics"][key]), RMSE_TOLERANCE_M,
                                 "%s: %s" % (key, summary))


if __name__ == "__main__":
    import rostest

    rospy.init_node("bench_matches_demo_test")
    rostest.rosrun("probe_sim_ros", "bench_matches_demo", BenchMatchesDemoTest)
