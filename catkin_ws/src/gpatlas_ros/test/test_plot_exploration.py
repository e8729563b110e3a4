#!/usr/bin/env python3
"""scripts/plot_exploration.py on a small results folder made here: with surface.ply it draws the
curves and the three views (a taller figure), without it the curves alone; and a folder whose
predicted surface misses the truth's handle shows the handle's truth without predicted points."""
import json
import math
import os
import struct
import subprocess
import sys
import tempfile
import unittest

SCRIPT = os.path.join(os.path.dirname(os.path.realpath(__file__)), "..", "scripts", "plot_exploration.py")
DPI = 90  # the script's


def png_size(path):
    """(width, height) from a PNG's header."""
    with open(path, "rb") as f:
        header = f.read(24)
    if header[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path} is not a PNG")
    return struct.unpack(">II", header[16:24])


def sphere(centre, radius, rings=12, segments=24):
    """A UV sphere: vertices and triangles."""
    vertices = [(centre[0], centre[1], centre[2] + radius), (centre[0], centre[1], centre[2] - radius)]
    for i in range(1, rings):
        polar = math.pi * i / rings
        for j in range(segments):
            azimuth = 2 * math.pi * j / segments
            vertices.append((centre[0] + radius * math.sin(polar) * math.cos(azimuth),
                             centre[1] + radius * math.sin(polar) * math.sin(azimuth),
                             centre[2] + radius * math.cos(polar)))
    ring = lambda i, j: 2 + (i - 1) * segments + j % segments  # noqa: E731
    faces = []
    for j in range(segments):
        faces.append((0, ring(1, j), ring(1, j + 1)))
        faces.append((1, ring(rings - 1, j + 1), ring(rings - 1, j)))
        for i in range(1, rings - 1):
            faces += [(ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)), (ring(i, j), ring(i + 1, j + 1), ring(i, j + 1))]
    return vertices, faces


def write_ply(path, vertices, faces, position_sd=None):
    with open(path, "w") as f:
        f.write(f"ply\nformat ascii 1.0\nelement vertex {len(vertices)}\n")
        f.write("property double x\nproperty double y\nproperty double z\nproperty double variance\n")
        if position_sd is not None:
            f.write("property double position_sd_m\n")
        f.write(f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
        for i, v in enumerate(vertices):
            f.write(" ".join(map(repr, v)) + " 0.01" + (f" {position_sd[i]!r}" if position_sd else "") + "\n")
        for t in faces:
            f.write(f"3 {t[0]} {t[1]} {t[2]}\n")


def report(contacts):
    history = [{"action": k + 1, "contacts": len(c), "contacts_total": sum(len(x) for x in contacts[:k + 1]),
                "max_evaluated_variance": 0.5 / (k + 1), "sampled_max_variance": 0.4 / (k + 1),
                "rmse_pred_to_gt_m": 0.004, "rmse_gt_to_pred_m": 0.006, "fscore_5mm": 0.8, "contact_points": c}
               for k, c in enumerate(contacts)]
    return {"settings": {"strategy": "atlas_poke", "v_max": 0.1}, "stop_reason": "max_actions",
            "actions": len(history), "contacts": history[-1]["contacts_total"],
            "final_metrics": {"fscore_5mm": 0.8, "rmse_gt_to_pred_m": 0.006, "position_sd_m": 0.002},
            "initial": {"n_train": 300, "sampled_max_variance": 0.6, "rmse_pred_to_gt_m": 0.01,
                        "rmse_gt_to_pred_m": 0.012, "fscore_5mm": 0.5},
            "history": history}


class PlotExplorationTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.results = self.dir.name
        contacts = [[[0.66, 0.0, 0.1]], [], [[0.6, 0.06, 0.1], [0.6, 0.061, 0.105]]]
        with open(os.path.join(self.results, "report.json"), "w") as f:
            json.dump(report(contacts), f)

    def tearDown(self):
        self.dir.cleanup()

    def plot(self):
        proc = subprocess.run([sys.executable, SCRIPT, self.results], capture_output=True, text=True, timeout=120)
        self.assertEqual(proc.returncode, 0, proc.stdout + proc.stderr)
        png = os.path.join(self.results, "exploration.png")
        self.assertEqual(proc.stdout.strip(), png)
        return png_size(png)

    def test_curves_alone_without_a_surface(self):
        self.assertEqual(self.plot(), (7 * DPI, 4 * DPI))

    def test_the_surface_from_three_sides_beside_the_truth(self):
        # The truth: a ball with a "handle", a small ball beyond x = 0.745; the prediction: the
        # ball alone, its sd growing towards +x (the side the camera did not see).
        body, body_faces = sphere((0.6, 0.0, 0.1), 0.06)
        handle, handle_faces = sphere((0.76, 0.0, 0.1), 0.012, 6, 12)
        write_ply(os.path.join(self.results, "truth.ply"), body + handle,
                  body_faces + [tuple(i + len(body) for i in t) for t in handle_faces])
        sd = [0.001 + 0.2 * max(0.0, v[0] - 0.6) for v in body]
        write_ply(os.path.join(self.results, "surface.ply"), body, body_faces, sd)
        self.assertEqual(self.plot(), (12 * DPI, 8 * DPI))

    def test_an_older_surface_without_position_sd_still_plots(self):
        body, body_faces = sphere((0.6, 0.0, 0.1), 0.06)
        write_ply(os.path.join(self.results, "surface.ply"), body, body_faces)
        self.assertEqual(self.plot(), (12 * DPI, 8 * DPI))


if __name__ == "__main__":
    unittest.main()
