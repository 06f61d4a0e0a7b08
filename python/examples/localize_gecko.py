#!/usr/bin/env python3
"""Localize a simulated touch sequence on the bundled gecko with tacmap's Python module, and plot
the belief after every touch.

The paper's experiment (Luo et al., ICRA 2015, Sec. IV; Fig. 5): a 14 x 6 tactile array explores
a 3D-printed gecko in seven touches; a camera image of the gecko is the map. Here the simulator
presses the gecko's relief at the protocol's true locations (data/gecko), and the localizer gets
what a robot would have: the raw frames and the arm's measured motion between touches, never the
truth. It prints one line per touch (the estimate's error, the belief's P(error <= 5 mm), the
verdict) and writes a figure of the map and the belief after each touch.

Run (after `python3 -m pip install .` in a venv, which scripts/python_demo does):
    python3 python/examples/localize_gecko.py [out.png]
Exit status 0 when the final estimate is within 5 mm of the truth.
"""

import argparse
import os
import sys

import numpy as np

import tacmap

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_DATA = os.path.join(HERE, "..", "..", "data")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("output", nargs="?", default="gecko_belief.png",
                        help="the figure to write (PNG; default: gecko_belief.png)")
    parser.add_argument("--sequence", type=int, default=0,
                        help="which of the protocol's 22 sequences to replay (default: 0)")
    parser.add_argument("--seed", type=int, default=1, help="the simulator's seed (default: 1)")
    parser.add_argument("--worn-sensor", action="store_true",
                        help="simulate the realistic scenario's used sensor (realistic_sensor())")
    parser.add_argument("--data", default=DEFAULT_DATA, help="tacmap's data folder")
    args = parser.parse_args()

    try:
        import matplotlib
        matplotlib.use("Agg")  # files only: no display needed
        import matplotlib.pyplot as plt
    except ImportError:
        sys.exit("localize_gecko: matplotlib is missing; install it (Debian: python3-matplotlib)")

    protocol = tacmap.load_protocol(os.path.join(args.data, "gecko", "protocol.txt"))
    if not 0 <= args.sequence < len(protocol.sequences):
        sys.exit(f"localize_gecko: --sequence {args.sequence}; expected 0 .. "
                 f"{len(protocol.sequences) - 1}")
    params = tacmap.SimulatorParams(seed=args.seed)
    if args.worn_sensor:
        params = tacmap.realistic_sensor(params)  # more noise, gain spread, dead taxels
    sim = tacmap.Simulator(protocol.relief_mm(), protocol.mm_per_px, params)
    # The defaults: the best configuration measured (classic SIFT, latent appearance).
    loc = tacmap.Localizer(protocol.map, protocol.mm_per_px)

    # The sensor's footprint on the map, (width, height) mm, drawn at the estimate.
    footprint = np.array([loc.sensor.cols, loc.sensor.rows]) * loc.sensor.pitch_mm
    steps = protocol.sequences[args.sequence]
    # Row 1: the whole map; row 2: 30 x 30 mm around the estimate, where a converged belief's
    # few millimetres are visible.
    fig, axes = plt.subplots(2, len(steps), figsize=(2.4 * len(steps) + 0.8, 5.6), squeeze=False,
                             layout="constrained")
    print(f"gecko, sequence {args.sequence}: {len(steps)} touches, config {loc.config.name()}")
    print("touch  error (mm)  P(within 5 mm)  verdict")
    error = float("inf")
    for t, step in enumerate(steps):
        truth = protocol.locations[step.location]
        frame = sim.render(truth[0], truth[1])  # what the sensor reports at the true location
        # The arm's measured motion since the previous touch (none before the first).
        r = loc.touch(frame, step.measured_motion if t > 0 else None)
        error = float(np.linalg.norm(r.position_mm - truth))
        print(f"{t + 1:5d}  {error:10.2f}  {r.probability_within:14.3f}  {r.verdict}")

        # The belief relative to its peak on a log scale over six decades (a linear scale shows
        # a converged belief as a single dot), in bright colours over the light map; states
        # below a millionth of the peak stay transparent. extent_mm puts both in map millimetres.
        belief = loc.belief()
        relative = np.log10(np.maximum(belief / belief.max(), 1e-30))
        for row, ax in enumerate(axes[:, t]):
            ax.imshow(protocol.map, cmap="gray", vmin=-1.5, vmax=1.2, extent=loc.map_extent_mm)
            shown = ax.imshow(np.ma.masked_less(relative, -6.0), cmap="turbo", vmin=-6.0,
                              vmax=0.0, alpha=0.85, extent=loc.extent_mm)
            ax.add_patch(plt.Rectangle(r.position_mm - footprint / 2, *footprint, fill=False,
                                       edgecolor="black", linewidth=1))
            ax.plot(*truth, "+", color="magenta", markersize=9, markeredgewidth=1.5,
                    label="truth")
            ax.plot(*r.position_mm, "o", color="black", markersize=6, fillstyle="none",
                    label="estimate")
            ax.set_xticks([])
            ax.set_yticks([])
            if row == 1:  # the zoom, in map mm (y down, as the map)
                ax.set_xlim(r.position_mm[0] - 15.0, r.position_mm[0] + 15.0)
                ax.set_ylim(r.position_mm[1] + 15.0, r.position_mm[1] - 15.0)
                ax.set_title("30 x 30 mm around the estimate", fontsize=7)
        axes[0, t].set_title(f"touch {t + 1}: {r.verdict}\nerror {error:.1f} mm", fontsize=8)
    axes[0, 0].legend(loc="lower left", fontsize=6)
    bar = fig.colorbar(shown, ax=axes.ravel().tolist(), shrink=0.6, pad=0.01)
    bar.set_label("belief / its peak (log10)", fontsize=8)
    bar.ax.tick_params(labelsize=7)
    fig.suptitle("tacmap: belief over the sensor's position after each touch (transparent: below "
                 "a millionth of the peak; box: the sensor at the estimate)", fontsize=9)
    fig.savefig(args.output, dpi=100)
    print(f"wrote {args.output}")
    if not error < 5.0:
        print(f"FAILED: final error {error:.2f} mm; expected below 5 mm")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
