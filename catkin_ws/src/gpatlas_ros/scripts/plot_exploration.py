#!/usr/bin/env python3
"""Plots an exploration's report.json: the largest surface variance and the shape error (when a
ground truth was known) against the number of actions. Writes exploration.png beside it."""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(results_dir):
    report = json.load(open(os.path.join(results_dir, "report.json")))
    history = report["history"]
    initial = report.get("initial") or {}
    rows = ([dict(initial, action=0)] if initial else []) + history

    def series(key, scale=1.0):
        return [(r["action"], scale * r[key]) for r in rows if r.get(key) is not None]

    fig, ax_var = plt.subplots(figsize=(7, 4))
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
    fig.tight_layout()
    out = os.path.join(results_dir, "exploration.png")
    fig.savefig(out, dpi=90)
    print(out)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: plot_exploration.py RESULTS_DIR")
    main(sys.argv[1])
