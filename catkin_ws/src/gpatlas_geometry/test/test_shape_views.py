#!/usr/bin/env python3
"""scripts/shape_views.py: reads the PLY files writePly writes, samples a truth over its area,
and draws three views in which the side facing the viewer is on top and the colours saturate
at the clip."""
import os
import sys
import tempfile
import unittest

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.realpath(__file__)), "..", "scripts"))
import shape_views  # noqa: E402


def write_ply(path, vertices, faces, extra=None):
    """An ASCII PLY in writePly's layout: x y z, then the extra properties in order."""
    extra = extra or {}
    with open(path, "w") as f:
        f.write(f"ply\nformat ascii 1.0\ncomment test\nelement vertex {len(vertices)}\n")
        f.write("property double x\nproperty double y\nproperty double z\n")
        for name in extra:
            f.write(f"property double {name}\n")
        f.write(f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
        for i, v in enumerate(vertices):
            f.write(" ".join(repr(float(x)) for x in list(v) + [extra[n][i] for n in extra]) + "\n")
        for t in faces:
            f.write(f"3 {t[0]} {t[1]} {t[2]}\n")


# Two triangles: the square [0, 1] x [0, 2] at z = 0.
SQUARE = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 2.0, 0.0], [0.0, 2.0, 0.0]])
SQUARE_FACES = [(0, 1, 2), (0, 2, 3)]


class ShapeViewsTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()

    def tearDown(self):
        self.dir.cleanup()

    def test_reads_every_vertex_property_and_the_faces(self):
        path = os.path.join(self.dir.name, "square.ply")
        sd = [0.001, 0.002, 0.004, 0.008]
        write_ply(path, SQUARE, SQUARE_FACES, {"variance": [0.1, 0.2, 0.3, 0.4], "position_sd_m": sd})
        vertices, faces, columns = shape_views.read_ply(path)
        np.testing.assert_array_equal(vertices, SQUARE)
        np.testing.assert_array_equal(faces, SQUARE_FACES)
        np.testing.assert_array_equal(columns["position_sd_m"], sd)
        predicted, sd_mm, truth = shape_views.load_shape(path, path)
        self.assertEqual(sorted(sd_mm.tolist()), [1.0, 2.0, 4.0, 8.0])
        self.assertEqual(len(truth), shape_views.MAX_POINTS)
        # A mesh without the property (an older file) has no sd to colour by.
        write_ply(path, SQUARE, SQUARE_FACES, {"variance": [0.1, 0.2, 0.3, 0.4]})
        self.assertTrue(np.isnan(shape_views.load_shape(path)[1]).all())

    def test_truth_points_lie_on_the_triangles_spread_by_area(self):
        # Vertices crowd one corner; points spread by area do not.
        points = shape_views.surface_points(SQUARE, np.array(SQUARE_FACES), 20000)
        self.assertTrue((points[:, 0] >= -1e-12).all() and (points[:, 0] <= 1 + 1e-12).all())
        self.assertTrue((points[:, 1] >= -1e-12).all() and (points[:, 1] <= 2 + 1e-12).all())
        np.testing.assert_array_equal(points[:, 2], 0.0)
        # The square's centroid, within a few standard errors (sd of a uniform: side / sqrt 12).
        self.assertAlmostEqual(points[:, 0].mean(), 0.5, delta=4 * 0.29 / np.sqrt(20000))
        self.assertAlmostEqual(points[:, 1].mean(), 1.0, delta=4 * 0.58 / np.sqrt(20000))

    def test_each_view_draws_the_side_facing_it_last_and_clips_the_colours(self):
        rng = np.random.default_rng(0)
        predicted = rng.normal(size=(500, 3))
        sd_mm = rng.uniform(0.0, 30.0, size=500)
        fig, axes = plt.subplots(1, 3)
        contacts = np.array([[0.0, 0.0, 1.0]])
        mappable = shape_views.draw_views(axes, predicted, sd_mm, truth=predicted, contacts=contacts)
        self.assertLessEqual(mappable.get_array().max(), shape_views.CLIP_MM)
        self.assertEqual(mappable.get_clim(), (0.0, shape_views.CLIP_MM))
        # Top from +z: the highest point last; front from -y: the lowest y last; side from +x: the
        # largest x last. The truth, predicted and contacts scatters in that order.
        for ax, (index, nearest) in zip(axes, ((2, predicted[:, 2].argmax()), (1, predicted[:, 1].argmin()),
                                               (0, predicted[:, 0].argmax()))):
            truth_layer, predicted_layer, contact_layer = ax.collections
            title, h, v = [view for view in shape_views.VIEWS if view[3] == index][0][:3]
            self.assertEqual(ax.get_title(), title)
            np.testing.assert_array_equal(predicted_layer.get_offsets()[-1], predicted[nearest, [h, v]])
            self.assertEqual(len(truth_layer.get_offsets()), 500)
            np.testing.assert_array_equal(contact_layer.get_offsets()[0], contacts[0, [h, v]])
        # Every view spans the same length, so a centimetre is as long in each.
        spans = [np.diff(ax.get_xlim())[0] for ax in axes] + [np.diff(ax.get_ylim())[0] for ax in axes]
        self.assertAlmostEqual(min(spans), max(spans))
        plt.close(fig)


if __name__ == "__main__":
    unittest.main()
