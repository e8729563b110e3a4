#!/usr/bin/env python3
"""Generate urdf/vito.urdf (plain URDF, no xacro) for the Vito bimanual robot.

Only the Python standard library is used. Run from anywhere:

    python3 scripts/generate_urdf.py            # writes ../urdf/vito.urdf
    python3 scripts/generate_urdf.py --stdout   # prints the URDF instead

The generated file is committed; test/test_urdf.py checks that it is up to date.

Model summary (all lengths in metres, angles in radians):
  * `world` root frame; the table top is the plane z = 0, the robot faces +x.
  * `torso_link` fixed to `world` (pedestal column, shoulder bar, arm mounts).
  * two KUKA LWR 4+ arms with the real kinematics: base->A2 axis 0.3105,
    A2->A4 0.4, A4->A6 0.39, A6->flange 0.078 (A7 on the A6 centre).
  * right arm: Pisa/IIT SoftHand approximated by a palm box and five finger boxes.
  * left arm: exploratory probe = ATI Nano17 (d 17 mm, h 14.5 mm) + shaft + tip
    sphere of radius 0.02; frame `probe_tip` = centre of that sphere.
  * `table` and a head camera (`head_link`, `camera_link`, `camera_optical_frame`).
"""

import argparse
import math
import os
import sys

# --------------------------------------------------------------------------------------
# Parameters (single source of truth; the README and the test quote these values)
# --------------------------------------------------------------------------------------
DEG = math.pi / 180.0

# KUKA LWR 4+ kinematics: offsets along the arm axis (z of the previous link frame).
LWR_BASE_TO_A1 = 0.1105   # base mounting surface -> A1 housing top (A1 axis is z)
LWR_A1_TO_A2 = 0.2        # A1 -> A2: base-to-shoulder total 0.3105
LWR_A2_TO_A3 = 0.2
LWR_A3_TO_A4 = 0.2        # A2 -> A4 (shoulder-to-elbow) 0.4
LWR_A4_TO_A5 = 0.2
LWR_A5_TO_A6 = 0.19       # A4 -> A6 (elbow-to-wrist) 0.39
LWR_A6_TO_A7 = 0.0        # A7 axis passes through the wrist centre
LWR_A7_TO_FLANGE = 0.078  # wrist centre -> flange surface

# (axis, position limit [rad], velocity limit [rad/s], effort limit [Nm], link mass [kg])
# Position limits: +-170, +-120, +-170, +-120, +-170, +-120, +-170 deg.
# Velocity limits: KUKA LWR 4+ data sheet (110, 110, 128, 128, 204, 184, 184 deg/s).
# Effort limits:   KUKA LWR 4+ data sheet (176, 176, 100, 100, 100, 38, 38 Nm).
LWR_JOINTS = [
    ((0, 0, 1), 170 * DEG, 110 * DEG, 176.0, 2.7),
    ((0, -1, 0), 120 * DEG, 110 * DEG, 176.0, 2.7),
    ((0, 0, 1), 170 * DEG, 128 * DEG, 100.0, 2.5),
    ((0, 1, 0), 120 * DEG, 128 * DEG, 100.0, 2.5),
    ((0, 0, 1), 170 * DEG, 204 * DEG, 100.0, 1.8),
    ((0, -1, 0), 120 * DEG, 184 * DEG, 38.0, 1.2),
    ((0, 0, 1), 170 * DEG, 184 * DEG, 38.0, 0.3),
]
LWR_OFFSETS = [LWR_BASE_TO_A1, LWR_A1_TO_A2, LWR_A2_TO_A3, LWR_A3_TO_A4,
               LWR_A4_TO_A5, LWR_A5_TO_A6, LWR_A6_TO_A7]
LWR_BASE_MASS = 2.0
LWR_FLANGE_MASS = 0.05

# Arm mounting on the torso (pose of <side>_arm_base_link in world == torso frame).
# The arm axis (base z) points forward, 20 deg above horizontal and 15 deg outwards.
ARM_MOUNT_XYZ = {"left": (0.0, 0.25, 0.4), "right": (0.0, -0.25, 0.4)}
ARM_MOUNT_PITCH = 70 * DEG            # rotation about y: 90 deg would be horizontal
ARM_MOUNT_YAW = {"left": 15 * DEG, "right": -15 * DEG}

