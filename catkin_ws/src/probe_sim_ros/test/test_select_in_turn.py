#!/usr/bin/env python3
"""Explores the scene's sphere, selects the cylinder beside it, explores that (select_in_turn.test)."""
import json
import math
import os
import subprocess
import unittest

import rospy
import rostest
from geometry_msgs.msg import PointStamped
from gpatlas_msgs.srv import SelectObject

SPHERE_XY = (0.7, 0.0)    # simulation.yaml's object_position_xy_m
CYLINDER_XY = (0.7, 0.2)  # the neighbour's offset in the launch file
EXPLORATION_TIMEOUT_S = 270.0

# The exploration node's services and topics, as sim_exploration.launch remaps them.
REMAPS = {
    "capture": "/probe_sim/capture",
    "probe": "/probe_sim/probe",
    "next_touch": "/gpatlas/atlas_planner/next_touch",
    "add_observations": "/gpatlas/gp_model/add_observations",
    "save_map": "/gpatlas/collision_map/save_map",
    "plan_approach": "/gpatlas/collision_map/plan_approach",
    "collision_map_status": "/gpatlas/collision_map/status",
    "training_set": "/gpatlas/gp_model/training_set",
    "camera_points": "/gpatlas/camera_points",
}


def horizontal_distance(point, xy):
    return math.hypot(point[0] - xy[0], point[1] - xy[1])


class SelectInTurnTest(unittest.TestCase):
    def explore(self, name):
        """Runs one exploration node to its end and returns its report."""
        remaps = dict(REMAPS, ground_truth="/probe_sim/ground_truth")
        command = ["rosrun", "gpatlas_ros", "exploration_node", "__name:=" + name, "__ns:=/gpatlas"]
        command += ["%s:=%s" % item for item in remaps.items()]
        node = subprocess.Popen(command)
        try:
            code = node.wait(timeout=EXPLORATION_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            node.kill()
            self.fail("%s did not end within %.0f s" % (name, EXPLORATION_TIMEOUT_S))
        report_path = os.path.join(rospy.get_param("~results_dir"), name.split("_")[1], "report.json")
        self.assertTrue(os.path.exists(report_path), "%s exited with %d and no report" % (name, code))
        with open(report_path) as f:
            return json.load(f)

    def assert_converged_on(self, report, own_xy, other_xy, what):
        self.assertTrue(report["converged"], "%s: %s" % (what, report["stop_reason"]))
        contacts = [p for action in report["history"] for p in action["contact_points"]]
        self.assertGreater(len(contacts), 0, what + ": no contact")
        for p in contacts:
            self.assertLess(horizontal_distance(p, own_xy), horizontal_distance(p, other_xy),
                            "%s: a contact at %s is on the other object" % (what, p))

    def test_each_object_in_turn(self):
        rospy.wait_for_service("/gpatlas/segmentation/select_object", timeout=120.0)
        select = rospy.ServiceProxy("/gpatlas/segmentation/select_object", SelectObject)
        rospy.wait_for_service("/probe_sim/select_object", timeout=120.0)
        simulation_select = rospy.ServiceProxy("/probe_sim/select_object", SelectObject)

        # The simulation refuses a point it cannot place or that is near no object, and keeps its object.
        for frame, xyz in (("world", (float("nan"), 0.0, 0.05)), ("camera_optical_frame", (0.7, 0.0, 0.05)),
                           ("world", (0.7, -0.3, 0.05))):
            bad = PointStamped()
            bad.header.frame_id = frame
            bad.point.x, bad.point.y, bad.point.z = xyz
            answer = simulation_select(bad)
            self.assertFalse(answer.success, "%s %s: %s" % (frame, xyz, answer.message))
            self.assertFalse(answer.changed)

        # The start-up choice (object_hint): the sphere.
        first = self.explore("explore_first")
        self.assert_converged_on(first, SPHERE_XY, CYLINDER_XY, "the sphere")

        # 1 cm above the cylinder's top: it becomes the explored object, the sphere an obstacle.
        point = PointStamped()
        point.header.frame_id = "world"
        point.point.x, point.point.y, point.point.z = CYLINDER_XY[0], CYLINDER_XY[1], 0.11
        answer = select(point)
        self.assertTrue(answer.success, answer.message)
        self.assertTrue(answer.changed, answer.message)
        # The simulation is told too: its probe reports the cylinder's contacts, its ground truth is the cylinder.
        answer = simulation_select(point)
        self.assertTrue(answer.success, answer.message)
        self.assertTrue(answer.changed, answer.message)

        second = self.explore("explore_second")
        self.assert_converged_on(second, CYLINDER_XY, SPHERE_XY, "the cylinder")
        # Measured against the cylinder, the simulation's object now: the shape is known.
        self.assertGreater(second["final_metrics"]["fscore_5mm"], 0.9)
        rospy.loginfo("select_in_turn: the sphere in %d actions, the cylinder in %d", first["actions"],
                      second["actions"])


if __name__ == "__main__":
    rospy.init_node("select_in_turn_test")
    rostest.rosrun("probe_sim_ros", "select_in_turn_test", SelectInTurnTest)
