#!/usr/bin/env python3
"""Checks of urdf/vito.urdf: check_urdf, joint set and limits, forward kinematics.

The expected numbers below are written out by hand from the KUKA LWR 4+ data sheet and the
probe drawing (they are NOT imported from scripts/generate_urdf.py), so the forward
kinematics computed here from the parsed URDF is checked against an independent truth.

Runs under nose (catkin_add_nosetests) and also standalone: python3 test/test_urdf.py
"""

import importlib.util
import math
import os
import re
import shutil
import subprocess
import unittest
import xml.etree.ElementTree as ET

import numpy as np
import yaml

PKG_DIR = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
URDF_PATH = os.path.join(PKG_DIR, "urdf", "vito.urdf")
GENERATOR_PATH = os.path.join(PKG_DIR, "scripts", "generate_urdf.py")
READY_POSE_PATH = os.path.join(PKG_DIR, "config", "ready_pose.yaml")

# KUKA LWR 4+ geometry (data sheet)
BASE_TO_SHOULDER = 0.3105
SHOULDER_TO_ELBOW = 0.4
ELBOW_TO_WRIST = 0.39
WRIST_TO_FLANGE = 0.078
ARM_LENGTH = BASE_TO_SHOULDER + SHOULDER_TO_ELBOW + ELBOW_TO_WRIST + WRIST_TO_FLANGE  # 1.1785
LIMITS_DEG = [170, 120, 170, 120, 170, 120, 170]

# Probe: Nano17 height 14.5 mm + shaft 60 mm; probe_tip = centre of the r = 20 mm tip.
PROBE_TIP_OFFSET = 0.0145 + 0.060
PROBE_TIP_RADIUS = 0.02

CAMERA_TARGET = np.array([0.7, 0.0, 0.1])

PURE_FRAMES = {"world", "camera_optical_frame"}


def rpy_matrix(r, p, y):
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def axis_angle(axis, angle):
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


def floats(text, default):
    return [float(v) for v in text.split()] if text else list(default)


class Model(object):
    """Minimal URDF kinematic tree parsed with xml.etree."""

    def __init__(self, path):
        self.root = ET.parse(path).getroot()
        self.links = {l.get("name"): l for l in self.root.findall("link")}
        self.joints = {}
        self.parent_joint = {}
        for j in self.root.findall("joint"):
            o = j.find("origin")
            xyz = floats(o.get("xyz") if o is not None else None, (0, 0, 0))
            rpy = floats(o.get("rpy") if o is not None else None, (0, 0, 0))
            ax = j.find("axis")
            info = {
                "name": j.get("name"),
                "type": j.get("type"),
                "parent": j.find("parent").get("link"),
                "child": j.find("child").get("link"),
                "T": self.homogeneous(rpy_matrix(*rpy), xyz),
                "axis": floats(ax.get("xyz") if ax is not None else None, (1, 0, 0)),
                "limit": j.find("limit"),
            }
            self.joints[info["name"]] = info
            self.parent_joint[info["child"]] = info

    @staticmethod
    def homogeneous(rot, xyz):
        t = np.eye(4)
        t[:3, :3] = rot
        t[:3, 3] = xyz
        return t

    def chain(self, link):
        """Joints from the root to link."""
        out = []
        while link in self.parent_joint:
            j = self.parent_joint[link]
            out.append(j)
            link = j["parent"]
        return list(reversed(out))

    def pose(self, link, q=None):
        """Pose of link in the root frame for the joint positions q (dict, default 0)."""
        q = q or {}
        t = np.eye(4)
        for j in self.chain(link):
            t = t @ j["T"]
            if j["type"] in ("revolute", "continuous"):
                t = t @ self.homogeneous(axis_angle(j["axis"], q.get(j["name"], 0.0)), (0, 0, 0))
        return t

    def relative(self, base, link, q=None):
        return np.linalg.inv(self.pose(base, q)) @ self.pose(link, q)