# Probe (left arm): ATI Nano17 on the flange, shaft, hemispherical tip.
NANO17_RADIUS = 0.0085
NANO17_HEIGHT = 0.0145
NANO17_MASS = 0.00907
PROBE_SHAFT_RADIUS = 0.005
PROBE_SHAFT_LENGTH = 0.06
PROBE_SHAFT_MASS = 0.013
PROBE_TIP_RADIUS = 0.02
PROBE_TIP_MASS = 0.02
# probe_tip (centre of the tip sphere / hemisphere) relative to the flange, along flange z:
PROBE_TIP_OFFSET = NANO17_HEIGHT + PROBE_SHAFT_LENGTH   # 0.0745 m

# SoftHand (right arm)
HAND_ADAPTER_RADIUS = 0.035
HAND_ADAPTER_LENGTH = 0.04
HAND_PALM_SIZE = (0.035, 0.09, 0.11)    # x: palm normal, y: across, z: along the hand
HAND_PALM_MASS = 0.35
HAND_PALM_OFFSET = HAND_ADAPTER_LENGTH + HAND_PALM_SIZE[2] / 2.0   # 0.095 m

# Table: top surface centre of the `table` frame at (0.75, 0, 0) in world.
TABLE_XYZ = (0.75, 0.0, 0.0)
TABLE_SIZE = (0.8, 1.2, 0.04)
TABLE_HEIGHT = 0.75        # floor at z = -0.75
TABLE_MASS = 20.0

# Head and camera
HEAD_XYZ = (-0.2, 0.0, 0.6)           # head_link in torso frame
CAMERA_IN_HEAD = (0.09, 0.0, 0.15)    # camera_link in head_link frame
CAMERA_TARGET = (0.7, 0.0, 0.1)       # point on the table the camera looks at (world)


# --------------------------------------------------------------------------------------
# Small XML writer
# --------------------------------------------------------------------------------------
def fmt(v):
    """Format a float compactly and reproducibly."""
    if abs(v) < 5e-10:
        v = 0.0
    s = "%.9f" % v
    s = s.rstrip("0").rstrip(".")
    if s in ("-0", ""):
        s = "0"
    return s


def vec(values):
    return " ".join(fmt(v) for v in values)


def origin(xyz=(0, 0, 0), rpy=(0, 0, 0)):
    return '<origin xyz="%s" rpy="%s"/>' % (vec(xyz), vec(rpy))


def box(size):
    return '<box size="%s"/>' % vec(size)


def cylinder(radius, length):
    return '<cylinder radius="%s" length="%s"/>' % (fmt(radius), fmt(length))


def sphere(radius):
    return '<sphere radius="%s"/>' % fmt(radius)


def inertia_box(m, size):
    x, y, z = size
    return (m * (y * y + z * z) / 12.0, m * (x * x + z * z) / 12.0, m * (x * x + y * y) / 12.0)


def inertia_cylinder(m, r, length):
    """Solid cylinder with its axis along z."""
    i = m * (3 * r * r + length * length) / 12.0
    return (i, i, m * r * r / 2.0)


def inertia_sphere(m, r):
    i = 2.0 * m * r * r / 5.0
    return (i, i, i)


class Shape(object):
    def __init__(self, geometry, xyz=(0, 0, 0), rpy=(0, 0, 0), material=None):
        self.geometry = geometry
        self.xyz = xyz
        self.rpy = rpy
        self.material = material


