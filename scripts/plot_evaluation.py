#!/usr/bin/python3
"""Figures like the paper's Figs. 6-8 from a tacmap-evaluate CSV.

  scripts/plot_evaluation.py evaluation.csv [more.csv ...] [--out FOLDER]

Several CSVs (e.g. one per --seed) are pooled. Writes, per map in the CSVs:
  <map>_error_vs_touch.png      median error per touch with the 25-75 % band, one line per
                                configuration (Fig. 6)
  <map>_final_error_hist.png    histogram of the final (last-touch) errors, one panel per
                                configuration: 1 mm bins from 0 to 20 mm, larger errors counted
                                in the last bin ("> 20") (Fig. 7)
  <map>_touches_to_localize.png histogram of touches to localize over the localized sequences, one
                                panel per configuration (Fig. 8)
and, over all maps, when the CSVs have the belief's claims (tacmap-evaluate since "Confidence"):
  reliability.png               reliability diagram per configuration: the belief's claimed
                                P(error <= 5 mm) against how often the error was <= 5 mm, in 10
                                bins, with the expected calibration error (ECE) in the legend;
                                beside it the same for the heading (pose grids: P(heading error
                                <= 15 degrees)) and the appearance hypothesis, where present
Each configuration keeps one colour, marker and line style in every figure: the styles are
fixed once from the sorted names of all configurations in the CSVs (config_styles).
Needs python3-matplotlib (Debian; hence /usr/bin/python3, the interpreter it is installed for).
"""
import argparse
import csv
import math
import os
import statistics
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402


# 20 colours: tab10's ten hues, then the lighter shade of each (tab20's odd entries), so that
# neighbours in the sorted list of names (e.g. ncc beside classic_sift) get different hues.
_TAB20 = matplotlib.colormaps["tab20"].colors
PALETTE = [_TAB20[2 * i] for i in range(10)] + [_TAB20[2 * i + 1] for i in range(10)]
# A marker cycle of another length (7) than the palette (20): two configurations share colour
# and marker only 140 names apart.
MARKERS = ["o", "s", "^", "D", "v", "P", "X"]


def family_linestyle(config):
    """Line style by descriptor family, a second cue beside the colour."""
    if config.startswith("sift_lite"):
        return "-"
    if config.startswith("classic"):
        return "--"
    if config.startswith("ncc"):
        return ":"
    return "-."


def config_styles(names):
    """One style per configuration: {name: {"color", "marker", "linestyle"}}, from the sorted
    set of `names` (all configurations of all maps), so a configuration looks the same in every
    figure of a run."""
    return {name: {"color": PALETTE[i % len(PALETTE)], "marker": MARKERS[i % len(MARKERS)],
                   "linestyle": family_linestyle(name)}
            for i, name in enumerate(sorted(set(names)))}


def quantile(values, q):
    values = sorted(values)
    if not values:
        return float("nan")
    pos = q * (len(values) - 1)
    lo = int(pos)
    hi = min(lo + 1, len(values) - 1)
    return values[lo] + (values[hi] - values[lo]) * (pos - lo)


def load(paths):
    # runs[map][config][(file, sequence)] = list of rows in touch order; scenarios[map] = the
    # simulation scenarios its rows were run in (CSV column "scenario"; older CSVs have none)
    runs = defaultdict(lambda: defaultdict(lambda: defaultdict(list)))
    scenarios = defaultdict(set)
    for index, path in enumerate(paths):
        load_one(path, index, runs, scenarios)
    for configs in runs.values():
        for seqs in configs.values():
            for rows in seqs.values():
                rows.sort(key=lambda r: int(r["touch"]))
    return runs, scenarios


def load_one(path, index, runs, scenarios):
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        needed = {"map", "config", "sequence", "touch", "error_mm", "localized", "touches_to_localize"}
        missing = needed - set(reader.fieldnames or [])
        if missing:
            sys.exit(f"plot_evaluation: {path} lacks the columns {sorted(missing)}; "
                     "expected a CSV written by tacmap-evaluate")
        for row in reader:
            runs[row["map"]][row["config"]][(index, int(row["sequence"]))].append(row)
            if row.get("scenario"):
                scenarios[row["map"]].add(row["scenario"])


def reliability(claims, bins=10):
    """claims: (probability, outcome) pairs -> (per-bin (mean claim, frequency, count), ECE)."""
    sums = [[0.0, 0.0, 0] for _ in range(bins)]
    for p, ok in claims:
        p = min(max(p, 0.0), 1.0)
        b = min(bins - 1, int(p * bins))
        sums[b][0] += p
        sums[b][1] += 1.0 if ok else 0.0
        sums[b][2] += 1
    points = [(sp / n, so / n, n) for sp, so, n in sums if n]
    ece = sum(abs(mp - fr) * n for mp, fr, n in points) / max(1, len(claims))
    return points, ece


