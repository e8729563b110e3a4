#!/usr/bin/env python3
"""Plots gpatlas_bench's history.csv: per object, the shape error (RMSE, both directions) and the
largest surface variance against the number of actions, one line per strategy and seed, and
with --save-meshes' files the predicted surfaces from three sides, coloured by their position
sd, over the truth and with the contacts (shape_views.py, a row per run, the first few); and
anytime.png, the summary's anytime curve: per object one panel, per strategy the mean over its
seeds of F@5mm and of the RMSEs after each number of touches (a run that stopped earlier counts
with its final value)."""
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


# Runs shown from three sides per object: a row each, the first strategies' first seeds.
MAX_SHAPE_ROWS = 4


def import_shape_views():
    """gpatlas_geometry's shape_views.py, found from this script's place in the source tree
    (src/probe_sim/scripts) or the install space (lib/probe_sim, beside share/gpatlas_geometry)."""
    here = os.path.dirname(os.path.realpath(__file__))
    for relative in ("../../gpatlas_geometry/scripts", "../../share/gpatlas_geometry/scripts"):
        folder = os.path.normpath(os.path.join(here, relative))
        if os.path.isfile(os.path.join(folder, "shape_views.py")):
            sys.path.insert(0, folder)
            break
    import shape_views
    return shape_views


def main(out_dir):
    path = os.path.join(out_dir, "history.csv")
    rows = list(csv.DictReader(open(path)))
    objects = sorted({r["object"] for r in rows})
    colours = {}
    for obj in objects:
        runs = {}
        for r in rows:
            if r["object"] == obj:
                runs.setdefault((r["strategy"], r["seed"]), []).append(r)
        saved = [run for run in sorted(runs, key=lambda run: (run[0], int(run[1])))
                 if os.path.isfile(run_file(out_dir, obj, run, ".ply"))]
        shown = sorted(saved, key=lambda run: (int(run[1]), run[0]))[:MAX_SHAPE_ROWS]
        fig = plt.figure(figsize=(11, 4 + 3.6 * len(shown)))
        grid = fig.add_gridspec(1 + len(shown), 6, height_ratios=[1.0] + [1.0] * len(shown))
        ax_err, ax_var = fig.add_subplot(grid[0, 0:3]), fig.add_subplot(grid[0, 3:6])
        plot_object_curves(obj, runs, colours, ax_err, ax_var)
        if shown:
            plot_object_shapes(fig, grid, out_dir, obj, [run for run in saved if run in shown], len(saved))
        else:
            fig.tight_layout()
        png = os.path.join(out_dir, f"{obj}.png")
        fig.savefig(png, dpi=90)
        plt.close(fig)
        print(f"plot: {png}")
    plot_anytime(out_dir, rows)


def run_file(out_dir, obj, run, suffix):
    """--save-meshes' file of a run (strategy, seed): OBJECT_STRATEGY_seedS.ply, ..._contacts.csv."""
    return os.path.join(out_dir, f"{obj}_{run[0]}_seed{run[1]}{suffix}")


def plot_object_curves(obj, runs, colours, ax_err, ax_var):
    for (strategy, seed), hist in sorted(runs.items()):
        colour = colours.setdefault(strategy, f"C{len(colours)}")
        label = strategy if seed == min(s for (st, s) in runs if st == strategy) else None
        err = [(int(h["action"]), 1000 * 0.5 * (float(h["rmse_pred_to_gt_m"]) + float(h["rmse_gt_to_pred_m"])))
               for h in hist if h["rmse_pred_to_gt_m"] != "nan"]
        # The bench's own sample (the same for every strategy); older files lack it.
        key = "sampled_max_variance" if "sampled_max_variance" in hist[0] else "max_evaluated_variance"
        var = [(int(h["action"]), float(h[key])) for h in hist
               if h[key] != "nan" and math.isfinite(float(h[key]))]
        if err:
            ax_err.plot(*zip(*err), color=colour, marker="o", ms=3, label=label)
        if var:
            ax_var.plot(*zip(*var), color=colour, marker="o", ms=3, label=label)
    ax_err.set_xlabel("actions")
    ax_err.set_ylabel("shape RMSE, mean of both directions (mm)")
    ax_err.set_title(f"{obj}: shape error")
    ax_var.set_xlabel("actions")
    ax_var.set_ylabel("largest variance of a surface sample")
    ax_var.set_yscale("log")
    ax_var.set_title(f"{obj}: largest variance on the surface")
    for ax in (ax_err, ax_var):
        ax.grid(True, alpha=0.3)
        ax.legend()


