#!/usr/bin/env python3
"""gpatlas_core's folders are layers: a file includes only its own folder and the folders before
it, and nothing of PCL, VTK, ROS or the packages above the core. The built library loads no PCL
or VTK either (ldd, so indirect dependencies count too)."""
import os
import re
import subprocess
import unittest

from catkin.find_in_workspaces import find_in_workspaces

PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LAYERS = ["common", "model", "observations", "planning", "exploration", "config", "testing"]
INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]([^>"]+)[>"]', re.M)
FORBIDDEN_PREFIXES = ("pcl/", "vtk", "ros/", "gpatlas_geometry/", "gpatlas_motion/", "gpatlas_ros/",
                      "gpatlas_conversions/", "gpatlas_msgs/", "probe_sim/")


def layer_of(path):
    """The layer of a file under include/gpatlas_core/<layer>/ or src/<layer>/."""
    parts = os.path.relpath(path, PACKAGE).split(os.sep)
    for folder in LAYERS:
        if folder in parts[:-1]:
            return folder
    return None


def sources():
    for top in ("include", "src"):
        for root, _, files in os.walk(os.path.join(PACKAGE, top)):
            for name in files:
                if name.endswith((".h", ".cpp")):
                    yield os.path.join(root, name)


class LayerTest(unittest.TestCase):
    def test_every_file_is_in_a_layer(self):
        unplaced = [os.path.relpath(p, PACKAGE) for p in sources() if layer_of(p) is None]
        self.assertEqual(unplaced, [])

    def test_no_include_goes_up_a_layer(self):
        upward = []
        for path in sources():
            own = LAYERS.index(layer_of(path))
            with open(path) as f:
                for included in INCLUDE.findall(f.read()):
                    match = re.match(r"gpatlas_core/([a-z_]+)/", included)
                    if match and LAYERS.index(match.group(1)) > own:
                        upward.append(f"{os.path.relpath(path, PACKAGE)} includes {included}")
        self.assertEqual(upward, [])

    def test_no_pcl_vtk_ros_or_upper_package_is_included(self):
        bad = []
        for path in sources():
            with open(path) as f:
                bad += [f"{os.path.relpath(path, PACKAGE)}: {i}" for i in INCLUDE.findall(f.read())
                        if i.startswith(FORBIDDEN_PREFIXES)]
        self.assertEqual(bad, [])

    def test_the_package_and_its_library_need_no_pcl_or_vtk(self):
        with open(os.path.join(PACKAGE, "package.xml")) as f:
            dependencies = re.findall(r"<[a-z_]*depend>([^<]+)<", f.read())
        self.assertEqual([d for d in dependencies if "pcl" in d.lower() or "vtk" in d.lower()], [])
        found = find_in_workspaces(["lib"], path="libgpatlas_core.so", first_matching_workspace_only=True)
        self.assertTrue(found, "libgpatlas_core.so not found in the workspace")
        out = subprocess.run(["ldd", found[0]], capture_output=True, text=True, check=True).stdout
        loaded = [line.split()[0] for line in out.splitlines() if line.strip()]
        self.assertEqual([n for n in loaded if n.startswith(("libpcl", "libvtk"))], [])


if __name__ == "__main__":
    unittest.main()