def plot_reliability(runs, out, styles):
    """Reliability diagrams over every map, one line per configuration; None without claims."""
    kinds = {"position": "P(error <= 5 mm)", "heading": "P(heading error <= 15 deg)",
             "appearance": "P(appearance hypothesis)"}
    claims = {k: defaultdict(list) for k in kinds}
    for configs in runs.values():
        for config, seqs in configs.items():
            for rows in seqs.values():
                for r in rows:
                    if not r.get("p_within_5mm"):
                        return None  # an older CSV
                    claims["position"][config].append(
                        (float(r["p_within_5mm"]), float(r["error_mm"]) <= 5.0))
                    if int(r.get("headings") or 0) > 0 and r.get("p_heading"):
                        d = abs(float(r["map_theta_rad"]) - float(r["true_theta_rad"]))
                        d = min(d, 2 * math.pi - d)
                        claims["heading"][config].append(
                            (float(r["p_heading"]), d <= math.radians(15.0)))
                    if r.get("p_inverted"):
                        p_dark = float(r["p_inverted"])
                        said_dark = p_dark > 0.5
                        claims["appearance"][config].append(
                            (p_dark if said_dark else 1.0 - p_dark,
                             said_dark == (r.get("raised_dark") == "1")))
    panels = [k for k in kinds if claims[k]]
    # Legends under the panels, out of the data's way (one line per configuration).
    fig, axes = plt.subplots(1, len(panels), squeeze=False,
                             figsize=(6.5 * len(panels), 6.5 + 0.16 * len(claims["position"])))
    configs = sorted(claims["position"])
    for ax, kind in zip(axes[0], panels):
        ax.plot([0, 1], [0, 1], color="k", linewidth=1, linestyle="--", label="calibrated")
        for config in configs:
            if not claims[kind].get(config):
                continue
            points, ece = reliability(claims[kind][config])
            ax.plot([p[0] for p in points], [p[1] for p in points], **styles[config],
                    label=f"{config}: ECE {100 * ece:.1f} pts ({len(claims[kind][config])})")
        ax.set_xlim(0, 1)
        ax.set_ylim(0, 1)
        ax.set_aspect("equal")
        ax.set_xlabel(f"the belief's claim, {kinds[kind]} (bin mean)")
        ax.set_ylabel("observed frequency")
        ax.set_title(f"reliability: {kind}")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.1))
    path = os.path.join(out, "reliability.png")
    fig.tight_layout()
    fig.savefig(path, dpi=120, bbox_inches="tight")  # "tight": the legends below the panels
    plt.close(fig)
    return path


def small_multiples(count):
    """A figure with one panel per configuration (`count`), up to 4 per row, shared axes."""
    cols = min(4, count)
    rows = math.ceil(count / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols, 2.6 * rows + 0.8), sharex=True,
                             sharey=True, squeeze=False)
    flat = [ax for row in axes for ax in row]
    for ax in flat[count:]:
        ax.set_visible(False)
    return fig, flat[:count]


def label_small_multiples(fig, axes, xlabel, title):
    """Axis labels on the outer panels (x ticks under the lowest panel of every column, also
    above an empty slot), the title above all."""
    cols = axes[0].get_subplotspec().get_gridspec().ncols
    for i, ax in enumerate(axes):
        if i + cols >= len(axes):  # the lowest panel of its column
            ax.xaxis.set_tick_params(labelbottom=True)
            ax.set_xlabel(xlabel)
        if i % cols == 0:
            ax.set_ylabel("sequences")
    fig.suptitle(title)
    fig.tight_layout(rect=(0, 0, 1, 0.97))