class Urdf(object):
    def __init__(self, name):
        self.name = name
        self.lines = []

    def comment(self, text):
        self.lines.append("")
        for line in text.strip("\n").split("\n"):
            self.lines.append("  <!-- %s -->" % line.strip())

    def material(self, name, rgba):
        self.lines.append('  <material name="%s"><color rgba="%s"/></material>' % (name, vec(rgba)))

    def link(self, name, visuals=(), collisions=None, mass=None, com=(0, 0, 0), inertia=None):
        """A link. collisions defaults to the visuals (without materials)."""
        if collisions is None:
            collisions = visuals
        if not visuals and mass is None:
            self.lines.append('  <link name="%s"/>' % name)
            return
        out = ['  <link name="%s">' % name]
        for s in visuals:
            out.append("    <visual>")
            out.append("      " + origin(s.xyz, s.rpy))
            out.append("      <geometry>%s</geometry>" % s.geometry)
            if s.material:
                out.append('      <material name="%s"/>' % s.material)
            out.append("    </visual>")
        for s in collisions:
            out.append("    <collision>")
            out.append("      " + origin(s.xyz, s.rpy))
            out.append("      <geometry>%s</geometry>" % s.geometry)
            out.append("    </collision>")
        if mass is not None:
            ixx, iyy, izz = inertia
            out.append("    <inertial>")
            out.append("      " + origin(com))
            out.append('      <mass value="%s"/>' % fmt(mass))
            out.append('      <inertia ixx="%s" ixy="0" ixz="0" iyy="%s" iyz="0" izz="%s"/>'
                       % (fmt(ixx), fmt(iyy), fmt(izz)))
            out.append("    </inertial>")
        out.append("  </link>")
        self.lines.extend(out)

    def fixed(self, name, parent, child, xyz=(0, 0, 0), rpy=(0, 0, 0)):
        self.lines.append('  <joint name="%s" type="fixed">' % name)
        self.lines.append('    <parent link="%s"/>' % parent)
        self.lines.append('    <child link="%s"/>' % child)
        self.lines.append("    " + origin(xyz, rpy))
        self.lines.append("  </joint>")

    def revolute(self, name, parent, child, xyz, axis, lower, upper, velocity, effort):
        self.lines.append('  <joint name="%s" type="revolute">' % name)
        self.lines.append('    <parent link="%s"/>' % parent)
        self.lines.append('    <child link="%s"/>' % child)
        self.lines.append("    " + origin(xyz))
        self.lines.append('    <axis xyz="%s"/>' % vec(axis))
        self.lines.append('    <limit lower="%s" upper="%s" velocity="%s" effort="%s"/>'
                          % (fmt(lower), fmt(upper), fmt(velocity), fmt(effort)))
        self.lines.append('    <dynamics damping="0.5" friction="0.0"/>')
        self.lines.append("  </joint>")

    def text(self):
        head = ['<?xml version="1.0"?>',
                "<!-- GENERATED by scripts/generate_urdf.py - edit the script, not this file. -->",
                '<robot name="%s">' % self.name]
        return "\n".join(head + self.lines + ["</robot>", ""])


# --------------------------------------------------------------------------------------
# Robot parts
# --------------------------------------------------------------------------------------
def add_materials(u):
    u.comment("Materials")
    u.material("vito_grey", (0.55, 0.57, 0.6, 1.0))
    u.material("vito_dark", (0.2, 0.2, 0.22, 1.0))
    u.material("kuka_orange", (1.0, 0.45, 0.0, 1.0))
    u.material("kuka_silver", (0.78, 0.78, 0.8, 1.0))
    u.material("softhand_black", (0.1, 0.1, 0.1, 1.0))
    u.material("softhand_blue", (0.15, 0.35, 0.75, 1.0))
    u.material("probe_steel", (0.7, 0.72, 0.75, 1.0))
    u.material("probe_tip_red", (0.85, 0.1, 0.1, 1.0))
    u.material("table_wood", (0.72, 0.55, 0.36, 1.0))
    u.material("camera_black", (0.05, 0.05, 0.05, 1.0))


