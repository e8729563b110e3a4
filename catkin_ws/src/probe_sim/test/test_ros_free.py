#!/usr/bin/env python3
"""probe_sim is the ROS-free half of the simulation: its library and gpatlas_bench must load no
ROS library (ldd, so indirect dependencies count too) and none of the application's."""
import os
import subprocess
import unittest

from catkin.find_in_workspaces import find_in_workspaces

FORBIDDEN = ("libroscpp", "librosconsole", "librostime", "libgpatlas_ros", "libgpatlas_nodelets",
             "libgpatlas_conversions")


def find(kind, path):
    found = find_in_workspaces([kind], project="probe_sim" if kind == "libexec" else None, path=path,
                               first_matching_workspace_only=True)
    if not found:
        raise AssertionError(f"{path} not found in the workspace ({kind})")
    return found[0]


class RosFreeTest(unittest.TestCase):
    def check(self, binary):
        self.assertTrue(os.path.exists(binary), binary)
        out = subprocess.run(["ldd", binary], capture_output=True, text=True, check=True).stdout
        loaded = [line.split()[0] for line in out.splitlines() if line.strip()]
        bad = [name for name in loaded if name.startswith(FORBIDDEN)]
        self.assertEqual(bad, [], f"{binary} loads {bad}")
        return loaded

    def test_library(self):
        self.check(find("lib", "libprobe_sim.so"))

    def test_bench(self):
        loaded = self.check(find("libexec", "gpatlas_bench"))
        self.assertTrue(any(name.startswith("libprobe_sim") for name in loaded), loaded)


if __name__ == "__main__":
    unittest.main()
