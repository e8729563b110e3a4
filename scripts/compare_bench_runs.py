#!/usr/bin/env python3
"""Compares two gpatlas_bench outputs run for run: the same runs must give the same actions,
contacts, training points and shape errors (a refactoring that changes no behaviour).

    scripts/compare_bench_runs.py BEFORE_DIR AFTER_DIR [--tolerance-m 1e-9]

Each directory holds a bench run's runs.csv. Timing columns are ignored. Exit 1 on a difference.
"""
import argparse
import csv
import os
import sys

KEYS = ("object", "strategy", "probe", "seed")
COMPARED = ("actions", "contacts", "converged", "status", "stop_reason", "n_train",
            "rmse_pred_to_gt_m", "rmse_gt_to_pred_m", "fscore_5mm", "max_evaluated_variance",
            "unreachable_touches", "approach_collisions", "retreat_collisions")


def load(folder):
    with open(os.path.join(folder, "runs.csv"), newline="") as f:
        return {tuple(row[k] for k in KEYS): row for row in csv.DictReader(f)}


def same(a, b, tolerance):
    try:
        return abs(float(a) - float(b)) <= tolerance
    except ValueError:
        return a == b


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("before")
    parser.add_argument("after")
    parser.add_argument("--tolerance-m", type=float, default=1e-9)
    args = parser.parse_args()
    before, after = load(args.before), load(args.after)
    differences = 0
    for key in sorted(set(before) | set(after)):
        if key not in before or key not in after:
            print("only in %s: %s" % ("after" if key in after else "before", " ".join(key)))
            differences += 1
            continue
        for column in COMPARED:
            if column in before[key] and not same(before[key][column], after[key].get(column, ""), args.tolerance_m):
                print("%s: %s %s -> %s" % (" ".join(key), column, before[key][column], after[key].get(column)))
                differences += 1
    print("%d runs compared, %d differences" % (len(set(before) & set(after)), differences))
    return 1 if differences else 0


if __name__ == "__main__":
    sys.exit(main())