def add_world_torso_table(u):
    u.comment("""
    world: root frame. The table top is the plane z = 0, the robot faces +x.
    world has no geometry and no inertia on purpose (KDL does not support an inertial root).
    """)
    u.link("world")

    column = Shape(box((0.25, 0.3, 1.2)), (-0.25, 0.0, -0.15), material="vito_grey")
    bar = Shape(box((0.24, 0.5, 0.14)), (-0.14, 0.0, 0.4), material="vito_grey")
    foot = Shape(box((0.5, 0.5, 0.05)), (-0.25, 0.0, -0.725), material="vito_dark")
    shapes = [column, bar, foot]
    for side in ("left", "right"):
        xyz, rpy, zaxis = arm_mount(side)
        centre = tuple(p - 0.03 * a for p, a in zip(xyz, zaxis))
        shapes.append(Shape(box((0.16, 0.16, 0.06)), centre, rpy, material="vito_dark"))
    u.comment("Torso: pedestal column (floor at z = -0.75), shoulder bar, two tilted arm mounts")
    u.link("torso_link", shapes, mass=40.0, com=(-0.22, 0.0, -0.05),
           inertia=inertia_box(40.0, (0.3, 0.5, 1.2)))
    u.fixed("world_to_torso_joint", "world", "torso_link")

    u.comment("Table: frame `table` is the centre of the top surface (z = 0 in world)")
    tx, ty, tz = TABLE_SIZE
    top = Shape(box(TABLE_SIZE), (0, 0, -tz / 2.0), material="table_wood")
    leg_len = TABLE_HEIGHT - tz
    legs = [Shape(cylinder(0.025, leg_len), (sx * (tx / 2 - 0.05), sy * (ty / 2 - 0.05),
                                             -tz - leg_len / 2.0), material="table_wood")
            for sx in (1, -1) for sy in (1, -1)]
    u.link("table", [top] + legs, mass=TABLE_MASS, com=(0, 0, -0.1),
           inertia=inertia_box(TABLE_MASS, (tx, ty, 0.3)))
    u.fixed("world_to_table_joint", "world", "table", TABLE_XYZ)


def arm_mount(side):
    """Return (xyz, rpy, z axis in world) of <side>_arm_base_link."""
    yaw = ARM_MOUNT_YAW[side]
    pitch = ARM_MOUNT_PITCH
    # URDF rpy = fixed-axis roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll); z axis:
    zaxis = (math.sin(pitch) * math.cos(yaw), math.sin(pitch) * math.sin(yaw), math.cos(pitch))
    return ARM_MOUNT_XYZ[side], (0.0, pitch, yaw), zaxis


def add_lwr_arm(u, side):
    p = "%s_arm_" % side
    xyz, rpy, _ = arm_mount(side)
    u.comment("%s KUKA LWR 4+ arm; %sbase_link is the base mounting surface, z along the arm"
              % (side.capitalize(), p))
    base_len = LWR_BASE_TO_A1
    u.link(p + "base_link",
           [Shape(cylinder(0.07, base_len), (0, 0, base_len / 2), material="kuka_silver")],
           mass=LWR_BASE_MASS, com=(0, 0, base_len / 2),
           inertia=inertia_cylinder(LWR_BASE_MASS, 0.07, base_len))
    u.fixed(p + "mount_joint", "torso_link", p + "base_link", xyz, rpy)

    parent = p + "base_link"
    for i, (axis, lim, vel, eff, mass) in enumerate(LWR_JOINTS):
        n = i + 1
        link = "%s%d_link" % (p, n)
        # length of this link = offset to the next joint (or to the flange for link 7)
        length = LWR_OFFSETS[i + 1] if i + 1 < len(LWR_OFFSETS) else LWR_A7_TO_FLANGE
        colour = "kuka_orange" if n % 2 == 0 else "kuka_silver"
        shapes = []
        if n == 6:
            # wrist: a ball around the A6/A7 crossing point
            shapes.append(Shape(sphere(0.06), (0, 0, 0), material=colour))
            inertia = inertia_sphere(mass, 0.06)
            com = (0, 0, 0)
        elif n == 7:
            shapes.append(Shape(cylinder(0.04, length - 0.015), (0, 0, (length - 0.015) / 2),
                                material=colour))
            inertia = inertia_cylinder(mass, 0.04, length)
            com = (0, 0, length / 2)
        else:
            radius = 0.06 if n <= 4 else 0.055
            shapes.append(Shape(cylinder(radius, length), (0, 0, length / 2), material=colour))
            # joint housing of the next (pitch) joint
            shapes.append(Shape(sphere(radius + 0.003), (0, 0, length), material=colour))
            inertia = inertia_cylinder(mass, radius, length)
            com = (0, 0, length / 2)
        u.link(link, shapes, mass=mass, com=com, inertia=inertia)
        u.revolute("%sa%d_joint" % (p, n), parent, link, (0, 0, LWR_OFFSETS[i]), axis,
                   -lim, lim, vel, eff)
        parent = link

    u.comment("%s flange: frame on the flange surface, z out of the arm" % side.capitalize())
    u.link(p + "flange_link",
           [Shape(cylinder(0.031, 0.015), (0, 0, -0.0075), material="vito_dark")],
           mass=LWR_FLANGE_MASS, com=(0, 0, -0.0075),
           inertia=inertia_cylinder(LWR_FLANGE_MASS, 0.031, 0.015))
    u.fixed(p + "flange_joint", parent, p + "flange_link", (0, 0, LWR_A7_TO_FLANGE))


