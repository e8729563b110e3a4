#!/usr/bin/env python3
"""Runs gpatlas_bench on a procedural object with two strategies and checks its outputs."""
import csv
import math
import os
import shutil
import struct
import subprocess
import tempfile
import unittest

COLUMNS = ("object,strategy,probe,seed,vmax,max_position_sd_m,actions,contacts,converged,status,stop_reason,n_train,"
           "rmse_pred_to_gt_m,rmse_gt_to_pred_m,rmse_gt_to_pred_seen_m,rmse_gt_to_pred_unseen_m,chamfer_l1_m,"
           "fscore_5mm,calibration_2sd,position_sd_m,coverage_2sd,sharpness,position_sd_scale,max_evaluated_variance,wall_s,plan_ms_median,"
           "update_ms_median,unreachable_touches,unreachable_candidates,final_unreachable_candidates,"
           "final_unreachable_area_fraction,approach_collisions,retreat_collisions,neighbour_collision_touches,"
           "guarded_entries,approach_plan_ms_median,recent_target_error_m").split(",")


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


CURVE_EVERY = 1  # the default: the shape after every action
VARIANCE_EVERY = 3


class BenchSmokeTest(unittest.TestCase):
    def setUp(self):
        self.out = tempfile.mkdtemp(prefix="gpatlas_bench_test_")

    def tearDown(self):
        shutil.rmtree(self.out, ignore_errors=True)

    def run_bench(self, *args):
        return subprocess.run(["rosrun", "probe_sim", "gpatlas_bench", *args], capture_output=True, text=True,
                              timeout=600)

    def test_small_run_writes_plausible_csv(self):
        proc = self.run_bench("--object", "procedural:sphere", "--size-m", "0.12", "--set", "simulation/table=false",
                              "--strategy", "atlas_poke",
                              "--strategy", "random", "--seeds", "0", "--max-actions", "4", "--set", "view/max_surface_points=200",
                              "--variance-every", str(VARIANCE_EVERY), "--jobs", "2",
                              "--out", self.out, "--no-plot", "--save-meshes")
        self.assertEqual(proc.returncode, 0, proc.stdout + proc.stderr)
        self.assertIn("[2/2]", proc.stdout)
        with open(os.path.join(self.out, "runs.csv")) as f:
            reader = csv.DictReader(f)
            self.assertEqual(reader.fieldnames, COLUMNS)
            rows = list(reader)
        self.check_runs(rows)
        self.check_reachability(rows)
        self.check_history(rows)
        self.check_summary(rows)
        self.check_saved_meshes(rows)
        self.assertIn("planning time, random: median", proc.stdout)
        self.check_plot(rows)

    def check_runs(self, rows):
        self.assertEqual(sorted(r["strategy"] for r in rows), ["atlas_poke", "random"])
        for r in rows:
            self.assertEqual(r["object"], "sphere")
            actions = int(r["actions"])
            self.assertTrue(0 < actions <= 4, r)  # the sphere is not done with its view alone
            self.assertIn(r["stop_reason"], ("converged", "max_actions", "consecutive_failures",
                                             "planner_cap_reached"), r)
            self.assertGreaterEqual(int(r["n_train"]), 200)
            for key in ("rmse_pred_to_gt_m", "rmse_gt_to_pred_m", "chamfer_l1_m"):
                value = float(r[key])
                # A 12 cm sphere seen from one side, after 4 touches: with the default frame
                # (domain twice the visible extent) the unseen back is predicted within about a
                # centimetre.
                self.assertTrue(math.isfinite(value) and 0.0 <= value < 0.015, (key, value))
            variance = float(r["max_evaluated_variance"])
            self.assertTrue(math.isfinite(variance) and variance >= 0.0, r)
            for key in ("plan_ms_median", "update_ms_median"):
                self.assertTrue(math.isfinite(float(r[key])) and float(r[key]) >= 0.0, (key, r))
            # Approach planning is on by default: every touch was planned, in a fraction of its
            # 0.2 s budget.
            for key in ("unreachable_touches", "unreachable_candidates", "final_unreachable_candidates",
                        "approach_collisions", "retreat_collisions", "neighbour_collision_touches", "guarded_entries"):
                self.assertGreaterEqual(int(r[key]), 0, (key, r))
            # An atlas's charts left out of reach have a share of its area, and none have none; a
            # baseline's candidates are sampled points, without an area.
            share = float(r["final_unreachable_area_fraction"])
            self.assertTrue(0.0 <= share <= 1.0, r)
            if r["strategy"] == "atlas_poke":
                self.assertEqual(share > 0.0, int(r["final_unreachable_candidates"]) > 0, r)
            else:
                self.assertEqual(share, 0.0, r)
            self.assertTrue(0.0 <= float(r["approach_plan_ms_median"]) < 1000.0, r)
            # Where the last touches found the surface, measured from their targets: on this
            # sphere the model predicts it within its radius, and a run without a contact has none.
            error = float(r["recent_target_error_m"])
            if int(r["contacts"]) > 0:
                self.assertTrue(0.0 <= error < 0.06, r)
            else:
                self.assertTrue(math.isnan(error), r)
            self.assertEqual(float(r["vmax"]), 0.1)
            self.assertEqual(float(r["max_position_sd_m"]), 0.005)
            self.assertLessEqual(int(r["contacts"]), int(r["n_train"]))
            fscore = float(r["fscore_5mm"])
            self.assertTrue(0.0 <= fscore <= 1.0)
            self.assertGreater(float(r["wall_s"]), 0.0)

    def check_reachability(self, rows):
        # A sphere's surface is all reachable from outside (no table in the paper's protocol), so
        # the floor is zero and the reachable truth is the whole truth: the same samples.
        with open(os.path.join(self.out, "reachability.csv")) as f:
            reader = csv.DictReader(f)
            self.assertEqual(reader.fieldnames, ["object", "strategy", "seed", "reachable_area_fraction",
                                                 "floor_rmse_gt_to_pred_m", "rmse_gt_to_pred_reachable_m"])
            reach = {r["strategy"]: r for r in reader}
        self.assertEqual(sorted(reach), ["atlas_poke", "random"])
        for r in rows:
            row = reach[r["strategy"]]
            self.assertGreater(float(row["reachable_area_fraction"]), 0.999, row)
            self.assertLess(float(row["floor_rmse_gt_to_pred_m"]), 1e-5, row)
            reachable = float(row["rmse_gt_to_pred_reachable_m"])
            whole = float(r["rmse_gt_to_pred_m"])
            self.assertTrue(math.isfinite(reachable) and abs(reachable - whole) <= 1e-4 * whole,
                            (reachable, whole))

    def check_history(self, rows):
        # history.csv: each plan's model size. The first plan sees the initial model (the row
        # before any action); each row's size is what the model held before that action's update.
        # (Sizes need not grow: a touch retracts the guesses it contradicts.)
        with open(os.path.join(self.out, "history.csv")) as f:
            history = list(csv.DictReader(f))
        for r in rows:
            steps = sorted((h for h in history if h["strategy"] == r["strategy"]), key=lambda h: int(h["action"]))
            self.assertEqual(steps[0]["action"], "0")
            sizes = [int(h["n_train"]) for h in steps]
            self.assertGreaterEqual(sizes[0], 200)
            self.assertGreater(int(r["actions"]), 0, r)
            self.assertEqual(sizes[1], sizes[0], steps[:2])
            # The curve: the shape at action 0 and after every action (--curve-every 1) at the
            # curve's quality, the last action's as runs.csv has it; the bench's own variance sample
            # at the multiples of --variance-every (3), and after the last action.
            last = int(r["actions"])
            for h in steps:
                action = int(h["action"])
                sampled = float(h["sampled_max_variance"])
                curve = action % CURVE_EVERY == 0
                self.assertEqual(h["measured"], "final" if action == last else "curve" if curve else "", h)
                if (curve and action % VARIANCE_EVERY == 0) or action == last:
                    self.assertTrue(math.isfinite(sampled) and sampled >= 0.0, h)
                else:
                    self.assertTrue(math.isnan(sampled), h)
                shape = [float(h[k]) for k in ("rmse_pred_to_gt_m", "rmse_gt_to_pred_m", "fscore_5mm")]
                if curve or action == last:
                    self.assertTrue(all(math.isfinite(v) for v in shape) and 0.0 <= shape[2] <= 1.0, h)
                else:
                    self.assertTrue(all(math.isnan(v) for v in shape), h)
            for key, run_key in (("rmse_pred_to_gt_m", "rmse_pred_to_gt_m"), ("rmse_gt_to_pred_m", "rmse_gt_to_pred_m"),
                                 ("fscore_5mm", "fscore_5mm")):
                self.assertEqual(steps[-1][key], r[run_key], (key, steps[-1], r))
        # Both strategies start from the same model (same seed, same view), so the bench's sample of
        # it, unlike each strategy's own estimate, is the same number.
        initial = [float(h["sampled_max_variance"]) for h in history if h["action"] == "0"]
        self.assertEqual(len(initial), 2)
        self.assertEqual(initial[0], initial[1])

    def check_saved_meshes(self, rows):
        # --save-meshes: each run's surface with every vertex's position sd, and its contacts, on
        # the truth's sphere (its centre and radius from OBJECT_truth.ply) and as many as runs.csv
        # counts.
        truth, _ = read_ply(os.path.join(self.out, "sphere_truth.ply"))
        centre = [sum(v[k] for v in truth) / len(truth) for k in range(3)]
        radius = sum(math.dist(v, centre) for v in truth) / len(truth)
        self.assertAlmostEqual(radius, 0.06, delta=0.002)
        for r in rows:
            stem = os.path.join(self.out, f"sphere_{r['strategy']}_seed0")
            vertices, properties = read_ply(stem + ".ply")
            self.assertEqual(properties, ["x", "y", "z", "variance", "position_sd_m"])
            sd = [v[4] for v in vertices]
            self.assertTrue(all(math.isfinite(x) and x > 0.0 for x in sd), r)
            # The median over the predicted surface is of the order of runs.csv's median on the
            # truth (the two surfaces differ by a few millimetres here).
            median = sorted(sd)[len(sd) // 2]
            self.assertLess(median, 10 * float(r["position_sd_m"]) + 0.005, r)
            with open(stem + "_contacts.csv") as f:
                contacts = list(csv.DictReader(f))
            self.assertEqual(len(contacts), int(r["contacts"]), r)
            for c in contacts:
                self.assertTrue(1 <= int(c["action"]) <= int(r["actions"]), c)
                gap = math.dist([float(c[k]) for k in "xyz"], centre) - radius
                self.assertLess(abs(gap), 0.003, c)

    def check_plot(self, rows):
        # The per-object plot from these files: the curves and a row of three views per run.
        script = os.path.join(os.path.dirname(os.path.realpath(__file__)), "..", "scripts", "plot_bench.py")
        proc = subprocess.run(["/usr/bin/python3", script, self.out], capture_output=True, text=True, timeout=300)
        self.assertEqual(proc.returncode, 0, proc.stdout + proc.stderr)
        with open(os.path.join(self.out, "sphere.png"), "rb") as f:
            header = f.read(24)
        self.assertEqual(header[:8], b"\x89PNG\r\n\x1a\n")
        width, height = struct.unpack(">II", header[16:24])
        # matplotlib rounds the inches' pixels down, by a float's error.
        self.assertEqual(width, 11 * 90)
        self.assertAlmostEqual(height, (4 + 3.6 * len(rows)) * 90, delta=1.0)

    def check_summary(self, rows):
        with open(os.path.join(self.out, "summary.md")) as f:
            summary = f.read()
        self.assertIn("| sphere |", summary)
        self.assertIn("atlas_poke steps", summary)
        self.assertIn("atlas_poke mean NN", summary)
        # The mean row's mean NN per strategy is the mean of runs.csv's chamfer_l1_m (one run each).
        mean_row = next(line for line in summary.splitlines() if line.startswith("| **mean** |"))
        cells = [c.strip() for c in mean_row.strip("|").split("|")]
        # Six cells per strategy: steps, RMSE, mean NN, F@5mm, coverage / sharpness, converged.
        for i, strategy in enumerate(["atlas_poke", "random"]):
            run = next(r for r in rows if r["strategy"] == strategy)
            self.assertAlmostEqual(float(cells[1 + 6 * i + 2]), float(run["chamfer_l1_m"]), delta=1e-4, msg=mean_row)
            coverage, sharpness = (float(c) for c in cells[1 + 6 * i + 4].split("/"))
            self.assertAlmostEqual(coverage, float(run["coverage_2sd"]), delta=1e-3, msg=mean_row)
            self.assertAlmostEqual(sharpness, float(run["sharpness"]), delta=0.01, msg=mean_row)
            self.assertTrue(0.0 <= float(run["calibration_2sd"]) <= 1.0, run)
            self.assertGreater(float(run["position_sd_m"]), 0.0, run)
            # Coverage and sharpness from the truth's distances to the predicted surface; the
            # view's cross-validation sets the scale (1 would be uncalibrated).
            self.assertTrue(0.0 <= float(run["coverage_2sd"]) <= 1.0, run)
            self.assertGreater(float(run["sharpness"]), 0.0, run)
            self.assertTrue(0.0 < float(run["position_sd_scale"]) < 1.0, run)
        self.assertIn("g->p reachable", summary)
        self.assertIn("- atlas_poke: median", summary)

    def test_the_anytime_table_is_the_curve_of_history_csv(self):
        # Four runs of up to 11 actions measured every 2: after 5 touches a run's point is its
        # action 4, after 10 its action 10, after 20 its final one (it stopped before). A 6 cm
        # sphere's runs reach F@5mm 0.9 at different actions (or not), so the median has work.
        proc = self.run_bench("--object", "procedural:sphere", "--size-m", "0.06", "--set", "simulation/table=false",
                              "--strategy", "atlas_poke,random", "--seeds", "0,1", "--max-actions", "11",
                              "--set", "view/max_surface_points=200", "--curve-every", "2", "--no-reachability",
                              "--jobs", "2", "--out", self.out, "--no-plot")
        self.assertEqual(proc.returncode, 0, proc.stdout + proc.stderr)
        self.assertIn("the curve's", proc.stdout)
        with open(os.path.join(self.out, "runs.csv")) as f:
            runs = list(csv.DictReader(f))
        with open(os.path.join(self.out, "history.csv")) as f:
            history = list(csv.DictReader(f))
        last = {(r["strategy"], r["seed"]): int(r["actions"]) for r in runs}
        for h in history:
            action = int(h["action"])
            measured = ("final" if action == last[(h["strategy"], h["seed"])] else
                        "curve" if action % 2 == 0 else "")
            self.assertEqual(h["measured"], measured, h)
            self.assertEqual(h["fscore_5mm"] == "nan", measured == "", h)
        with open(os.path.join(self.out, "summary.md")) as f:
            lines = f.read().splitlines()
        header = next(i for i, line in enumerate(lines) if line.startswith("| strategy | g->p @5 |"))
        columns = [c.strip() for c in lines[header].strip("|").split("|")]
        table = {}
        for line in lines[header + 2:]:
            if not line.startswith("|"):
                break
            cells = [c.strip() for c in line.strip("|").split("|")]
            table[cells[0]] = dict(zip(columns, cells))
        self.assertEqual(sorted(table), ["atlas_poke", "random"])
        for strategy, row in table.items():
            expected = self.anytime_row([r for r in runs if r["strategy"] == strategy], history)
            self.assertEqual(len(expected), len(row), (expected, row))
            for column, value in expected.items():
                self.assertEqual(row[column], value, (strategy, column, row))

    @staticmethod
    def anytime_row(runs, history):
        """The anytime table's row of one strategy, recomputed from runs.csv and history.csv."""
        curves = []
        for run in runs:
            rows = [h for h in history if (h["object"], h["strategy"], h["seed"]) ==
                    (run["object"], run["strategy"], run["seed"])]
            measured = [(int(h["action"]), float(h["rmse_gt_to_pred_m"]), float(h["rmse_pred_to_gt_m"]),
                         float(h["fscore_5mm"])) for h in rows if h["fscore_5mm"] != "nan"]
            curves.append((int(run["actions"]), measured))
        row = {"strategy": runs[0]["strategy"]}
        for k in (5, 10, 20):
            points = [[p for p in measured if p[0] <= k][-1] for _, measured in curves]
            row["g->p @%d" % k] = "%.2f" % (1000 * sum(p[1] for p in points) / len(points))
            row["p->g @%d" % k] = "%.2f" % (1000 * sum(p[2] for p in points) / len(points))
            row["F@5mm @%d" % k] = "%.3f" % (sum(p[3] for p in points) / len(points))
            row["reached %d" % k] = "%d/%d" % (sum(1 for actions, _ in curves if actions >= k), len(curves))
        first = [next((p[0] for p in measured if p[3] >= 0.9), None) for _, measured in curves]
        reached = sorted(t for t in first if t is not None)
        if reached:
            middle = len(reached) // 2
            median = reached[middle] if len(reached) % 2 else 0.5 * (reached[middle - 1] + reached[middle])
            row["touches to F@5mm 0.9"] = "%.1f" % median
        else:
            row["touches to F@5mm 0.9"] = "-"
        row["never"] = str(len(curves) - len(reached))
        return row

    def test_the_face_on_the_table_is_unreachable_and_sets_the_floor(self):
        # A 10 cm cube on the table: its bottom face (1/6 of the area) is covered. A prediction
        # that is exactly the other five faces is, from a bottom point, as far as the nearest
        # edge of the square: E[d^2] = a^2 / 24 over a square of side a, so the floor is
        # sqrt(1/6 * a^2 / 24) = a / 12.
        proc = self.run_bench("--object", "procedural:box", "--size-m", "0.1", "--set", "simulation/table=true", "--strategy",
                              "atlas_poke", "--seeds", "0", "--max-actions", "1", "--set", "view/max_surface_points=200",
                              "--out", self.out, "--no-plot")
        self.assertEqual(proc.returncode, 0, proc.stdout + proc.stderr)
        with open(os.path.join(self.out, "reachability.csv")) as f:
            (row,) = list(csv.DictReader(f))
        self.assertAlmostEqual(float(row["reachable_area_fraction"]), 5.0 / 6.0, places=6)
        self.assertAlmostEqual(float(row["floor_rmse_gt_to_pred_m"]) / (0.1 / 12.0), 1.0, delta=0.05)
        self.assertTrue(math.isfinite(float(row["rmse_gt_to_pred_reachable_m"])), row)

    def test_a_strategy_from_a_library_runs_like_the_built_in_ones(self):
        # The example library of gpatlas_core, found where the workspace's setup file points
        # the dynamic linker.
        dirs = [d for d in os.environ.get("LD_LIBRARY_PATH", "").split(":") if d]
        found = [os.path.join(d, "libgpatlas_example_strategies.so") for d in dirs
                 if os.path.exists(os.path.join(d, "libgpatlas_example_strategies.so"))]
        self.assertTrue(found, "libgpatlas_example_strategies.so not on LD_LIBRARY_PATH: %s" % dirs)
        proc = self.run_bench("--strategy-library", found[0], "--object", "procedural:sphere", "--size-m", "0.12",
                              "--set", "simulation/table=false",
                              "--strategy", "farthest_from_evidence,atlas_poke", "--seeds", "0", "--max-actions",
                              "2", "--set", "view/max_surface_points=200", "--no-reachability", "--out", self.out, "--no-plot")
        self.assertEqual(proc.returncode, 0, proc.stdout + proc.stderr)
        self.assertIn("adds the strategies: farthest_from_evidence", proc.stdout)
        with open(os.path.join(self.out, "runs.csv")) as f:
            rows = {r["strategy"]: r for r in csv.DictReader(f)}
        self.assertEqual(sorted(rows), ["atlas_poke", "farthest_from_evidence"])
        row = rows["farthest_from_evidence"]
        self.assertEqual(int(row["actions"]), 2, row)  # a partial view of a sphere needs more than 2
        self.assertTrue(0.0 <= float(row["rmse_pred_to_gt_m"]) < 0.015, row)

    def test_bad_arguments_are_refused(self):
        for args in (["--set", "exploration/v_max=0"], ["--set", "no/such_key=1"], ["--config", "/no/such/pipeline.yaml"],
                     ["--simulation", "/no/such/simulation.yaml"], ["--set", "simulation/probe_radius_m=-1"],
                     ["--strategy", "nope"], ["--object", "/no/such/file.stl"], ["--probe", "laser"], ["--reach-directions", "0"],
                     ["--strategy-library", "/no/such/libstrategies.so"], ["--curve-every", "-1"],
                     ["--curve-resolution-m", "0"], ["--curve-samples", "0"], ["--variance-every", "0"]):
            proc = self.run_bench(*args, "--out", self.out)
            self.assertEqual(proc.returncode, 2, args)
            self.assertIn("gpatlas_bench:", proc.stderr)


if __name__ == "__main__":
    unittest.main()