def plot_map(name, configs, out, styles, label=None):
    """`label`: the map's name in titles (default `name`); files are named after `name`;
    `styles`: config_styles over every configuration of the run."""
    written = []
    title = label or name
    # Fig. 6: error vs touch.
    fig, ax = plt.subplots(figsize=(12, 6))
    # Quartile bands only when few lines: with many configurations they hide each other.
    bands = len(configs) <= 4
    for config, seqs in sorted(configs.items()):
        n_touch = max(len(rows) for rows in seqs.values())
        xs, med, q1, q3 = [], [], [], []
        for t in range(n_touch):
            errs = [float(rows[t]["error_mm"]) for rows in seqs.values() if t < len(rows)]
            xs.append(t + 1)
            med.append(statistics.median(errs))
            q1.append(quantile(errs, 0.25))
            q3.append(quantile(errs, 0.75))
        ax.plot(xs, med, linewidth=2, label=config, **styles[config])
        if bands:
            ax.fill_between(xs, q1, q3, color=styles[config]["color"], alpha=0.15)
    ax.axhline(5.0, color="k", linestyle="--", linewidth=1, label="5 mm (localized)")
    ax.set_xlabel("touch")
    ax.set_ylabel("error of the estimate (mm; linear to 5, log above)")
    ax.set_title(f"{title}: error per touch (median" + (", 25-75 % band)" if bands else ")"))
    ax.set_yscale("symlog", linthresh=5.0)
    ax.set_ylim(bottom=0.0)
    top = ax.get_ylim()[1]
    ax.set_yticks([t for t in (0, 1, 2, 3, 4, 5, 10, 20, 50, 100, 200) if t <= top])
    ax.yaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
    ax.yaxis.set_minor_locator(matplotlib.ticker.NullLocator())
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    ax.grid(True, alpha=0.3)
    path = os.path.join(out, f"{name}_error_vs_touch.png")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    written.append(path)

    # Fig. 7: final errors, one panel per configuration. Linear 1 mm bins (each bar visible)
    # up to a stated clip: errors above it are counted in the last bin.
    clip = 20.0
    bins = [float(b) for b in range(0, int(clip) + 2)]  # [0, 1), ..., [20, 21): "> 20"
    fig, axes = small_multiples(len(configs))
    for ax, (config, seqs) in zip(axes, sorted(configs.items())):
        finals = [float(rows[-1]["error_mm"]) for rows in seqs.values()]
        ok = sum(1 for e in finals if e < 5.0)
        ax.hist([min(e, clip + 0.5) for e in finals], bins=bins, color=styles[config]["color"],
                edgecolor="black", linewidth=0.5)
        ax.axvline(5.0, color="k", linestyle="--", linewidth=1)
        ax.set_title(f"{config}\n{ok} of {len(finals)} below 5 mm", fontsize=8)
        ax.set_xticks([0, 5, 10, 15, clip + 0.5])
        ax.set_xticklabels(["0", "5", "10", "15", f"> {clip:.0f}"])
        ax.grid(True, axis="y", alpha=0.3)
    label_small_multiples(fig, axes, "final error (mm)",
                          f"{title}: final error per sequence (1 mm bins; errors above "
                          f"{clip:.0f} mm in the last bin; dashed: 5 mm)")
    path = os.path.join(out, f"{name}_final_error_hist.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    written.append(path)

    # Fig. 8: touches to localize, one panel per configuration.
    n_touch = max(len(rows) for seqs in configs.values() for rows in seqs.values())
    fig, axes = small_multiples(len(configs))
    for ax, (config, seqs) in zip(axes, sorted(configs.items())):
        ttl = [int(rows[0]["touches_to_localize"]) for rows in seqs.values()
               if rows[0]["localized"] == "1"]
        ax.hist(ttl, bins=[t + 0.5 for t in range(n_touch + 1)], color=styles[config]["color"],
                edgecolor="black", linewidth=0.5)
        ax.set_title(f"{config}\n{len(ttl)} of {len(seqs)} localized", fontsize=8)
        ax.set_xticks(range(1, n_touch + 1))
        ax.grid(True, axis="y", alpha=0.3)
    label_small_multiples(fig, axes, "touches to localize",
                          f"{title}: touches to localize (error < 5 mm from then on; localized "
                          "sequences only)")
    path = os.path.join(out, f"{name}_touches_to_localize.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    written.append(path)
    return written


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("csv", nargs="+", help="CSV(s) written by tacmap-evaluate (pooled)")
    parser.add_argument("--out", default="evaluation-plots", help="output folder")
    parser.add_argument("--config", action="append", default=[],
                        help="plot only configurations containing this text (repeatable)")
    args = parser.parse_args()
    for path in args.csv:
        if not os.path.isfile(path):
            sys.exit(f"plot_evaluation: '{path}' does not exist; expected tacmap-evaluate's CSV")
    runs, scenarios = load(args.csv)
    if not runs:
        sys.exit(f"plot_evaluation: {args.csv} have no data rows")
    os.makedirs(args.out, exist_ok=True)
    if args.config:
        runs = {m: {c: v for c, v in configs.items() if any(f in c for f in args.config)}
                for m, configs in runs.items()}
        if not any(runs.values()):
            sys.exit(f"plot_evaluation: no configuration matches {args.config}")
    # One style per configuration for every figure, fixed once from all names.
    styles = config_styles(c for configs in runs.values() for c in configs)
    for name, configs in sorted(runs.items()):
        if not configs:
            continue
        label = f"{name} ({', '.join(sorted(scenarios[name]))} scenario)" if scenarios[name] else name
        for path in plot_map(name, configs, args.out, styles, label):
            print(os.path.abspath(path))
    path = plot_reliability(runs, args.out, styles)
    if path:
        print(os.path.abspath(path))


if __name__ == "__main__":
    main()