def add_probe(u):
    u.comment("""
    Exploratory probe on the left flange: ATI Nano17 (d 17 mm, h 14.5 mm), shaft, tip.
    probe_tip: centre of the hemispherical tip (radius 0.02), %s m beyond the left flange
    along the flange z axis; z points out of the tool (approach direction). The tip is
    modelled as a full sphere of radius 0.02 (visual and collision).
    """ % fmt(PROBE_TIP_OFFSET))
    u.link("left_probe_nano17_link",
           [Shape(cylinder(NANO17_RADIUS, NANO17_HEIGHT), (0, 0, NANO17_HEIGHT / 2),
                  material="probe_steel")],
           mass=NANO17_MASS, com=(0, 0, NANO17_HEIGHT / 2),
           inertia=inertia_cylinder(NANO17_MASS, NANO17_RADIUS, NANO17_HEIGHT))
    u.fixed("left_probe_nano17_joint", "left_arm_flange_link", "left_probe_nano17_link")
    u.link("left_probe_shaft_link",
           [Shape(cylinder(PROBE_SHAFT_RADIUS, PROBE_SHAFT_LENGTH), (0, 0, PROBE_SHAFT_LENGTH / 2),
                  material="probe_steel")],
           mass=PROBE_SHAFT_MASS, com=(0, 0, PROBE_SHAFT_LENGTH / 2),
           inertia=inertia_cylinder(PROBE_SHAFT_MASS, PROBE_SHAFT_RADIUS, PROBE_SHAFT_LENGTH))
    u.fixed("left_probe_shaft_joint", "left_probe_nano17_link", "left_probe_shaft_link",
            (0, 0, NANO17_HEIGHT))
    u.link("probe_tip", [Shape(sphere(PROBE_TIP_RADIUS), material="probe_tip_red")],
           mass=PROBE_TIP_MASS, inertia=inertia_sphere(PROBE_TIP_MASS, PROBE_TIP_RADIUS))
    u.fixed("probe_tip_joint", "left_probe_shaft_link", "probe_tip", (0, 0, PROBE_SHAFT_LENGTH))


