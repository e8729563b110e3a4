#!/usr/bin/env python3
"""Waits for the exploration node's report and checks the results folder it writes."""
import json
import math
import os
import shutil
import time
import unittest

import rospy
import rostest
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import Marker, MarkerArray


def read_ply(path):
    """writePly's ASCII PLY: each vertex's values and the vertex properties' names."""
    with open(path) as f:
        properties, count, element = [], 0, None
        for line in f:
            words = line.split()
            if words[0] == "element":
                element = words[1]
                count = int(words[2]) if element == "vertex" else count
            elif words[0] == "property" and element == "vertex":
                properties.append(words[-1])
            elif words[0] == "end_header":
                break
        vertices = [[float(x) for x in f.readline().split()] for _ in range(count)]
    return vertices, properties


class SimExplorationTest(unittest.TestCase):
    def setUp(self):
        self.trajectories = []
        if rospy.get_param("~use_arm", False):
            rospy.Subscriber("/gpatlas/collision_map/approach_trajectory", JointTrajectory, self.trajectories.append)
        self.patches = []
        if rospy.get_param("~probe", "") == "patch":
            rospy.Subscriber("/probe_sim/patch", MarkerArray, self.patches.append)

    def test_results_folder(self):
        results = rospy.get_param("~results_dir")
        report_path = os.path.join(results, "report.json")
        deadline = time.time() + 200.0
        while not os.path.exists(report_path) and time.time() < deadline and not rospy.is_shutdown():
            time.sleep(0.5)
        self.assertTrue(os.path.exists(report_path), "no report.json after 200 s")
        # The plot is drawn from the report, after it (matplotlib takes seconds on a busy machine).
        plot_path = os.path.join(results, "exploration.png")
        plot_deadline = time.time() + 60.0
        while not os.path.exists(plot_path) and time.time() < plot_deadline:
            time.sleep(0.5)
        time.sleep(1.0)  # its writing finished
        with open(report_path) as f:
            report = json.load(f)
        self.assertIn(report["stop_reason"], ("max_actions", "consecutive_failures"), report["stop_reason"])
        self.assertLessEqual(report["actions"], 5)
        # An action whose every touch had no safe approach made none.
        probed = [h for h in report["history"] if not h["probe_reason"].startswith("no safe approach")]
        self.assertEqual(len(probed), report["actions"])
        self.assertEqual(report["contacts"], sum(h["contacts"] for h in report["history"]))
        if rospy.get_param("~probe", "") == "patch":
            # A pad's press reports a patch: several contacts for a touch that found the surface.
            touched = [h for h in probed if h["contacts"] > 0]
            self.assertTrue(touched)
            self.assertGreater(max(h["contacts"] for h in touched), 1, [h["contacts"] for h in touched])
            # rviz gets the pad's square at each press and the patch's points (a touch without a
            # press, such as the last one may be, only clears them).
            self.assertTrue(self.patches, "no /probe_sim/patch markers")
            presses = [p for p in self.patches if any(m.type == Marker.POINTS for m in p.markers)]
            self.assertTrue(presses, "no /probe_sim/patch message showed a press")
            for press in presses:
                self.assertIn(Marker.CUBE, [m.type for m in press.markers])
            self.assertGreater(max(len(m.points) for p in presses for m in p.markers if m.type == Marker.POINTS), 1)
        # Every touch went along a path planned on the collision map, and the probe met nothing
        # of the true scene on its way there or back.
        for h in probed:
            self.assertGreater(h["approach_ms"], 0.0, h)
        self.assertEqual(report["approach_collisions"], 0)
        self.assertEqual(report["retreat_collisions"], 0)
        self.assertIsNotNone(report["approach_plan_ms_median"])
        # Each touch that found the surface says how far from its target (the model's measured
        # error there), and the run the median of the last ones: within the 12 cm sphere's size.
        errors = [h["target_error_m"] for h in probed if h["contacts"] > 0]
        self.assertTrue(errors and all(e is not None and 0.0 <= e < 0.12 for e in errors), errors)
        self.assertIsNotNone(report["recent_target_error_m"])
        if rospy.get_param("~use_arm", False):
            # The planned approach for the left arm, as a robot driver gets it: its seven joints,
            # from the rest to the approach pose, in time order.
            self.assertTrue(self.trajectories, "no approach trajectory was published")
            trajectory = self.trajectories[-1]
            self.assertEqual(trajectory.joint_names, ["left_arm_a%d_joint" % j for j in range(1, 8)])
            self.assertGreaterEqual(len(trajectory.points), 2)
            times = [p.time_from_start.to_sec() for p in trajectory.points]
            self.assertEqual(times, sorted(times))
            self.assertGreater(times[-1], 0.0)
            for point in trajectory.points:
                self.assertEqual(len(point.positions), 7)
        # After the simulated actions the largest variance on the predicted surface has dropped.
        initial = report["initial"]["sampled_max_variance"]
        last = report["history"][-1]["sampled_max_variance"]
        self.assertIsNotNone(initial)
        self.assertIsNotNone(last)
        self.assertEqual(report["actions"], 5, report["stop_reason"])
        self.assertLess(last, initial)
        metrics = report["final_metrics"]
        self.assertIsNotNone(metrics, "the simulator's ground truth should give shape metrics")
        # The position sd measured on the truth, as the bench's runs.csv has it.
        self.assertTrue(0.0 <= metrics["coverage_2sd"] <= 1.0, metrics)
        self.assertGreater(metrics["sharpness"], 0.0, metrics)
        # The curve: the initial model and every action, each with its touches and contacts; with
        # the simulator's truth the measured ones (metrics_every 1, some skipped while one runs)
        # carry their RMSEs and F@5mm, the initial model's always.
        curve = report["curve"]
        self.assertEqual([p["touches"] for p in curve], list(range(report["actions"] + 1)))
        self.assertEqual([p["contacts_total"] for p in curve[1:]], [h["contacts_total"] for h in report["history"]])
        measured = [p for p in curve if p["fscore_5mm"] is not None]
        self.assertIs(measured[0], curve[0])
        for p in measured:
            self.assertTrue(0.0 <= p["fscore_5mm"] <= 1.0 and p["rmse_gt_to_pred_m"] is not None, p)
        # A 12 cm sphere seen from one side: the predicted shape is within a few centimetres.
        for key in ("rmse_pred_to_gt_m", "rmse_gt_to_pred_m"):
            self.assertTrue(0.0 <= metrics[key] < 0.05, (key, metrics[key]))
        for name in ("surface.ply", "truth.ply", "collision_map.bt", "exploration.png"):
            path = os.path.join(results, name)
            self.assertTrue(os.path.exists(path) and os.path.getsize(path) > 0, path)
        surface, properties = read_ply(os.path.join(results, "surface.ply"))
        self.assertEqual(properties, ["x", "y", "z", "variance", "position_sd_m"])
        self.assertTrue(all(math.isfinite(v[4]) and v[4] > 0.0 for v in surface))
        self.check_contacts(report, os.path.join(results, "truth.ply"))
        shutil.rmtree(results, ignore_errors=True)

    def check_contacts(self, report, truth_path):
        # Each action's accepted contacts, as many as it counts, on the simulated 12 cm sphere
        # (truth.ply: its centre and radius) within the probe's noise.
        truth, _ = read_ply(truth_path)
        centre = [sum(v[k] for v in truth) / len(truth) for k in range(3)]
        radius = sum(math.dist(v[:3], centre) for v in truth) / len(truth)
        self.assertAlmostEqual(radius, 0.06, delta=0.002)
        for h in report["history"]:
            self.assertEqual(len(h["contact_points"]), h["contacts"], h)
        points = [p for h in report["history"] for p in h["contact_points"]]
        self.assertEqual(len(points), report["contacts"])
        for p in points:
            self.assertLess(abs(math.dist(p, centre) - radius), 0.003, p)


if __name__ == "__main__":
    rospy.init_node("test_sim_exploration")
    rostest.rosrun("probe_sim_ros", "sim_exploration_test", SimExplorationTest)
