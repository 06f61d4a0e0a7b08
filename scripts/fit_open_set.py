#!/usr/bin/env python3
"""Fits the open set's model of an unknown surface (filter/open_set.hpp, eqs. 1 and 2) to simulated runs.

Reads CSVs written by `tacmap-evaluate --library --library-mode M -o FILE.csv` (mode M taken from
each row: closed and own-map sequences touch a mapped object, left-out and wrong-object ones an
unknown one) and prints the parameters that maximise the likelihood of "known" against "unknown"
at every touch of

    log odds(U | z_1..t) = logit(prior) - sum_{s <= t} f_s

with f the touch's log Bayes factor for the maps:
  --model support (eq. 1): f = a (S - d), S the touch's log_prediction_support;
  --model shadow (eq. 2; CSVs written with --unknown-model shadow): f = b (L - L') + c S - m, L the
  touch's predictive log-evidence and L' the shadow filter's (log_shadow_evidence),
by logistic regression on the cumulative sums of the terms (and of 1, the touches). The two
classes are weighed equally, so that the fit's prior is 0.5. A restart (S = -inf) starts the sums
again, as the front doors do; a rejected frame (no update) adds nothing.

--evaluate also replays the verdicts with the fitted (or the given) parameters at --prior, as the
front doors reach them (with_open_set: "localized" needs P(within) x (1 - P(U)) at the
threshold), and prints per mode: false "localized" at any touch (every claim in the left-out and
wrong-object modes; another object or 5 mm off in the others), recognition by touch 4 and a right
"localized" at the last touch.

    scripts/fit_open_set.py closed.csv own-map.csv left-out.csv wrong-object.csv
    scripts/fit_open_set.py --model shadow --evaluate --prior 0.5 *.csv
"""
import argparse
import csv
import math
import sys

import numpy as np

KNOWN = {"closed", "own-map"}
UNKNOWN = {"left-out", "wrong-object"}
THRESHOLD = 0.9  # confidence_params::threshold, the default verdict's


def evidence(row, model):
    """The touch's terms of f under `model` (see the module's docstring), the last one 1."""
    support = float(row["log_prediction_support"])
    if model == "support":
        return np.array([support, 1.0])
    if "log_shadow_evidence" not in row:
        sys.exit("--model shadow needs CSVs written with tacmap-evaluate --unknown-model shadow "
                 "(a log_shadow_evidence column)")
    shadow = float(row["log_marginal_likelihood"]) - float(row["log_shadow_evidence"])
    return np.array([shadow, support, 1.0])


def read_sequences(paths, model):
    """Every sequence: (mode, list of touches), each touch a dict with its terms e (None for a
    rejected frame, "restart" for a restart) and the columns the verdicts need."""
    sequences = []
    for path in paths:
        with open(path, newline="") as f:
            for row in csv.DictReader(f):
                mode = row["mode"]
                if mode not in KNOWN | UNKNOWN:
                    sys.exit(f"{path}: mode '{mode}'; expected one of {sorted(KNOWN | UNKNOWN)}")
                if row["touch"] == "1":
                    sequences.append((mode, []))
                elif not sequences:
                    sys.exit(f"{path}: a sequence starts at touch {row['touch']}; expected 1")
                if math.isinf(float(row["log_prediction_support"])):
                    e = "restart"  # the question starts again
                elif row["objects_evaluated"] == "0":
                    e = None  # a rejected frame: no update
                else:
                    e = evidence(row, model)
                sequences[-1][1].append({
                    "e": e,
                    "claim": row["verdict"] == "localized",
                    "within": float(row["probability_within"]),
                    "right_object": row["decided"] == row["object"],
                    "p_object": float(row["p_true_object"]),
                    "error_mm": float(row["error_mm"]),
                })
    return sequences


def cumulative_rows(sequences, terms):
    """(features, label) per touch: the cumulative sums of the `terms` terms since the last
    restart."""
    x, y = [], []
    for mode, touches in sequences:
        sums = np.zeros(terms)
        for touch in touches:
            if isinstance(touch["e"], str):
                sums = np.zeros(terms)
                continue
            if touch["e"] is not None:
                sums = sums + touch["e"]
            x.append(sums.copy())
            y.append(1.0 if mode in UNKNOWN else 0.0)
    return np.array(x).reshape(-1, terms), np.array(y)


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


