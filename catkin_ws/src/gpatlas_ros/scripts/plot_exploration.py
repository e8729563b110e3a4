#!/usr/bin/env python3
"""Plots an exploration's results folder: from report.json, the largest surface variance and the
shape error (when a ground truth was known) against the number of actions; below, the predicted
surface (surface.ply) from three sides, coloured by its position sd, over the truth (truth.ply)
and with the contacts (report.json's contact_points). Writes exploration.png beside them."""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def import_shape_views():
    """gpatlas_geometry's shape_views.py, found from this script's place in the source tree
    (src/gpatlas_ros/scripts), the install space's share (share/gpatlas_ros/scripts) or lib
    (lib/gpatlas_ros): each with gpatlas_geometry's beside it."""
    here = os.path.dirname(os.path.realpath(__file__))
    for relative in ("../../gpatlas_geometry/scripts", "../../share/gpatlas_geometry/scripts"):
        folder = os.path.normpath(os.path.join(here, relative))
        if os.path.isfile(os.path.join(folder, "shape_views.py")):
            sys.path.insert(0, folder)
            break
    import shape_views
    return shape_views


def plot_curves(ax_var, report):
    history = report["history"]
    initial = report.get("initial") or {}
    rows = ([dict(initial, action=0)] if initial else []) + history

    def series(key, scale=1.0):
        return [(r["action"], scale * r[key]) for r in rows if r.get(key) is not None]

    mesh_var = series("sampled_max_variance")
    if mesh_var:
        ax_var.plot(*zip(*mesh_var), "b.-", label="max variance on the predicted surface")
    planner_var = series("max_evaluated_variance")
    if planner_var:
        ax_var.plot(*zip(*planner_var), "c.:", lw=0.8, label="planner's estimate before the action")
    ax_var.axhline(report["settings"]["v_max"], color="b", ls="--", lw=0.8, label="V_max")
    ax_var.set_xlabel("actions")
    ax_var.set_ylabel("variance", color="b")
    ax_var.set_yscale("log")
    to_truth = series("rmse_pred_to_gt_m", 1000.0)
    from_truth = series("rmse_gt_to_pred_m", 1000.0)
    if to_truth:
        ax_err = ax_var.twinx()
        ax_err.plot(*zip(*to_truth), "r.-", label="RMSE pred->truth")
        ax_err.plot(*zip(*from_truth), "m.-", label="RMSE truth->pred")
        ax_err.set_ylabel("shape RMSE (mm)", color="r")
        ax_err.legend(loc="upper right", fontsize=8)
    ax_var.legend(loc="upper left", fontsize=8)
    ax_var.set_title(f"{report['settings']['strategy']}: {report['stop_reason']} after {report['actions']} actions")


def contact_points(report):
    """Every contact the model took, N x 3 in metres (reports older than contact_points: none)."""
    points = [p for r in report["history"] for p in r.get("contact_points", [])]
    return np.array(points, dtype=float).reshape(-1, 3)


def shape_caption(report):
    metrics = report.get("final_metrics") or {}
    parts = []
    if metrics.get("fscore_5mm") is not None:
        parts.append(f"F@5mm {metrics['fscore_5mm']:.2f}")
    if metrics.get("rmse_gt_to_pred_m") is not None:
        parts.append(f"RMSE truth->pred {1000 * metrics['rmse_gt_to_pred_m']:.1f} mm")
    if metrics.get("position_sd_m") is not None:
        parts.append(f"median position sd on the truth {1000 * metrics['position_sd_m']:.1f} mm")
    return ", ".join(parts)


def main(results_dir):
    report = json.load(open(os.path.join(results_dir, "report.json")))
    surface = os.path.join(results_dir, "surface.ply")
    if not os.path.isfile(surface):
        fig, ax_var = plt.subplots(figsize=(7, 4))
        plot_curves(ax_var, report)
        fig.tight_layout()
    else:
        views = import_shape_views()
        fig = plt.figure(figsize=(12, 8))
        grid = fig.add_gridspec(2, 3, height_ratios=[1.0, 1.3])
        ax_var = fig.add_subplot(grid[0, :])
        plot_curves(ax_var, report)
        shape_axes = [fig.add_subplot(grid[1, k]) for k in range(3)]
        truth = os.path.join(results_dir, "truth.ply")
        predicted, sd_mm, truth_points = views.load_shape(surface, truth if os.path.isfile(truth) else None)
        mappable = views.draw_views(shape_axes, predicted, sd_mm, truth_points, contact_points(report))
        fig.tight_layout(rect=(0, 0.03, 0.96, 1))
        views.add_colour_bar(fig, mappable, shape_axes)
        caption = shape_caption(report)
        fig.text(0.01, 0.01, views.LEGEND + ("; " + caption if caption else ""), fontsize=8)
    out = os.path.join(results_dir, "exploration.png")
    fig.savefig(out, dpi=90)
    print(out)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: plot_exploration.py RESULTS_DIR")
    main(sys.argv[1])
