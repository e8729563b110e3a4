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
    actions = [h["action"] for h in history]
    fig, ax_var = plt.subplots(figsize=(7, 4))
    variances = [h["max_surface_variance"] for h in history]
    ax_var.plot(actions, [v if v is not None else float("nan") for v in variances], "b.-", label="max surface variance")
    ax_var.axhline(report["settings"]["v_max"], color="b", ls="--", lw=0.8, label="V_max")
    ax_var.set_xlabel("actions")
    ax_var.set_ylabel("max surface variance", color="b")
    ax_var.set_yscale("log")
    errors = [(h["action"], h["rmse_pred_to_gt_m"], h["rmse_gt_to_pred_m"]) for h in history
              if h["rmse_pred_to_gt_m"] is not None]
    if errors:
        ax_err = ax_var.twinx()
        ax_err.plot([e[0] for e in errors], [1000 * e[1] for e in errors], "r.-", label="RMSE pred->truth")
        ax_err.plot([e[0] for e in errors], [1000 * e[2] for e in errors], "m.-", label="RMSE truth->pred")
        ax_err.set_ylabel("shape RMSE (mm)", color="r")
        ax_err.legend(loc="upper right")
    ax_var.legend(loc="upper left")
    ax_var.set_title(f"{report['settings']['strategy']}: {report['stop_reason']} after {report['actions']} actions")
    fig.tight_layout()
    out = os.path.join(results_dir, "exploration.png")
    fig.savefig(out, dpi=90)
    print(out)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: plot_exploration.py RESULTS_DIR")
    main(sys.argv[1])