class TestVitoUrdf(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.model = Model(URDF_PATH)

    def test_check_urdf(self):
        exe = shutil.which("check_urdf")
        self.assertIsNotNone(exe, "check_urdf not found (Debian package liburdfdom-tools)")
        res = subprocess.run([exe, URDF_PATH], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             universal_newlines=True, timeout=30)
        self.assertEqual(res.returncode, 0, res.stdout)
        self.assertIn("Successfully Parsed XML", res.stdout)
        self.assertIn("root Link: world", res.stdout)

    def test_generated_file_is_up_to_date(self):
        spec = importlib.util.spec_from_file_location("generate_urdf", GENERATOR_PATH)
        gen = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(gen)
        with open(URDF_PATH) as f:
            self.assertEqual(f.read(), gen.build(),
                             "urdf/vito.urdf differs from scripts/generate_urdf.py output")

    def test_single_tree_rooted_at_world(self):
        children = set(self.model.parent_joint)
        roots = set(self.model.links) - children
        self.assertEqual(roots, {"world"})
        for name in ("table", "torso_link", "head_link", "camera_link", "camera_optical_frame",
                     "left_arm_base_link", "right_arm_base_link", "left_arm_flange_link",
                     "right_arm_flange_link", "probe_tip", "right_hand_palm_link",
                     "left_probe_nano17_link"):
            self.assertIn(name, self.model.links)

    def test_exactly_14_arm_joints_with_lwr_limits(self):
        movable = {n: j for n, j in self.model.joints.items() if j["type"] != "fixed"}
        expected = ["%s_arm_a%d_joint" % (s, i) for s in ("left", "right") for i in range(1, 8)]
        self.assertEqual(sorted(movable), sorted(expected))
        for name, j in movable.items():
            self.assertEqual(j["type"], "revolute", name)
            idx = int(re.match(r"^(left|right)_arm_a([1-7])_joint$", name).group(2)) - 1
            lim = math.radians(LIMITS_DEG[idx])
            limit = j["limit"]
            self.assertIsNotNone(limit, name)
            self.assertAlmostEqual(float(limit.get("lower")), -lim, places=6, msg=name)
            self.assertAlmostEqual(float(limit.get("upper")), lim, places=6, msg=name)
            self.assertGreater(float(limit.get("velocity")), 0.5, name)
            self.assertLess(float(limit.get("velocity")), 4.0, name)
            self.assertGreater(float(limit.get("effort")), 10.0, name)
            self.assertLessEqual(float(limit.get("effort")), 200.0, name)

    def test_every_physical_link_has_visual_collision_inertial(self):
        for name, link in self.model.links.items():
            if name in PURE_FRAMES:
                continue
            self.assertIsNotNone(link.find("visual"), name)
            self.assertIsNotNone(link.find("collision"), name)
            inertial = link.find("inertial")
            self.assertIsNotNone(inertial, name)
            self.assertGreater(float(inertial.find("mass").get("value")), 0.0, name)

    def check_straight_arm(self, side):
        base = "%s_arm_base_link" % side
        t = self.model.relative(base, "%s_arm_flange_link" % side)
        # straight arm along the base z axis, flange frame parallel to the base frame
        np.testing.assert_allclose(t[:3, 3], [0, 0, ARM_LENGTH], atol=1e-9)
        np.testing.assert_allclose(t[:3, :3], np.eye(3), atol=1e-9)
        self.assertAlmostEqual(np.linalg.norm(t[:3, 3]), 1.1785, places=9)

    def test_fk_zero_left_arm(self):
        self.check_straight_arm("left")

    def test_fk_zero_right_arm(self):
        self.check_straight_arm("right")

    def test_fk_bent_arm(self):
        """A2 = 90 deg: everything past the shoulder is perpendicular to the base axis;
        A4 = 90 deg: everything past the elbow is perpendicular to the upper arm."""
        base, flange = "left_arm_base_link", "left_arm_flange_link"
        p = self.model.relative(base, flange, {"left_arm_a2_joint": math.pi / 2})[:3, 3]
        self.assertAlmostEqual(p[2], BASE_TO_SHOULDER, places=9)
        self.assertAlmostEqual(np.linalg.norm(p[:2]), ARM_LENGTH - BASE_TO_SHOULDER, places=9)
        p = self.model.relative(base, flange, {"left_arm_a4_joint": math.pi / 2})[:3, 3]
        self.assertAlmostEqual(p[2], BASE_TO_SHOULDER + SHOULDER_TO_ELBOW, places=9)
        self.assertAlmostEqual(np.linalg.norm(p[:2]), ELBOW_TO_WRIST + WRIST_TO_FLANGE, places=9)
        # A6 = 90 deg: only the flange offset turns away from the axis
        p = self.model.relative(base, flange, {"left_arm_a6_joint": math.pi / 2})[:3, 3]
        self.assertAlmostEqual(p[2], ARM_LENGTH - WRIST_TO_FLANGE, places=9)
        self.assertAlmostEqual(np.linalg.norm(p[:2]), WRIST_TO_FLANGE, places=9)
        # roll joints do not move the flange origin of a straight arm
        q = {"left_arm_a%d_joint" % i: 1.0 for i in (1, 3, 5, 7)}
        p = self.model.relative(base, flange, q)[:3, 3]
        np.testing.assert_allclose(p, [0, 0, ARM_LENGTH], atol=1e-9)

    def test_probe_tip_offset(self):
        t = self.model.relative("left_arm_flange_link", "probe_tip")
        np.testing.assert_allclose(t[:3, 3], [0, 0, PROBE_TIP_OFFSET], atol=1e-9)
        # z of probe_tip = approach direction = flange z
        np.testing.assert_allclose(t[:3, :3], np.eye(3), atol=1e-9)
        t = self.model.relative("left_arm_base_link", "probe_tip")
        np.testing.assert_allclose(t[:3, 3], [0, 0, ARM_LENGTH + PROBE_TIP_OFFSET], atol=1e-9)
        # collision sphere of the tip: radius 0.02 centred on probe_tip
        spheres = []
        for c in self.model.links["probe_tip"].findall("collision"):
            s = c.find("geometry/sphere")
            if s is not None:
                o = c.find("origin")
                spheres.append((float(s.get("radius")), floats(o.get("xyz") if o is not None else None, (0, 0, 0))))
        self.assertEqual(len(spheres), 1)
        self.assertAlmostEqual(spheres[0][0], PROBE_TIP_RADIUS, places=9)
        np.testing.assert_allclose(spheres[0][1], [0, 0, 0], atol=1e-12)

    def test_nano17_dimensions(self):
        cyl = self.model.links["left_probe_nano17_link"].find("collision/geometry/cylinder")
        self.assertAlmostEqual(float(cyl.get("radius")) * 2, 0.017, places=9)
        self.assertAlmostEqual(float(cyl.get("length")), 0.0145, places=9)

    def test_arm_bases_and_table(self):
        for side, sign in (("left", 1), ("right", -1)):
            p = self.model.pose("%s_arm_base_link" % side)[:3, 3]
            self.assertLess(abs(p[0]), 0.15)
            self.assertAlmostEqual(p[1], sign * 0.25, places=6)
            self.assertTrue(0.3 <= p[2] <= 0.5)
            # the object (x = 0.6..0.8, y = 0, z = 0..0.2) is within reach of the shoulder
            shoulder = self.model.pose("%s_arm_2_link" % side)[:3, 3]
            for target in ([0.6, 0, 0.05], [0.8, 0, 0.05], [0.7, 0, 0.2]):
                dist = np.linalg.norm(np.array(target) - shoulder)
                self.assertLess(dist, SHOULDER_TO_ELBOW + ELBOW_TO_WRIST + WRIST_TO_FLANGE, target)
        table = self.model.pose("table")
        self.assertAlmostEqual(table[2, 3], 0.0, places=9)
        self.assertTrue(0.5 < table[0, 3] < 1.0)
        top = self.model.links["table"].find("collision")
        size = floats(top.find("geometry/box").get("size"), ())
        z = floats(top.find("origin").get("xyz"), ())[2]
        self.assertAlmostEqual(z + size[2] / 2.0, 0.0, places=9)   # top surface at z = 0

    def test_camera_optical_frame_looks_at_table(self):
        t = self.model.pose("camera_optical_frame")
        z = t[:3, 2]
        to_target = CAMERA_TARGET - t[:3, 3]
        to_target /= np.linalg.norm(to_target)
        self.assertGreater(float(z @ to_target), math.cos(math.radians(1.0)))
        # x right (towards -y for a camera facing +x), y down
        self.assertLess(t[1, 0], -0.99)
        self.assertLess(t[2, 1], 0.0)

    def test_ready_pose(self):
        """config/ready_pose.yaml: within limits, probe and hand above the object area."""
        with open(READY_POSE_PATH) as f:
            q = yaml.safe_load(f)["zeros"]
        movable = {n for n, j in self.model.joints.items() if j["type"] != "fixed"}
        self.assertEqual(set(q), movable)
        for name, value in q.items():
            limit = self.model.joints[name]["limit"]
            self.assertTrue(float(limit.get("lower")) < value < float(limit.get("upper")), name)
        tip = self.model.pose("probe_tip", q)
        self.assertTrue(0.6 <= tip[0, 3] <= 0.8 and abs(tip[1, 3]) < 0.2, tip[:3, 3])
        self.assertTrue(0.2 < tip[2, 3] < 0.4, tip[:3, 3])
        self.assertLess(tip[2, 2], -0.99)   # probe approach direction points down
        palm = self.model.pose("right_hand_palm_link", q)
        self.assertTrue(0.6 <= palm[0, 3] <= 0.9 and palm[2, 3] > 0.15, palm[:3, 3])
        # no arm link origin below the table top
        for side in ("left", "right"):
            for i in range(1, 8):
                self.assertGreater(self.model.pose("%s_arm_%d_link" % (side, i), q)[2, 3], 0.05)


if __name__ == "__main__":
    unittest.main()
