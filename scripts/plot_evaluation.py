#!/usr/bin/python3
"""Figures like the paper's Figs. 6-8 from a tacmap-evaluate CSV.

  scripts/plot_evaluation.py evaluation.csv [--out FOLDER]

Writes, per map in the CSV:
  <map>_error_vs_touch.png      median error per touch with the 25-75 % band, one line per
                                configuration (Fig. 6)
  <map>_final_error_hist.png    histogram of the final (last-touch) errors per configuration (Fig. 7)
  <map>_touches_to_localize.png histogram of touches to localize over the localized sequences (Fig. 8)
Needs python3-matplotlib (Debian; hence /usr/bin/python3, the interpreter it is installed for).
"""
import argparse
import csv
import os
import statistics
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def quantile(values, q):
    values = sorted(values)
    if not values:
        return float("nan")
    pos = q * (len(values) - 1)
    lo = int(pos)
    hi = min(lo + 1, len(values) - 1)
    return values[lo] + (values[hi] - values[lo]) * (pos - lo)


def load(path):
    # runs[map][config][sequence] = list of rows in touch order; scenarios[map] = the simulation
    # scenarios its rows were run in (CSV column "scenario"; older CSVs have none)
    runs = defaultdict(lambda: defaultdict(lambda: defaultdict(list)))
    scenarios = defaultdict(set)
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        needed = {"map", "config", "sequence", "touch", "error_mm", "localized", "touches_to_localize"}
        missing = needed - set(reader.fieldnames or [])
        if missing:
            sys.exit(f"plot_evaluation: {path} lacks the columns {sorted(missing)}; "
                     "expected a CSV written by tacmap-evaluate")
        for row in reader:
            runs[row["map"]][row["config"]][int(row["sequence"])].append(row)
            if row.get("scenario"):
                scenarios[row["map"]].add(row["scenario"])
    for configs in runs.values():
        for seqs in configs.values():
            for rows in seqs.values():
                rows.sort(key=lambda r: int(r["touch"]))
    return runs, scenarios


def plot_map(name, configs, out, label=None):
    """`label`: the map's name in titles (default `name`); files are named after `name`."""
    written = []
    title = label or name
    # Fig. 6: error vs touch.
    fig, ax = plt.subplots(figsize=(12, 6))
    colours = plt.get_cmap("tab20")
    # Quartile bands only when few lines: with many configurations they hide each other.
    bands = len(configs) <= 4
    for i, (config, seqs) in enumerate(sorted(configs.items())):
        n_touch = max(len(rows) for rows in seqs.values())
        xs, med, q1, q3 = [], [], [], []
        for t in range(n_touch):
            errs = [float(rows[t]["error_mm"]) for rows in seqs.values() if t < len(rows)]
            xs.append(t + 1)
            med.append(statistics.median(errs))
            q1.append(quantile(errs, 0.25))
            q3.append(quantile(errs, 0.75))
        style = "-" if config.startswith("sift_lite") else ("--" if config.startswith("classic") else ":")
        (line,) = ax.plot(xs, med, marker="o", linestyle=style, linewidth=2,
                          color=colours(i % 20), label=config)
        if bands:
            ax.fill_between(xs, q1, q3, color=line.get_color(), alpha=0.15)
    ax.axhline(5.0, color="k", linestyle="--", linewidth=1, label="5 mm (localized)")
    ax.set_xlabel("touch")
    ax.set_ylabel("error of the MAP estimate (mm)")
    ax.set_title(f"{title}: error per touch (median" + (", 25-75 % band)" if bands else ")"))
    ax.set_yscale("symlog", linthresh=5.0)
    ax.set_ylim(bottom=0.0)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    ax.grid(True, alpha=0.3)
    path = os.path.join(out, f"{name}_error_vs_touch.png")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    written.append(path)

    # Fig. 7: final errors.
    fig, ax = plt.subplots(figsize=(12, 6))
    finals = {c: [float(rows[-1]["error_mm"]) for rows in seqs.values()]
              for c, seqs in sorted(configs.items())}
    top = max(max(v) for v in finals.values())
    bins = [0, 1, 2, 3, 4, 5, 10, 20, 40, max(80.0, top + 1)]
    ax.hist(list(finals.values()), bins=bins, label=list(finals.keys()))
    ax.set_xscale("symlog", linthresh=5.0)
    ax.axvline(5.0, color="k", linestyle="--", linewidth=1)
    ax.set_xlabel("final error (mm)")
    ax.set_ylabel("sequences")
    ax.set_title(f"{title}: final error per sequence")
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    path = os.path.join(out, f"{name}_final_error_hist.png")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    written.append(path)

    # Fig. 8: touches to localize.
    fig, ax = plt.subplots(figsize=(12, 6))
    ttl = {}
    for c, seqs in sorted(configs.items()):
        ttl[c] = [int(rows[0]["touches_to_localize"]) for rows in seqs.values()
                  if rows[0]["localized"] == "1"]
    n_touch = max(len(rows) for seqs in configs.values() for rows in seqs.values())
    ax.hist([v for v in ttl.values()], bins=[t + 0.5 for t in range(n_touch + 1)],
            label=[f"{c} ({len(v)} localized)" for c, v in ttl.items()])
    ax.set_xlabel("touches to localize (error < 5 mm from then on)")
    ax.set_ylabel("sequences")
    ax.set_title(f"{title}: touches to localize (localized sequences)")
    ax.set_xticks(range(1, n_touch + 1))
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    path = os.path.join(out, f"{name}_touches_to_localize.png")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    written.append(path)
    return written


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("csv", help="CSV written by tacmap-evaluate")
    parser.add_argument("--out", default="evaluation-plots", help="output folder")
    parser.add_argument("--config", action="append", default=[],
                        help="plot only configurations containing this text (repeatable)")
    args = parser.parse_args()
    if not os.path.isfile(args.csv):
        sys.exit(f"plot_evaluation: '{args.csv}' does not exist; expected tacmap-evaluate's CSV")
    runs, scenarios = load(args.csv)
    if not runs:
        sys.exit(f"plot_evaluation: '{args.csv}' has no data rows")
    os.makedirs(args.out, exist_ok=True)
    for name, configs in sorted(runs.items()):
        if args.config:
            configs = {c: v for c, v in configs.items() if any(f in c for f in args.config)}
            if not configs:
                sys.exit(f"plot_evaluation: no configuration matches {args.config}")
        label = f"{name} ({', '.join(sorted(scenarios[name]))} scenario)" if scenarios[name] else name
        for path in plot_map(name, configs, args.out, label):
            print(os.path.abspath(path))


if __name__ == "__main__":
    main()
