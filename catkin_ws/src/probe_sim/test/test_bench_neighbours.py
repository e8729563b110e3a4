#!/usr/bin/env python3
"""A simulated scene of three objects: gpatlas_bench explores each in turn, the other two its
neighbours (the camera sees them, the probe can hit them), as a user selecting each object."""
import csv
import os
import shutil
import subprocess
import tempfile
import unittest

# The scene, world frame: object and the centre of its footprint on the table (x, y, metres).
SCENE = [("procedural:cylinder", (0.7, 0.0)), ("procedural:box", (0.7, 0.2)), ("procedural:torus", (0.7, -0.2))]
SIZE_M = "0.1"


def neighbour_flags(explored):
    """The other objects of SCENE as --neighbour flags, placed from the explored one's centre."""
    x0, y0 = SCENE[explored][1]
    flags = []
    for i, (spec, (x, y)) in enumerate(SCENE):
        if i != explored:
            flags += ["--neighbour", f"{spec}@{x - x0:g},{y - y0:g}"]
    return flags


class BenchNeighboursTest(unittest.TestCase):
    def setUp(self):
        self.out = tempfile.mkdtemp(prefix="gpatlas_bench_neighbours_")

    def tearDown(self):
        shutil.rmtree(self.out, ignore_errors=True)

    def explore(self, explored):
        spec, (x, y) = SCENE[explored]
        out = os.path.join(self.out, str(explored))
        args = ["rosrun", "probe_sim", "gpatlas_bench", "--object", spec, "--size-m", SIZE_M,
                "--set", f"simulation/object_position_xy_m=[{x}, {y}]", *neighbour_flags(explored),
                "--strategy", "atlas_poke", "--seeds", "0", "--max-actions", "40", "--curve-every", "0",
                "--no-reachability", "--no-plot", "--out", out]
        proc = subprocess.run(args, capture_output=True, text=True, timeout=600)
        self.assertEqual(proc.returncode, 0, proc.stdout + proc.stderr)
        with open(os.path.join(out, "runs.csv")) as f:
            rows = list(csv.DictReader(f))
        self.assertEqual(len(rows), 1, rows)
        return rows[0]

    def test_each_object_selected_in_turn_is_explored_to_convergence_without_collisions(self):
        for explored in range(len(SCENE)):
            r = self.explore(explored)
            name = SCENE[explored][0]
            # The explored object's model against its own truth: had segmentation kept a
            # neighbour, the surface would lie 10-20 cm from it.
            self.assertEqual(r["status"], "converged", (name, r))
            self.assertGreater(float(r["fscore_5mm"]), 0.8, (name, r))
            self.assertLess(float(r["rmse_pred_to_gt_m"]), 0.006, (name, r))
            # No way there and back met a neighbour, and hardly any touch was refused for want of
            # one. The object itself can be met where its model is still wrong (benchmarks.md
            # section 15), and the planner's paths depend on the machine's load: at most one touch.
            self.assertEqual(int(r["neighbour_collision_touches"]), 0, (name, r))
            self.assertLessEqual(int(r["approach_collisions"]) + int(r["retreat_collisions"]), 2, (name, r))
            self.assertLessEqual(int(r["unreachable_touches"]), 0.05 * int(r["actions"]), (name, r))


if __name__ == "__main__":
    unittest.main()