def read_contacts(path):
    """--save-meshes' contacts file: N x 3 in metres (none when the file is missing)."""
    if not os.path.isfile(path):
        return None
    points = [(float(r["x"]), float(r["y"]), float(r["z"])) for r in csv.DictReader(open(path))]
    return np.array(points, dtype=float).reshape(-1, 3)


def plot_object_shapes(fig, grid, out_dir, obj, shown, saved_count):
    """A row per shown run: its predicted surface from three sides over the object's truth."""
    views = import_shape_views()
    truth = os.path.join(out_dir, f"{obj}_truth.ply")
    rows = []
    for i, run in enumerate(shown):
        axes = [fig.add_subplot(grid[1 + i, 2 * k:2 * k + 2]) for k in range(3)]
        predicted, sd_mm, truth_points = views.load_shape(run_file(out_dir, obj, run, ".ply"),
                                                          truth if os.path.isfile(truth) else None)
        contacts = read_contacts(run_file(out_dir, obj, run, "_contacts.csv"))
        rows.append((axes, views.draw_views(axes, predicted, sd_mm, truth_points, contacts)))
        axes[0].set_ylabel(f"{run[0]} seed {run[1]}\n" + axes[0].get_ylabel(), fontsize=8)
    fig.tight_layout(rect=(0, 0.03, 0.96, 1))
    for axes, mappable in rows:
        views.add_colour_bar(fig, mappable, axes)
    note = f" ({len(shown)} of {saved_count} saved runs shown)" if saved_count > len(shown) else ""
    fig.text(0.01, 0.01, views.LEGEND + note, fontsize=8)


def measured_point(hist, touches):
    """The run's last measured point at or before `touches` (its final one when it stopped earlier)."""
    point = None
    for h in hist:
        if int(h["action"]) <= touches and h.get("fscore_5mm", "nan") != "nan" and h["rmse_gt_to_pred_m"] != "nan":
            point = h
    return point


def plot_anytime(out_dir, rows):
    if not rows or "fscore_5mm" not in rows[0]:
        return
    objects = sorted({r["object"] for r in rows})
    strategies = sorted({r["strategy"] for r in rows})
    fig, axes = plt.subplots(2, len(objects), figsize=(4.5 * len(objects), 7), squeeze=False)
    for col, obj in enumerate(objects):
        ax_f, ax_e = axes[0][col], axes[1][col]
        for i, strategy in enumerate(strategies):
            runs = {}
            for r in rows:
                if r["object"] == obj and r["strategy"] == strategy:
                    runs.setdefault(r["seed"], []).append(r)
            if not runs:
                continue
            last = max(int(h["action"]) for hist in runs.values() for h in hist)
            curve = []
            for k in range(last + 1):
                points = [p for p in (measured_point(hist, k) for hist in runs.values()) if p is not None]
                if points:
                    mean = lambda key, scale=1.0: scale * sum(float(p[key]) for p in points) / len(points)
                    curve.append((k, mean("fscore_5mm"), mean("rmse_gt_to_pred_m", 1000), mean("rmse_pred_to_gt_m", 1000)))
            if not curve:
                continue
            k, f, g, p = zip(*curve)
            colour = f"C{i}"
            ax_f.plot(k, f, color=colour, label=f"{strategy} ({len(runs)} seeds)")
            ax_e.plot(k, g, color=colour, label=f"{strategy} truth->predicted")
            ax_e.plot(k, p, color=colour, linestyle="--", label=f"{strategy} predicted->truth")
        ax_f.axhline(0.9, color="grey", linewidth=0.8, linestyle=":")
        ax_f.set_title(f"{obj}: F@5mm")
        ax_f.set_ylim(0.0, 1.0)
        ax_e.set_title(f"{obj}: RMSE (mm)")
        for ax in (ax_f, ax_e):
            ax.set_xlabel("touches")
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=7)
    fig.tight_layout()
    png = os.path.join(out_dir, "anytime.png")
    fig.savefig(png, dpi=90)
    plt.close(fig)
    print(f"plot: {png}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: plot_bench.py OUT_DIR")
    main(sys.argv[1])
