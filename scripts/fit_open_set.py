#!/usr/bin/env python3
"""Fits the open set's model of an unknown surface (filter/open_set.hpp, eq. 1) to simulated runs.

Reads CSVs written by `tacmap-evaluate --library --library-mode M -o FILE.csv` (mode M taken from
each row: closed and own-map sequences touch a mapped object, left-out and wrong-object ones an
unknown one) and prints the open_set_params that maximise the likelihood of "known" against
"unknown" at every touch:

    log odds(U | z_1..t) = logit(prior) - sum_{s <= t} a * (S_s - d)

with S the touch's log_prediction_support, by logistic regression on the cumulative sums of S and
of 1 (the touches). The two classes are weighed equally, so the fit's prior is 0.5. A restart
(S = -inf) starts the sums again, as the front doors do; a rejected frame (no update) adds
nothing.

    scripts/fit_open_set.py closed.csv own-map.csv left-out.csv wrong-object.csv
"""
import argparse
import csv
import math
import sys

import numpy as np

KNOWN = {"closed", "own-map"}
UNKNOWN = {"left-out", "wrong-object"}


def cumulative_rows(paths):
    """(features, label) per touch: features = cumulative (S, touches)."""
    x, y = [], []
    for path in paths:
        with open(path, newline="") as f:
            sums = None
            for row in csv.DictReader(f):
                mode = row["mode"]
                if mode not in KNOWN | UNKNOWN:
                    sys.exit(f"{path}: mode '{mode}'; expected one of {sorted(KNOWN | UNKNOWN)}")
                if row["touch"] == "1":
                    sums = np.zeros(2)
                support = float(row["log_prediction_support"])
                if math.isinf(support):
                    sums = np.zeros(2)  # a restart: the question starts again
                    continue
                if row["objects_evaluated"] != "0":  # 0: a rejected frame, no update
                    sums = sums + np.array([support, 1.0])
                x.append(sums.copy())
                y.append(1.0 if mode in UNKNOWN else 0.0)
    return np.array(x), np.array(y)


def fit(x, y, l2=1e-8):
    """Weights w of logit P(U) = -x w (class-balanced logistic regression, Newton's method)."""
    weight = np.where(y == 1.0, 0.5 / max(1.0, y.sum()), 0.5 / max(1.0, (1 - y).sum()))
    w = np.zeros(x.shape[1])
    for _ in range(200):
        p = 1.0 / (1.0 + np.exp(x @ w))
        gradient = -x.T @ (weight * (p - y)) + l2 * w
        hessian = (x.T * (weight * p * (1 - p))) @ x + l2 * np.eye(len(w))
        step = np.linalg.solve(hessian, gradient)
        w -= step
        if np.abs(step).max() < 1e-10:
            break
    return w


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("csv", nargs="+", help="tacmap-evaluate --library CSVs")
    args = parser.parse_args()
    x, y = cumulative_rows(args.csv)
    if y.sum() == 0 or y.sum() == len(y):
        sys.exit("need touches of both known (closed, own-map) and unknown (left-out, "
                 "wrong-object) sequences")
    w = fit(x, y)
    a = w[0]
    d = -w[1] / a
    print(f"touches: {int((1 - y).sum())} known, {int(y.sum())} unknown")
    print(f"evidence_weight = {a:.3f}  (a)")
    print(f"support_margin = {d:.3f}  (d, nats)")


if __name__ == "__main__":
    main()
