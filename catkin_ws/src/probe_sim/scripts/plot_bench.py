#!/usr/bin/env python3
"""Plots gpatlas_bench's history.csv: per object, the shape error (RMSE, both directions) and the
largest surface variance against the number of actions, one line per strategy and seed."""
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(out_dir):
    path = os.path.join(out_dir, "history.csv")
    rows = list(csv.DictReader(open(path)))
    objects = sorted({r["object"] for r in rows})
    colours = {}
    for obj in objects:
        fig, (ax_err, ax_var) = plt.subplots(1, 2, figsize=(11, 4))
        runs = {}
        for r in rows:
            if r["object"] == obj:
                runs.setdefault((r["strategy"], r["seed"]), []).append(r)
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
        fig.tight_layout()
        png = os.path.join(out_dir, f"{obj}.png")
        fig.savefig(png, dpi=90)
        plt.close(fig)
        print(f"plot: {png}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: plot_bench.py OUT_DIR")
    main(sys.argv[1])
