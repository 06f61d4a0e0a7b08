"""scripts/fit_open_set.py on small made-up CSVs whose answers are known: the fit recovers the a
and d the touches were drawn with (for each model, from that model's columns only), restarts and
rejected frames are handled as the front doors handle them, the replayed verdicts count false
claims and recognition as tacmap-evaluate does, and bad input is refused with a message.

Run by CTest (tests/evaluation/CMakeLists.txt) with an interpreter that has numpy.
"""
import csv
import importlib.util
import math
import os
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "..", "scripts", "fit_open_set.py")
FIELDS = ["config", "mode", "object", "sequence", "touch", "decided", "p_true_object", "error_mm",
          "probability_within", "verdict", "objects_evaluated", "log_marginal_likelihood",
          "log_prediction_support", "log_shadow_evidence"]


def load_script():
    spec = importlib.util.spec_from_file_location("fit_open_set", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def row(mode, touch, e_support=0.0, e_shadow=0.0, verdict="uncertain", within=0.0,
        decided="a", p_object=0.0, error_mm=1.0, evaluated=1):
    """One touch on object 'a'; the shadow model's evidence e_shadow is L - L' (L = -100)."""
    return {"config": "c", "mode": mode, "object": "a", "sequence": 0, "touch": touch,
            "decided": decided, "p_true_object": p_object, "error_mm": error_mm,
            "probability_within": within, "verdict": verdict, "objects_evaluated": evaluated,
            "log_marginal_likelihood": -100.0, "log_prediction_support": e_support,
            "log_shadow_evidence": -100.0 - e_shadow}


def write(path, rows):
    with open(path, "w", newline="") as f:
        out = csv.DictWriter(f, fieldnames=FIELDS)
        out.writeheader()
        out.writerows(rows)


def calibrated_rows(points):
    """One-touch sequences: for each (f, columns), 400 touches with those columns, of which the
    share of unknown ones is exactly the model's P(U | f) = 1 / (1 + exp(f)). With the f values
    symmetric about 0 both classes are equally many (the class weights change nothing), and the
    maximum-likelihood fit is the model's parameters up to the counts' rounding."""
    rows = []
    for f, columns in points:
        unknown = round(400 / (1.0 + math.exp(f)))
        for k in range(400):
            rows.append(row("left-out" if k < unknown else "closed", 1, **columns))
    return rows


def support_points(a, d):
    """f = a (S - d) on a grid of S symmetric about d; the shadow's columns constant."""
    return [(a * 0.5 * i, {"e_support": d + 0.5 * i}) for i in range(-8, 9)]


def shadow_points(b, c, m):
    """f = b (L - L') + c S - m: at S = -1, 0, 1, L - L' on a grid that puts f symmetric
    about 0."""
    return [(0.5 * i, {"e_support": s, "e_shadow": (0.5 * i + m - c * s) / b})
            for s in (-1.0, 0.0, 1.0) for i in range(-8, 9)]


def run_script(*args):
    return subprocess.run([sys.executable, "-B", SCRIPT, *args], capture_output=True, text=True)


def fitted(stdout):
    """The parameters the script printed, by name."""
    values = {}
    for line in stdout.splitlines():
        if line.startswith(("evidence_weight", "support_margin", "shadow_")):
            name, value = line.split("=")
            values[name.strip()] = float(value.split()[0])
    return values


class TestFit(unittest.TestCase):
    def test_recovers_the_support_model(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "support.csv")
            write(path, calibrated_rows(support_points(0.6, 1.5)))
            r = run_script(path)
            self.assertEqual(r.returncode, 0, r.stderr)
            v = fitted(r.stdout)
            self.assertAlmostEqual(v["evidence_weight"], 0.6, delta=0.02)
            self.assertAlmostEqual(v["support_margin"], 1.5, delta=0.05)

    def test_recovers_the_shadow_model_from_its_own_columns(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "shadow.csv")
            write(path, calibrated_rows(shadow_points(0.8, 0.3, 1.2)))
            r = run_script("--model", "shadow", path)
            self.assertEqual(r.returncode, 0, r.stderr)
            v = fitted(r.stdout)
            self.assertAlmostEqual(v["shadow_weight"], 0.8, delta=0.02)
            self.assertAlmostEqual(v["shadow_support_weight"], 0.3, delta=0.02)
            self.assertAlmostEqual(v["shadow_margin"], 1.2, delta=0.05)
            # The support model sees only S, which alone does not explain the classes.
            r = run_script(path)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertLess(fitted(r.stdout)["evidence_weight"], 0.5)

    def test_restarts_and_rejected_frames(self):
        m = load_script()
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "seq.csv")
            write(path, [row("closed", 1, e_support=2.0), row("closed", 2, evaluated=0),
                         row("closed", 3, e_support=-math.inf), row("closed", 4, e_support=3.0),
                         row("left-out", 1, e_support=-1.0)])
            x, y = m.cumulative_rows(m.read_sequences([path], "support"), 2)
        # Touch 2 was rejected (sums unchanged, a row); touch 3 restarted (no row, sums reset).
        self.assertEqual(x.tolist(), [[2.0, 1.0], [2.0, 1.0], [3.0, 1.0], [-1.0, 1.0]])
        self.assertEqual(y.tolist(), [0.0, 0.0, 0.0, 1.0])

    def test_replayed_verdicts(self):
        m = load_script()
        claim = {"verdict": "localized", "within": 0.99}
        rows = [  # left-out: a claim at touch 2 after strong evidence for the maps: false
            row("left-out", 1, e_support=1.0), row("left-out", 2, e_support=5.0,
                                                   verdict="localized", within=0.99),
            # closed: recognized by touch 4 (P(object) 0.99, evidence enough), claimed rightly
            *[row("closed", t, e_support=3.0, p_object=0.99, **{
                "verdict": claim["verdict"], "within": claim["within"]}) for t in (1, 2, 3, 4)]]
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "verdicts.csv")
            write(path, rows)
            sequences = m.read_sequences([path], "support")
        # a = 1, d = 0, prior 0.5: P(U) after the left-out claim is 1 / (1 + e^6) -> claimed.
        out = m.evaluate(sequences, [1.0, 0.0], 0.5)
        self.assertEqual(out["left-out"], [1, 1, 0, 0])
        self.assertEqual(out["closed"], [1, 0, 1, 1])
        # A margin of 4 nats a touch: the left-out touches give 1 - 4 + 5 - 4 = -2, P(U) 0.88 (no
        # claim); the closed ones -1 a touch, P(U) 0.98 at touch 4 (neither recognized nor right).
        out = m.evaluate(sequences, [1.0, -4.0], 0.5)
        self.assertEqual(out["left-out"], [1, 0, 0, 0])
        self.assertEqual(out["closed"], [1, 0, 0, 0])
        # A claim on the wrong object or 5 mm off is false in a closed library too.
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "wrong.csv")
            write(path, [row("closed", 1, e_support=9.0, verdict="localized", within=0.99,
                             decided="b"),
                         row("closed", 1, e_support=9.0, verdict="localized", within=0.99,
                             error_mm=7.0)])
            self.assertEqual(m.evaluate(m.read_sequences([path], "support"), [1.0, 0.0], 0.5),
                             {"closed": [2, 2, 0, 0]})

    def test_evaluate_prints_each_mode(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "support.csv")
            write(path, calibrated_rows(support_points(0.6, 1.5)))
            r = run_script("--evaluate", "--prior", "0.2", path)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertIn("prior 0.2", r.stdout)
            self.assertIn("closed: ", r.stdout)
            self.assertIn("left-out: ", r.stdout)

    def test_refuses_bad_input(self):
        with tempfile.TemporaryDirectory() as tmp:
            only_known = os.path.join(tmp, "known.csv")
            write(only_known, [row("closed", 1, e_support=1.0)])
            r = run_script(only_known)
            self.assertNotEqual(r.returncode, 0)
            self.assertIn("need touches of both known", r.stderr)
            bad_mode = os.path.join(tmp, "mode.csv")
            write(bad_mode, [row("sideways", 1)])
            r = run_script(bad_mode)
            self.assertNotEqual(r.returncode, 0)
            self.assertIn("mode 'sideways'", r.stderr)
            r = run_script("--evaluate", "--prior", "1.5", only_known)
            self.assertNotEqual(r.returncode, 0)
            self.assertIn("--prior 1.5", r.stderr)
            no_shadow = os.path.join(tmp, "no_shadow.csv")
            with open(no_shadow, "w", newline="") as f:
                out = csv.DictWriter(f, fieldnames=FIELDS[:-1])
                out.writeheader()
                out.writerow({k: v for k, v in row("closed", 1).items()
                              if k != "log_shadow_evidence"})
            r = run_script("--model", "shadow", no_shadow)
            self.assertNotEqual(r.returncode, 0)
            self.assertIn("--unknown-model shadow", r.stderr)


if __name__ == "__main__":
    unittest.main()
