"""scripts/plot_evaluation.py on a small made-up CSV (headless): every figure is written, and
each configuration has one style in all of them, distinct from every other's.

Run by CTest (tests/io/CMakeLists.txt) with the interpreter python3-matplotlib is installed for.
"""
import csv
import importlib.util
import os
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "..", "scripts", "plot_evaluation.py")

# 17 configurations, as tacmap-evaluate's default cross product names them.
CONFIGS = ([f"classic_sift/{p}/{s}/{f}" for p in ("aligned", "all_pairs")
            for s in ("exponential", "inverse") for f in ("per_window", "shared_dense")]
           + ["ncc"]
           + [f"sift_lite/{p}/{s}/{f}" for p in ("aligned", "all_pairs")
              for s in ("exponential", "inverse") for f in ("per_window", "shared_dense")])


def load_script():
    spec = importlib.util.spec_from_file_location("plot_evaluation", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def write_csv(path, maps, configs):
    fields = ["map", "config", "sequence", "touch", "error_mm", "localized",
              "touches_to_localize", "scenario", "p_within_5mm", "headings"]
    with open(path, "w", newline="") as f:
        out = csv.DictWriter(f, fieldnames=fields)
        out.writeheader()
        for m, map_name in enumerate(maps):
            for c, config in enumerate(configs):
                for seq in range(3):
                    errors = [30.0 - 9.0 * t + (c + seq + m) % 4 for t in range(4)]
                    errors = [max(e, 0.3 * (c % 5)) for e in errors]
                    localized = errors[-1] < 5.0
                    for t, e in enumerate(errors):
                        out.writerow({"map": map_name, "config": config, "sequence": seq,
                                      "touch": t + 1, "error_mm": f"{e:.2f}",
                                      "localized": int(localized),
                                      "touches_to_localize": 4 if localized else 0,
                                      "scenario": "realistic",
                                      "p_within_5mm": f"{min(1.0, 0.25 * (t + 1)):.2f}",
                                      "headings": 0})


class TestPlotEvaluation(unittest.TestCase):
    def test_writes_every_figure(self):
        with tempfile.TemporaryDirectory() as tmp:
            data = os.path.join(tmp, "eval.csv")
            # One map, six configurations (two rows of histogram panels): about 2 s of CPU, cheap
            # enough for every preset; the styles across maps are the test below.
            write_csv(data, ("gecko",), CONFIGS[6:12])
            out = os.path.join(tmp, "plots")
            env = dict(os.environ, MPLBACKEND="Agg")
            run = subprocess.run([sys.executable, SCRIPT, data, "--out", out], env=env,
                                 capture_output=True, text=True, check=False)
            self.assertEqual(run.returncode, 0, run.stderr)
            expected = [f"gecko_{kind}.png"
                        for kind in ("error_vs_touch", "final_error_hist", "touches_to_localize")]
            expected.append("reliability.png")
            for name in expected:
                path = os.path.join(out, name)
                self.assertTrue(os.path.isfile(path), f"{name} not written")
                with open(path, "rb") as f:
                    self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n", name)

    def test_one_distinct_style_per_configuration(self):
        plot = load_script()
        styles = plot.config_styles(CONFIGS + CONFIGS[:5])  # repeats (several maps) collapse
        self.assertEqual(sorted(styles), sorted(CONFIGS))
        looks = {(s["color"], s["marker"], s["linestyle"]) for s in styles.values()}
        self.assertEqual(len(looks), len(CONFIGS), "two configurations look alike")
        # The same names in another order (another map, another CSV) get the same styles.
        self.assertEqual(plot.config_styles(reversed(CONFIGS)), styles)
        # NCC and every classic_sift configuration differ in hue, not only in marker.
        ncc = styles["ncc"]["color"]
        for name in CONFIGS:
            if name.startswith("classic_sift"):
                distance = sum((a - b) ** 2 for a, b in zip(ncc, styles[name]["color"])) ** 0.5
                self.assertGreater(distance, 0.25, f"ncc and {name} have nearly one colour")


if __name__ == "__main__":
    unittest.main()