def add_softhand(u):
    u.comment("""
    Pisa/IIT SoftHand on the right flange (simplified: adapter, palm, five finger boxes).
    right_hand_palm_link: centre of the palm, z along the hand (out of the flange),
    x = palm normal (the fingers close towards +x), thumb on the +y side.
    """)
    u.link("right_hand_adapter_link",
           [Shape(cylinder(HAND_ADAPTER_RADIUS, HAND_ADAPTER_LENGTH),
                  (0, 0, HAND_ADAPTER_LENGTH / 2), material="softhand_black")],
           mass=0.1, com=(0, 0, HAND_ADAPTER_LENGTH / 2),
           inertia=inertia_cylinder(0.1, HAND_ADAPTER_RADIUS, HAND_ADAPTER_LENGTH))
    u.fixed("right_hand_adapter_joint", "right_arm_flange_link", "right_hand_adapter_link")
    u.link("right_hand_palm_link",
           [Shape(box(HAND_PALM_SIZE), material="softhand_black")],
           mass=HAND_PALM_MASS, inertia=inertia_box(HAND_PALM_MASS, HAND_PALM_SIZE))
    u.fixed("right_hand_palm_joint", "right_hand_adapter_link", "right_hand_palm_link",
            (0, 0, HAND_PALM_OFFSET - 0.0), (0, 0, 0))
    # fingers: (name, y offset, length), slightly flexed towards +x
    palm_top = HAND_PALM_SIZE[2] / 2.0
    fingers = [("index", 0.0325, 0.085), ("middle", 0.011, 0.09),
               ("ring", -0.011, 0.085), ("little", -0.0325, 0.07)]
    for name, y, length in fingers:
        size = (0.02, 0.019, length)
        link = "right_hand_%s_link" % name
        u.link(link, [Shape(box(size), (0, 0, length / 2), material="softhand_blue")],
               mass=0.03, com=(0, 0, length / 2), inertia=inertia_box(0.03, size))
        u.fixed("right_hand_%s_joint" % name, "right_hand_palm_link", link,
                (0.0, y, palm_top), (0, 0.25, 0))
    size = (0.022, 0.02, 0.065)
    u.link("right_hand_thumb_link", [Shape(box(size), (0, 0, 0.0325), material="softhand_blue")],
           mass=0.03, com=(0, 0, 0.0325), inertia=inertia_box(0.03, size))
    u.fixed("right_hand_thumb_joint", "right_hand_palm_link", "right_hand_thumb_link",
            (0.01, HAND_PALM_SIZE[1] / 2.0, -0.025), (-0.9, 0.3, 0))


def add_head_camera(u):
    cam_world = tuple(h + c for h, c in zip(HEAD_XYZ, CAMERA_IN_HEAD))
    d = [t - c for t, c in zip(CAMERA_TARGET, cam_world)]
    yaw = math.atan2(d[1], d[0])
    pitch = math.atan2(-d[2], math.hypot(d[0], d[1]))   # positive pitch looks down
    u.comment("""
    Head with an RGB-D camera. camera_link: x forward (looking at (%s) in world), z up.
    camera_optical_frame: z forward, x right, y down (REP 103 optical convention).
    """ % vec(CAMERA_TARGET))
    neck = Shape(cylinder(0.04, 0.09), (0, 0, 0.045), material="vito_dark")
    head = Shape(box((0.14, 0.22, 0.12)), (0, 0, 0.15), material="vito_grey")
    u.link("head_link", [neck, head], mass=1.5, com=(0, 0, 0.12),
           inertia=inertia_box(1.5, (0.14, 0.22, 0.2)))
    u.fixed("head_joint", "torso_link", "head_link", HEAD_XYZ)
    cam = Shape(box((0.035, 0.18, 0.03)), (0, 0, 0), material="camera_black")
    u.link("camera_link", [cam], mass=0.2, inertia=inertia_box(0.2, (0.035, 0.18, 0.03)))
    u.fixed("camera_joint", "head_link", "camera_link", CAMERA_IN_HEAD, (0, pitch, yaw))
    u.comment("camera_optical_frame is a pure frame (no geometry, no inertia)")
    u.link("camera_optical_frame")
    u.fixed("camera_optical_joint", "camera_link", "camera_optical_frame", (0, 0, 0),
            (-math.pi / 2, 0, -math.pi / 2))


def build():
    u = Urdf("vito")
    add_materials(u)
    add_world_torso_table(u)
    add_head_camera(u)
    add_lwr_arm(u, "left")
    add_lwr_arm(u, "right")
    add_probe(u)
    add_softhand(u)
    return u.text()


def default_output():
    here = os.path.dirname(os.path.abspath(__file__))
    return os.path.join(here, "..", "urdf", "vito.urdf")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--stdout", action="store_true", help="print instead of writing")
    parser.add_argument("-o", "--output", default=default_output(), help="output file")
    args = parser.parse_args(argv)
    text = build()
    if args.stdout:
        sys.stdout.write(text)
    else:
        with open(args.output, "w") as f:
            f.write(text)
        print("wrote %s" % os.path.normpath(args.output))
    return 0


if __name__ == "__main__":
    sys.exit(main())