def logistic(v):
    return 1.0 / (1.0 + math.exp(-v)) if v >= 0.0 else math.exp(v) / (1.0 + math.exp(v))


def evaluate(sequences, w, prior):
    """Per mode: [sequences, false claims at any touch, recognized by touch 4, right at last],
    with f = the touch's terms . w."""
    out = {}
    start = math.log(prior) - math.log1p(-prior)
    for mode, touches in sequences:
        tally = out.setdefault(mode, [0, 0, 0, 0])
        log_odds = start
        any_false = right_last = recognized = False
        for t, touch in enumerate(touches):
            if isinstance(touch["e"], str):
                log_odds = start
            elif touch["e"] is not None:
                log_odds -= float(touch["e"] @ w)
            known = 1.0 - logistic(log_odds)
            claim = touch["claim"] and touch["within"] * known >= THRESHOLD
            wrong = (mode in UNKNOWN or not touch["right_object"]
                     or not touch["error_mm"] < 5.0)
            any_false = any_false or (claim and wrong)
            if t + 1 == min(4, len(touches)):
                recognized = touch["right_object"] and touch["p_object"] * known > THRESHOLD
            if t + 1 == len(touches):
                right_last = claim and not wrong
        tally[0] += 1
        tally[1] += any_false
        tally[2] += recognized and mode not in UNKNOWN
        tally[3] += right_last
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("csv", nargs="+", help="tacmap-evaluate --library CSVs")
    parser.add_argument("--model", choices=("support", "shadow"), default="support",
                        help="the touch's evidence: its prediction support (eq. 1) or its "
                             "evidence against the shadow filter's (eq. 2)")
    parser.add_argument("--evaluate", action="store_true",
                        help="also replay the verdicts per mode (see above)")
    parser.add_argument("--prior", type=float, default=0.5, help="P(U) for --evaluate")
    parser.add_argument("--weight", type=float,
                        help="a (support) or b (shadow) for --evaluate instead of the fit's")
    parser.add_argument("--support-weight", type=float,
                        help="c (shadow) for --evaluate instead of the fit's")
    parser.add_argument("--margin", type=float,
                        help="d (support) or m (shadow) for --evaluate instead of the fit's")
    args = parser.parse_args()
    if not 0.0 < args.prior < 1.0:
        sys.exit(f"--prior {args.prior}; expected a probability in (0, 1)")
    sequences = read_sequences(args.csv, args.model)
    terms = 2 if args.model == "support" else 3
    x, y = cumulative_rows(sequences, terms)
    if y.sum() == 0 or y.sum() == len(y):
        sys.exit("need touches of both known (closed, own-map) and unknown (left-out, "
                 "wrong-object) sequences")
    w = fit(x, y)
    print(f"touches: {int((1 - y).sum())} known, {int(y.sum())} unknown")
    if args.model == "support":
        a = w[0] if args.weight is None else args.weight
        d = -w[1] / w[0] if args.margin is None else args.margin
        print(f"evidence_weight = {w[0]:.3f}  (a)")
        print(f"support_margin = {-w[1] / w[0]:.3f}  (d, nats)")
        used, shown = np.array([a, -a * d]), f"a = {a:.3f}, d = {d:.3f}"
    else:
        b = w[0] if args.weight is None else args.weight
        c = w[1] if args.support_weight is None else args.support_weight
        m = -w[2] if args.margin is None else args.margin
        print(f"shadow_weight = {w[0]:.3f}  (b)")
        print(f"shadow_support_weight = {w[1]:.3f}  (c)")
        print(f"shadow_margin = {-w[2]:.3f}  (m, nats)")
        used, shown = np.array([b, c, -m]), f"b = {b:.3f}, c = {c:.3f}, m = {m:.3f}"
    if args.evaluate:
        print(f"verdicts at {shown}, prior {args.prior:g}:")
        for mode, (n, false_any, recognized, right) in sorted(evaluate(sequences, used,
                                                                       args.prior).items()):
            print(f"  {mode}: {n} sequences, false 'localized' at any touch "
                  f"{100.0 * false_any / n:.1f} %, recognized by touch 4 "
                  f"{100.0 * recognized / n:.1f} %, right at the last touch "
                  f"{100.0 * right / n:.1f} %")


if __name__ == "__main__":
    main()
