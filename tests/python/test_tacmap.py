"""Tests of tacmap's Python module (python/), run by CTest (label `python`) with the interpreter
the module was built for; PYTHONPATH points at the built module and TACMAP_DATA_DIR at data/.

Each TestCase class is one CTest test (tests/python/CMakeLists.txt). The localization tests use
the bundled gecko (data/gecko) with the simulator, as tests/localizer/test_localizer.cpp does,
so they fail when a binding mixes up rows and columns, x and y, or the motion's frame. All but
one use a fast configuration (SIFT-lite on the shared dense field); TestLocalizerDefaults runs
the defaults.
"""

import math
import os
import tempfile
import threading
import time
import unittest

import numpy as np

import tacmap

DATA = os.environ.get(
    "TACMAP_DATA_DIR",
    os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "data"))
GECKO = os.path.join(DATA, "gecko", "protocol.txt")
SESSION = os.path.join(DATA, "sessions", "replay_demo.session")
VERDICTS = {"localized", "uncertain", "contradicted", "rejected_frame"}

_protocol = None


def gecko():
    """The bundled gecko protocol, loaded once."""
    global _protocol
    if _protocol is None:
        _protocol = tacmap.load_protocol(GECKO)
    return _protocol


def simulator(seed):
    p = gecko()
    return tacmap.Simulator(p.relief_mm(), p.mm_per_px, tacmap.SimulatorParams(seed=seed))


def fast_config(**fields):
    """SIFT-lite on the shared dense field: milliseconds to prepare."""
    return tacmap.LocalizerConfig(model="sift_lite", features="shared_dense", **fields)


def run_sequence(loc, sim, sequence):
    """Touches every step of a gecko sequence; returns the results and the truths."""
    p = gecko()
    results, truths = [], []
    for t, step in enumerate(p.sequences[sequence]):
        truth = p.locations[step.location]
        frame = sim.render(truth[0], truth[1])
        results.append(loc.touch(frame, step.measured_motion if t > 0 else None))
        truths.append(truth)
    return results, truths


class TestLocalizerDefaults(unittest.TestCase):
    """The defaults (classic SIFT, per-window features, latent appearance) on the gecko."""

    def test_localizes_the_gecko_and_says_so(self):
        p = gecko()
        loc = tacmap.Localizer(p.map, p.mm_per_px)
        self.assertEqual(loc.config.model, "classic_sift")
        self.assertAlmostEqual(loc.config.preprocessing.mm_per_px, p.mm_per_px)
        rows, cols = loc.shape
        self.assertGreater(rows * cols, 1000)
        self.assertEqual(loc.window, (18, 42))  # (width, height): 6 x 14 taxels at 3 px each
        localized = 0
        for q in range(2):
            loc.reset()
            self.assertEqual(loc.touches, 0)
            results, truths = run_sequence(loc, simulator(100 + q), q)
            for t, (r, truth) in enumerate(zip(results, truths)):
                self.assertTrue(r.accepted)
                self.assertEqual(r.touches, t + 1)
                self.assertIn(r.verdict, VERDICTS)
                self.assertEqual(r.position_mm.shape, (2,))
                self.assertGreaterEqual(r.probability_within, 0.0)
                self.assertLessEqual(r.probability_within, 1.0 + 1e-9)
                self.assertEqual(len(r.appearance_probability), 2)  # latent by default
            # Tracking is on by default: the first touch takes the whole grid, and a touch
            # once localized the tracked path.
            self.assertEqual(results[0].path, "full (wide support)")
            after = [r.path for prev, r in zip(results, results[1:]) if prev.verdict == "localized"]
            self.assertIn("tracked", after)
            final = results[-1]
            error = np.linalg.norm(final.position_mm - truths[-1])
            self.assertLess(error, 5.0, f"sequence {q}: final error {error:.2f} mm")
            localized += final.verdict == "localized"
            # The gecko's raised parts are bright in its map: "as photographed" wins.
            self.assertGreater(final.appearance_probability[0], 0.9)
            # The belief is a distribution over the grid, and its peak is at the truth: rows
            # are y, columns x, and position_mm maps them back.
            b = loc.belief()
            self.assertEqual(b.shape, loc.shape)
            self.assertEqual(b.dtype, np.float32)
            self.assertAlmostEqual(float(b.sum(dtype=np.float64)), 1.0, places=4)
            peak = np.unravel_index(np.argmax(b), b.shape)
            self.assertLess(np.linalg.norm(loc.position_mm(*peak) - truths[-1]), 5.0)
        self.assertGreaterEqual(localized, 1)
        # extent_mm: the belief pixels' edges, half a pixel around the positions.
        left, right, bottom, top = loc.extent_mm
        half = 0.5 * p.mm_per_px
        np.testing.assert_allclose(loc.position_mm(0, 0), [left + half, top + half])
        np.testing.assert_allclose(loc.position_mm(rows - 1, cols - 1),
                                   [right - half, bottom - half])


class TestOpenSet(unittest.TestCase):
    """P(not this object): the touches weighed against another surface than the map's."""

    @staticmethod
    def blobs(shape, seed):
        rng = np.random.default_rng(seed)
        y, x = np.mgrid[0:shape[0], 0:shape[1]]
        out = np.zeros(shape)
        for _ in range(60):
            cy, cx = rng.uniform(0, shape[0]), rng.uniform(0, shape[1])
            s = rng.uniform(2.0, 6.0)
            out += rng.choice([-1.0, 1.0]) * np.exp(-0.5 * ((y - cy) ** 2 + (x - cx) ** 2) / s**2)
        return out.astype(np.float32)

    def test_rises_on_another_object_and_falls_on_its_own(self):
        p = gecko()
        own = tacmap.Localizer(p.map, p.mm_per_px, fast_config())
        other = tacmap.Localizer(self.blobs(p.map.shape, 11), p.mm_per_px, fast_config())
        on_own, _ = run_sequence(own, simulator(70), 0)
        on_other, _ = run_sequence(other, simulator(70), 0)
        self.assertLess(on_own[-1].probability_other_object, 0.01)
        self.assertEqual(on_own[-1].verdict, "localized")
        self.assertGreater(on_other[-1].probability_other_object, 0.9)
        for r in on_other:
            self.assertNotEqual(r.verdict, "localized")

    def test_prior_is_configured_and_checked(self):
        p = gecko()
        loc = tacmap.Localizer(p.map, p.mm_per_px, fast_config(prior_unknown=0.2))
        self.assertEqual(loc.config.prior_unknown, 0.2)
        results, _ = run_sequence(loc, simulator(71), 0)
        even, _ = run_sequence(tacmap.Localizer(p.map, p.mm_per_px, fast_config()), simulator(71), 0)

        def logit(q):
            return np.log(q) - np.log1p(-q)

        # The touches' evidence is the same whatever the prior: the log odds differ by the prior's.
        for a, b in zip(results, even):
            self.assertAlmostEqual(logit(a.probability_other_object) -
                                   logit(b.probability_other_object), np.log(0.25), places=6)
        for bad in (0.0, 1.0, -0.5, float("nan")):
            with self.assertRaisesRegex(ValueError, "prior_unknown"):
                fast_config(prior_unknown=bad)


class TestLocalizer(unittest.TestCase):
    def test_rejected_frame_keeps_the_count_and_applies_the_motion(self):
        p = gecko()
        loc = tacmap.Localizer(p.map, p.mm_per_px, fast_config())
        ref = tacmap.Localizer(p.map, p.mm_per_px, fast_config())
        sim = simulator(7)
        x, y = p.locations[0]
        frame = sim.render(x, y)
        loc.touch(frame)
        ref.touch(frame)
        r = loc.touch(np.zeros((14, 6)), (3.0, -2.0))
        self.assertEqual(r.verdict, "rejected_frame")
        self.assertEqual(r.rejection, "weak_peak")
        self.assertFalse(r.accepted)
        self.assertEqual(r.touches, 1)
        self.assertEqual(loc.touches, 1)
        # The motion applied: the next touch agrees with one that moved with the frame.
        frame2 = sim.render(x, y)
        a = loc.touch(frame2, (-3.0, 2.0))
        b = ref.touch(frame2, (0.0, 0.0))
        self.assertLess(np.linalg.norm(a.position_mm - b.position_mm), 1.5)

    def test_a_localizer_takes_a_burst_as_one_touch(self):
        p = gecko()
        single = tacmap.Localizer(p.map, p.mm_per_px, fast_config())
        burst = tacmap.Localizer(p.map, p.mm_per_px, fast_config())
        frame = np.asarray(simulator(4).render(*p.locations[1]), dtype=np.float64)
        # A press settling, four settled readings and an outlier: a 3-D array works as well.
        frames = np.stack([frame / 3.0, frame, frame, frame, frame, 2.0 * frame])
        a = single.touch(frame)
        b = burst.touch_burst(frames)
        self.assertEqual(a.frames_combined, 1)
        self.assertEqual(b.frames_combined, 4)
        np.testing.assert_allclose(b.position_mm, a.position_mm)
        np.testing.assert_allclose(burst.belief(), single.belief(), atol=1e-6)
        c = burst.touch_burst(list(frames), (1.0, 0.0))
        self.assertEqual(c.touches, 2)
        with self.assertRaisesRegex(ValueError, "no frames"):
            burst.touch_burst([])
        self.assertEqual(burst.touches, 2)

    def test_next_touch_ranks_candidate_moves_without_changing_the_belief(self):
        p = gecko()
        loc = tacmap.Localizer(p.map, p.mm_per_px, fast_config())
        sim = simulator(6)
        loc.touch(sim.render(*p.locations[0]))
        before = loc.belief()
        xs, ys = np.meshgrid(np.arange(-20.0, 21.0, 10.0), np.arange(-20.0, 21.0, 10.0))
        moves = np.stack([xs.ravel(), ys.ravel()], axis=1)
        r = loc.next_touch(moves, objective="entropy")
        self.assertIsInstance(r, tacmap.NextTouchRanking)
        self.assertEqual(r.score.shape, (25,))
        self.assertEqual(sorted(r.order.tolist()), list(range(25)))
        self.assertEqual(r.best, r.order[0])
        self.assertTrue(np.all(np.diff(r.score[r.order]) <= 0.0))
        self.assertFalse(r.uninformative)
        self.assertGreater(r.hypotheses, 1)
        self.assertTrue(np.all((r.on_map >= 0.0) & (r.on_map <= 1.0)))
        np.testing.assert_array_equal(loc.belief(), before)
        # A list of pairs works as well; the verdict's objective scores probabilities.
        v = loc.next_touch(moves.tolist(), objective="verdict", hypotheses=32)
        self.assertTrue(np.all((v.score >= 0.0) & (v.score <= 1.0 + 1e-9)))
        # The objective is the one asked for (the default is the verdict's).
        np.testing.assert_array_equal(loc.next_touch(moves, hypotheses=32).score, v.score)
        self.assertFalse(np.allclose(loc.next_touch(moves, hypotheses=32,
                                                    objective="entropy").score, v.score))
        # One candidate: nothing to choose between.
        self.assertTrue(loc.next_touch([(1.0, 0.0)]).uninformative)
        with self.assertRaisesRegex(ValueError, "candidate 1 moves .* not finite"):
            loc.next_touch([(1.0, 0.0), (math.nan, 0.0)])
        with self.assertRaisesRegex(ValueError, "candidate 0 moves .* off the map"):
            loc.next_touch([(0.0, 1000.0)])
        with self.assertRaisesRegex(ValueError, "no candidate moves"):
            loc.next_touch(np.zeros((0, 2)))
        with self.assertRaisesRegex(ValueError, "an \\(N, 2\\) array"):
            loc.next_touch([1.0, 2.0, 3.0])
        with self.assertRaisesRegex(ValueError, "objective"):
            loc.next_touch(moves, objective="best")
        np.testing.assert_array_equal(loc.belief(), before)

    def test_frames_as_frame_objects_arrays_and_strided_views_agree(self):
        p = gecko()
        sim = simulator(3)
        x, y = p.locations[2]
        frame = sim.render(x, y)
        self.assertIsInstance(frame, tacmap.Frame)
        self.assertEqual(frame.counts.shape, (14, 6))
        self.assertEqual(frame.counts.dtype, np.float32)
        self.assertEqual(frame.geometry, tacmap.TaxelGeometry())
        variants = [
            frame,
            np.asarray(frame),
            frame.counts.astype(np.float64),
            frame.counts.astype(np.uint16),
            np.asfortranarray(frame.counts),
            np.ascontiguousarray(frame.counts.T).T,  # a transposed view: not C-contiguous
            np.repeat(np.repeat(frame.counts, 2, axis=0), 2, axis=1)[::2, ::2],  # strided
            frame.counts.tolist(),
        ]
        self.assertFalse(variants[5].flags.c_contiguous)
        self.assertFalse(variants[6].flags.c_contiguous)
        positions = []
        for v in variants:
            loc = tacmap.Localizer(p.map, p.mm_per_px, fast_config())
            positions.append(loc.touch(v).position_mm)
        for pos in positions[1:]:
            np.testing.assert_array_equal(pos, positions[0])

    def test_touch_at_turns_poses_into_the_same_odometry(self):
        p = gecko()
        by_motion = tacmap.Localizer(p.map, p.mm_per_px, fast_config())
        by_pose = tacmap.Localizer(p.map, p.mm_per_px, fast_config())
        sim = simulator(3)
        arm = np.array([500.0, -20.0])  # any origin
        for t, step in enumerate(p.sequences[1]):
            x, y = p.locations[step.location]
            frame = sim.render(x, y)
            if t > 0:
                arm = arm + step.measured_motion
            a = by_motion.touch(frame, step.measured_motion if t > 0 else None)
            b = by_pose.touch_at(frame, arm[0], arm[1], 0.01)
            np.testing.assert_allclose(a.position_mm, b.position_mm, atol=1e-9)
        np.testing.assert_allclose(by_motion.belief(), by_pose.belief(), atol=1e-6)
        with self.assertRaisesRegex(ValueError, "headings"):
            by_pose.touch_at(frame, arm[0], arm[1], 0.5)  # turned: breaks the planar model

    def test_unknown_heading_gives_a_belief_per_heading(self):
        p = gecko()
        loc = tacmap.Localizer(p.map, p.mm_per_px, fast_config(headings=4))
        self.assertEqual(loc.headings, 4)
        hb = loc.heading_belief()
        self.assertEqual(hb.shape, (4,) + loc.shape)
        self.assertAlmostEqual(float(hb.sum(dtype=np.float64)), 1.0, places=4)
        self.assertAlmostEqual(loc.heading_rad(1), math.pi / 2)
        with self.assertRaisesRegex(IndexError, "heading_rad: layer 4"):
            loc.heading_rad(4)
        sim = simulator(5)
        x, y = p.locations[0]
        r = loc.touch(sim.render(x, y))
        self.assertIn(r.verdict, VERDICTS)
        np.testing.assert_allclose(loc.heading_belief().sum(axis=0), loc.belief(), atol=1e-6)
        # A map-frame motion means nothing without the heading: refused, naming the fix.
        with self.assertRaisesRegex(ValueError, "sensor_odometry|sensor's frame"):
            loc.touch(sim.render(x, y), (1.0, 0.0))
        loc.touch(sim.render(x, y), (1.0, 0.0, 0.1))  # sensor frame: fine
        planar = tacmap.Localizer(p.map, p.mm_per_px, fast_config())
        self.assertEqual(planar.heading_belief().shape, (1,) + planar.shape)

    def test_verdicts_include_contradicted_after_a_kidnap(self):
        p = gecko()
        loc = tacmap.Localizer(p.map, p.mm_per_px, fast_config(wide_probability=0.0))
        sim = simulator(11)
        results, truths = run_sequence(loc, sim, 0)
        self.assertEqual(results[-1].verdict, "localized")
        last = truths[-1]
        far = max(range(len(p.locations)), key=lambda i: np.linalg.norm(p.locations[i] - last))
        x, y = p.locations[far]
        r = loc.touch(sim.render(x, y), (0.0, 0.0))
        self.assertEqual(r.verdict, "contradicted")
        self.assertLess(r.log_prediction_support, loc.config.confidence.contradiction)

    def test_reset_and_accessors(self):
        p = gecko()
        loc = tacmap.Localizer(p.map, p.mm_per_px, fast_config(), tacmap.TaxelGeometry(14, 6, 3.4))
        x, y = p.locations[0]
        loc.touch(simulator(1).render(x, y))
        self.assertEqual(loc.touches, 1)
        loc.reset()
        self.assertEqual(loc.touches, 0)
        b = loc.belief()
        self.assertAlmostEqual(float(b.max() - b.min()), 0.0, places=7)  # uniform
        np.testing.assert_array_equal(loc.map, p.map)
        self.assertEqual(loc.sensor, tacmap.TaxelGeometry())
        self.assertAlmostEqual(loc.mm_per_px, p.mm_per_px)
        self.assertEqual(loc.map_extent_mm, (0.0, 120 * p.mm_per_px, 120 * p.mm_per_px, 0.0))
        with self.assertRaises(IndexError):
            loc.position_mm(-1, 0)
        self.assertIn("Localizer(", repr(loc))


class TestBadInput(unittest.TestCase):
    """Wrong dtypes, shapes and values raise TypeError or ValueError naming the argument and
    what was expected: never a crash."""

    @classmethod
    def setUpClass(cls):
        p = gecko()
        cls.loc = tacmap.Localizer(p.map, p.mm_per_px, fast_config())
        x, y = p.locations[0]
        cls.frame = simulator(2).render(x, y)

    def test_maps(self):
        p = gecko()
        cfg = fast_config()
        with self.assertRaisesRegex(TypeError, r"map: dtype complex128.*\(rows, cols\)"):
            tacmap.Localizer(p.map.astype(np.complex128), p.mm_per_px, cfg)
        with self.assertRaisesRegex(TypeError, "map: dtype object"):
            tacmap.Localizer(np.array([[1, "a"], [2, 3]], dtype=object), p.mm_per_px, cfg)
        with self.assertRaisesRegex(TypeError, "map: dtype bool"):
            tacmap.Localizer(p.map > 0.5, p.mm_per_px, cfg)
        with self.assertRaisesRegex(TypeError, "map: got str"):
            tacmap.Localizer("gecko.pgm", p.mm_per_px, cfg)
        with self.assertRaisesRegex(ValueError, r"map: a 1-D array of shape \(14400,\).*2-D"):
            tacmap.Localizer(p.map.ravel(), p.mm_per_px, cfg)
        with self.assertRaisesRegex(ValueError, "map: a 3-D array"):
            tacmap.Localizer(np.stack([p.map] * 3, axis=-1), p.mm_per_px, cfg)
        nan_map = p.map.copy()
        nan_map[3, 4] = np.nan
        with self.assertRaisesRegex(ValueError, "map has non-finite pixels"):
            tacmap.Localizer(nan_map, p.mm_per_px, cfg)
        with self.assertRaisesRegex(ValueError, "mm_per_px = -1"):
            tacmap.Localizer(p.map, -1.0, cfg)
        with self.assertRaisesRegex(ValueError, "at least the sensor's size"):
            tacmap.Localizer(np.zeros((10, 10)), p.mm_per_px, cfg)
        with self.assertRaisesRegex(ValueError, "map is empty"):
            tacmap.Localizer(np.zeros((0, 0)), p.mm_per_px, cfg)
        # A strided view of a map is copied, not refused.
        big = np.repeat(np.repeat(p.map, 2, axis=0), 2, axis=1)
        loc = tacmap.Localizer(big[::2, ::2], p.mm_per_px, cfg)
        np.testing.assert_array_equal(loc.map, p.map)

    def test_frames(self):
        loc, counts = self.loc, self.frame.counts
        with self.assertRaisesRegex(ValueError, r"frame: shape \(6, 14\); expected \(14, 6\)"):
            loc.touch(counts.T)
        with self.assertRaisesRegex(ValueError, r"frame: a 1-D array of shape \(84,\)"):
            loc.touch(counts.ravel())
        with self.assertRaisesRegex(TypeError, "frame: dtype complex"):
            loc.touch(counts + 1j)
        with self.assertRaisesRegex(TypeError, "frame: dtype object"):
            loc.touch(np.full((14, 6), None))
        with self.assertRaisesRegex(TypeError, "frame: got NoneType"):
            loc.touch(None)
        with self.assertRaisesRegex(ValueError, r"frame: shape \(7, 3\)"):
            loc.touch(counts[::2, ::2])  # a strided view of the wrong shape
        bad = counts.copy()
        bad[2, 3] = np.nan
        with self.assertRaisesRegex(ValueError, r"taxel \(2, 3\)"):
            loc.touch(bad)
        bad[2, 3] = -5
        with self.assertRaisesRegex(ValueError, "non-negative"):
            loc.touch(bad)
        other = tacmap.Frame(np.ones((10, 4)) * 1000)
        with self.assertRaisesRegex(ValueError, "10 x 4 taxels"):
            loc.touch(other)
        with self.assertRaisesRegex(ValueError, "Frame.counts: shape"):
            self.frame.counts = np.zeros((3, 3))
        with self.assertRaisesRegex(ValueError, "geometry and pitch_mm"):
            tacmap.Frame(counts, pitch_mm=3.4, geometry=tacmap.TaxelGeometry())

    def test_motions(self):
        loc, frame = self.loc, self.frame
        with self.assertRaisesRegex(ValueError, r"moved: 4 values.*\(dx_mm, dy_mm\)"):
            loc.touch(frame, (1, 2, 3, 4))
        with self.assertRaisesRegex(TypeError, "moved: got str"):
            loc.touch(frame, "up")
        with self.assertRaisesRegex(TypeError, "moved: got float"):
            loc.touch(frame, 1.0)
        with self.assertRaisesRegex(TypeError, "moved: element 1 = 'x' is not a number"):
            loc.touch(frame, (1.0, "x"))
        with self.assertRaisesRegex(ValueError, "not finite"):
            loc.touch(frame, (math.nan, 0.0))
        with self.assertRaisesRegex(ValueError, "turned by 0.2 rad"):
            loc.touch(frame, (0.0, 0.0, 0.2))
        with self.assertRaisesRegex(ValueError, "not finite"):
            loc.touch_at(frame, math.inf, 0.0)

    def test_configurations(self):
        with self.assertRaisesRegex(ValueError, "LocalizerConfig.model = 'sift'; expected "
                                    "'sift_lite', 'classic_sift' or 'ncc'"):
            tacmap.LocalizerConfig(model="sift")
        cfg = tacmap.LocalizerConfig()
        with self.assertRaisesRegex(ValueError, "LocalizerConfig.appearance = 'inverted'"):
            cfg.appearance = "inverted"
        with self.assertRaisesRegex(ValueError, "motion_sigma_mm = -1"):
            tacmap.LocalizerConfig(motion_sigma_mm=-1.0)
        with self.assertRaisesRegex(TypeError, "motion_k = '8' has the wrong type"):
            tacmap.LocalizerConfig(motion_k="8")
        with self.assertRaisesRegex(TypeError, "unknown field 'sigma'"):
            tacmap.LocalizerConfig(sigma=1.0)
        with self.assertRaisesRegex(ValueError, "appearance_switch = 0.1 needs appearance"):
            tacmap.LocalizerConfig(appearance="fixed", appearance_switch=0.1)
        with self.assertRaisesRegex(ValueError, "threshold = 2"):
            tacmap.ConfidenceParams(threshold=2.0)
        cfg.motion_k = 0  # attributes are checked when the configuration is used
        p = gecko()
        with self.assertRaisesRegex(ValueError, "motion_k = 0"):
            tacmap.Localizer(p.map, p.mm_per_px, cfg)
        with self.assertRaisesRegex(ValueError, "headings = 4.*ncc"):
            tacmap.Localizer(p.map, p.mm_per_px, tacmap.LocalizerConfig(model="ncc", headings=4))
        with self.assertRaises(TypeError):
            tacmap.Localizer(p.map, p.mm_per_px, config="fast")

    def test_files_simulator_and_experiment(self):
        with self.assertRaisesRegex(ValueError, "cannot open"):
            tacmap.read_pgm(os.path.join(DATA, "no_such_map.pgm"))
        with self.assertRaisesRegex(ValueError, "load_protocol"):
            tacmap.load_protocol(os.path.join(DATA, "no_such_protocol.txt"))
        with self.assertRaises(tacmap.SessionLogError) as caught:
            tacmap.SessionReader(os.path.join(DATA, "no_such.session"))
        self.assertIsInstance(caught.exception, RuntimeError)
        self.assertEqual(caught.exception.line, 0)
        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, "bad.session")
            with open(path, "w") as f:
                f.write("tacmap-session 1\ngeometry 14 6 3.4\nframe 0 0 1 2 3\n")
            log = tacmap.SessionReader(path)
            with self.assertRaises(tacmap.SessionLogError) as caught:
                next(log)
            self.assertEqual(caught.exception.line, 3)
        sim = simulator(1)
        with self.assertRaisesRegex(ValueError, "outside the map's extent"):
            sim.render(1.0, 1.0)
        with self.assertRaisesRegex(ValueError, "noise_counts = -1"):
            tacmap.SimulatorParams(noise_counts=-1.0)
        with self.assertRaisesRegex(ValueError, "ScenarioParams.polarity = 'grey'"):
            tacmap.ScenarioParams(polarity="grey")
        with self.assertRaisesRegex(ValueError, "ExplorationFaults.oracle = 'always'"):
            tacmap.ExplorationFaults(oracle="always")
        told = tacmap.ExplorationFaults(outlier_probability=0.1, oracle="told")
        self.assertEqual(told.oracle, "told")
        with self.assertRaisesRegex(ValueError, "broad_probability = 0.95"):
            tacmap.LocalizerConfig(broad_probability=0.95).validate()
        experiment = tacmap.Experiment(gecko(), fast_config())
        with self.assertRaisesRegex(ValueError, "sequence 99 does not exist"):
            experiment.run(99)
        with self.assertRaisesRegex(ValueError, "sequence = -1"):
            experiment.run(-1)
        with self.assertRaisesRegex(TypeError, "Experiment: config is a str"):
            tacmap.Experiment(gecko(), "fast")
        with self.assertRaisesRegex(ValueError, "patch_size = 17"):
            tacmap.SiftLite(patch_size=17)
        with self.assertRaisesRegex(ValueError, "smaller than"):
            tacmap.SiftLite().compute(np.zeros((5, 5)))
        with self.assertRaisesRegex(TypeError, "SiftLite.compute: image: dtype complex"):
            tacmap.SiftLite().compute(np.zeros((30, 30), dtype=np.complex64))


class TestThreads(unittest.TestCase):
    def test_the_gil_is_released_while_a_map_is_prepared(self):
        # The defaults' per-window descriptors take a few tenths of a second per map. If the GIL
        # were held, this thread could not run Python code meanwhile: its loop would stall for
        # the whole preparation.
        p = gecko()
        durations = []

        def prepare():
            for _ in range(2):
                start = time.perf_counter()
                tacmap.Localizer(p.map, p.mm_per_px)
                durations.append(time.perf_counter() - start)

        worker = threading.Thread(target=prepare)
        ticks = []
        worker.start()
        while worker.is_alive():
            ticks.append(time.perf_counter())
            sum(range(200))  # some Python work
        worker.join()
        gaps = np.diff(ticks)
        self.assertGreater(len(ticks), 100)
        self.assertLess(gaps.max(), 0.5 * min(durations),
                        f"the main thread stalled {gaps.max():.3f} s while a map took "
                        f"{min(durations):.3f} s: is the GIL held?")

    def test_two_localizers_in_two_threads(self):
        p = gecko()
        expected = {}
        for q in range(2):
            loc = tacmap.Localizer(p.map, p.mm_per_px, fast_config())
            expected[q] = run_sequence(loc, simulator(20 + q), q)[0][-1].position_mm
        got, errors = {}, []

        def work(q):
            try:
                loc = tacmap.Localizer(p.map, p.mm_per_px, fast_config())
                for _ in range(3):
                    loc.reset()
                    got[q] = run_sequence(loc, simulator(20 + q), q)[0][-1].position_mm
            except Exception as e:  # reported below: a thread's exception is otherwise lost
                errors.append(e)

        threads = [threading.Thread(target=work, args=(q,)) for q in range(2)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(60)
        self.assertEqual(errors, [])
        for q in range(2):
            np.testing.assert_array_equal(got[q], expected[q])

    def test_one_localizer_shared_by_threads_is_serialised(self):
        p = gecko()
        loc = tacmap.Localizer(p.map, p.mm_per_px, fast_config())
        x, y = p.locations[0]
        frames = [simulator(30 + k).render(x, y) for k in range(4)]
        errors = []

        def work(frame):
            try:
                for _ in range(5):
                    loc.touch(frame, (0.0, 0.0))
                    loc.belief()
            except Exception as e:
                errors.append(e)

        threads = [threading.Thread(target=work, args=(f,)) for f in frames]
        for t in threads:
            t.start()
        for t in threads:
            t.join(60)
        self.assertEqual(errors, [])
        self.assertEqual(loc.touches, 20)


class TestSimulation(unittest.TestCase):
    def test_simulator_frames(self):
        p = gecko()
        x, y = p.locations[3]
        a, b = simulator(9), simulator(9)
        f1, f2 = a.render(x, y), b.render(x, y)
        np.testing.assert_array_equal(f1.counts, f2.counts)  # deterministic
        self.assertGreater(f1.counts.max(), 1000)
        f3 = a.render(x, y)
        self.assertEqual(f3.sequence, f1.sequence + 1)
        self.assertEqual(f3.timestamp_ns - f1.timestamp_ns, 10_000_000)
        self.assertTrue(a.fits(x, y))
        self.assertFalse(a.fits(0.0, 0.0))
        self.assertEqual(a.map_size, (120, 120))
        self.assertEqual(a.expected_counts(x, y).shape, (14, 6))
        self.assertEqual(a.dead_taxels.dtype, np.bool_)
        # The counts view writes through; a Frame from an array round-trips.
        f1.counts[0, 0] = 7.0
        self.assertEqual(np.asarray(f1)[0, 0], 7.0)
        g = tacmap.Frame(f1.counts, timestamp_ns=5, sequence=3)
        self.assertEqual((g.timestamp_ns, g.sequence, g.geometry), (5, 3, tacmap.TaxelGeometry()))
        relief = tacmap.relief_from_image(p.map)
        np.testing.assert_array_equal(relief, p.relief_mm())
        self.assertEqual(float(relief.max()), 4.0)

    def test_a_press_read_as_a_burst(self):
        p = gecko()
        x, y = p.locations[3]
        # One frame per press: exactly render.
        one = simulator(9).render_press(x, y)
        self.assertEqual(len(one), 1)
        np.testing.assert_array_equal(one[0].counts, simulator(9).render(x, y).counts)
        # Twenty: each frame its own noise, the first ones under-pressed; combine_burst drops them.
        params = tacmap.SimulatorParams(seed=9, frames_per_press=20)
        self.assertEqual((params.settle_start, params.settle_frames), (0.5, 2.0))
        burst = tacmap.Simulator(p.relief_mm(), p.mm_per_px, params).render_press(x, y)
        self.assertEqual(len(burst), 20)
        self.assertLess(burst[0].counts.sum(), 0.8 * burst[-1].counts.sum())
        self.assertFalse(np.array_equal(burst[-1].counts, burst[-2].counts))
        combined = tacmap.combine_burst(burst)
        self.assertEqual(combined.status[0], "settling")
        self.assertLess(combined.used, 20)
        with self.assertRaisesRegex(ValueError, "frames_per_press = 0"):
            tacmap.Simulator(p.relief_mm(), p.mm_per_px, tacmap.SimulatorParams(frames_per_press=0))
        # Bumps: outlier frames; the frames not bumped read as without them.
        bumpy = tacmap.SimulatorParams(seed=9, frames_per_press=20, bump_probability=0.3)
        self.assertEqual((bumpy.bump_depth_spread, bumpy.bump_shift_mm), (0.6, 1.7))
        shaken = tacmap.Simulator(p.relief_mm(), p.mm_per_px, bumpy).render_press(x, y)
        same = [np.array_equal(a.counts, b.counts) for a, b in zip(burst, shaken)]
        self.assertTrue(same[0])
        self.assertIn(False, same)
        self.assertGreater(same.count(True), 5)
        with self.assertRaisesRegex(ValueError, "bump_probability = 2"):
            tacmap.Simulator(p.relief_mm(), p.mm_per_px, tacmap.SimulatorParams(bump_probability=2))

    def test_an_experiment_keeps_its_protocol_alive(self):
        protocol = tacmap.load_protocol(GECKO)
        experiment = tacmap.Experiment(protocol, fast_config())
        del protocol
        import gc
        gc.collect()
        self.assertEqual(len(experiment.run(2).touches), len(gecko().sequences[2]))

    def test_scenarios(self):
        r = tacmap.ScenarioParams.realistic()
        self.assertEqual(r.polarity, "bright")
        self.assertTrue(r.changes_map() and r.moves_sensor())
        self.assertEqual(tacmap.ScenarioParams.unknown_object().polarity, "random")
        self.assertFalse(tacmap.ScenarioParams().changes_map())
        s = tacmap.realistic_sensor()
        self.assertEqual(s.noise_counts, 40.0)
        self.assertEqual(s.geometry, tacmap.TaxelGeometry())

    def test_experiment_on_the_gecko(self):
        p = gecko()
        config = tacmap.LocalizationConfig(model="sift_lite", features="shared_dense",
                                           simulator_seed=3)
        self.assertIsInstance(config, tacmap.LocalizerConfig)
        experiment = tacmap.Experiment(p, config)
        self.assertEqual(experiment.config.model, "sift_lite")
        result = experiment.run(0, keep_images=True)
        self.assertEqual(len(result.touches), len(p.sequences[0]))
        self.assertEqual(len(result.beliefs), len(result.touches))
        left, right, bottom, top = experiment.extent_mm
        self.assertAlmostEqual((right - left) / p.mm_per_px, 103)
        self.assertAlmostEqual((bottom - top) / p.mm_per_px, 79)
        self.assertEqual(result.beliefs[0].shape, (79, 103))
        self.assertAlmostEqual(float(result.beliefs[-1].sum(dtype=np.float64)), 1.0, places=4)
        self.assertEqual(result.tactile_images[0].shape, (42, 18))
        last = result.touches[-1]
        np.testing.assert_allclose([last.true_x_mm, last.true_y_mm],
                                   p.locations[p.sequences[0][-1].location])
        self.assertLess(last.error_mm, 5.0)
        self.assertTrue(result.localized())
        self.assertIsNotNone(result.touches_to_localize())
        self.assertEqual(result.errors_mm.shape, (len(result.touches),))
        self.assertIn(last.verdict, VERDICTS)
        # A LocalizerConfig is accepted too (the simulated world's defaults around it), and the
        # realistic scenario runs.
        realistic = tacmap.LocalizationConfig(
            model="sift_lite", features="shared_dense",
            scenario=tacmap.ScenarioParams.realistic(), simulator=tacmap.realistic_sensor())
        results = [tacmap.Experiment(p, fast_config()).run(1),
                   tacmap.Experiment(p, realistic).run(1)]
        self.assertEqual(len(tacmap.median_error_per_touch(results)), len(p.sequences[1]))
        self.assertLess(results[0].touches[-1].error_mm, 5.0)


class TestSessionReader(unittest.TestCase):
    def test_replay_demo_session(self):
        log = tacmap.SessionReader(SESSION)
        h = log.header
        self.assertEqual(h.geometry, tacmap.TaxelGeometry(14, 6, 3.4))
        self.assertAlmostEqual(h.mm_per_px, 3.4 / 3.0)
        self.assertEqual(h.map_file, "replay_demo_map.pgm")
        self.assertIsNotNone(h.calibration)
        self.assertIn("source", h.extra)
        self.assertTrue(os.path.exists(log.map_path))
        records = list(log)
        frames = [r for r in records if isinstance(r, tacmap.Frame)]
        poses = [r for r in records if isinstance(r, tacmap.Pose)]
        self.assertEqual(len(frames) + len(poses), len(records))
        self.assertGreater(len(frames), 20)
        self.assertGreater(len(poses), len(frames))
        self.assertEqual(log.stats["frames"], len(frames))
        self.assertEqual(frames[0].counts.shape, (14, 6))
        self.assertEqual([f.sequence for f in frames], list(range(len(frames))))
        self.assertIsNone(log.next())
        # Replay it (as examples/replay_localize.cpp does, with the pose just before each
        # frame): the calibration and odometry_between must be bound the right way round.
        map_ = tacmap.read_pgm(log.map_path)
        loc = tacmap.Localizer(map_, h.mm_per_px,
                               tacmap.LocalizerConfig(model="ncc", appearance="fixed"), h.geometry)
        cal, last, before, errors = h.calibration, None, None, []
        for r in records:
            if isinstance(r, tacmap.Pose):
                before = r
                continue
            if before is None:
                continue
            moved = tacmap.odometry_between(last, before, cal).control() if last else None
            last = before
            result = loc.touch(r, moved)
            if result.accepted:
                errors.append(np.linalg.norm(result.position_mm - cal.to_map_mm(before)))
        self.assertGreater(len(errors), 5)
        self.assertLess(errors[-1], 3.0)


class TestDescriptorsAndImages(unittest.TestCase):
    def test_dense_sift(self):
        img = gecko().map
        lite, classic = tacmap.SiftLite(), tacmap.ClassicSift()
        self.assertEqual((lite.dimension, lite.patch_size, lite.grid_spacing), (32, 18, 9))
        self.assertEqual((classic.dimension, classic.patch_size), (128, 16))
        a = lite.compute(img)
        self.assertEqual(a.shape, (120 - 18 + 1, 120 - 18 + 1, 32))
        self.assertEqual(a.dtype, np.float32)
        self.assertTrue(np.isfinite(a).all())
        self.assertGreater(float(np.abs(a).max()), 0.0)
        b = classic.compute(img)
        self.assertEqual(b.shape, (105, 105, 128))
        self.assertTrue(np.isfinite(b).all())
        # sample() is compute() on the grid; a non-contiguous image is copied, not refused.
        tactile = np.ascontiguousarray(img[:42, :18].T).T
        self.assertFalse(tactile.flags.c_contiguous)
        s = lite.sample(tactile)
        self.assertEqual(s.shape, (3, 1, 32))
        np.testing.assert_allclose(s[1, 0], lite.compute(tactile)[9, 0], atol=1e-5)
        # Each descriptor describes its own patch: (r, c) is the patch at top-left (r, c).
        np.testing.assert_allclose(lite.compute(img[10:40, 20:50])[0, 0], a[10, 20], atol=1e-2)

    def test_image_files(self):
        m = tacmap.read_pgm(os.path.join(DATA, "gecko", "gecko_map.pgm"))
        self.assertEqual(m.shape, (120, 120))
        self.assertEqual(m.dtype, np.float32)
        self.assertTrue(0.0 <= m.min() and m.max() <= 1.0)
        np.testing.assert_array_equal(m, gecko().map)
        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, "x.pgm")
            tacmap.write_pgm(path, m, "a test")
            np.testing.assert_allclose(tacmap.read_pgm(path), m, atol=1 / 255)
            if tacmap.has_image_file:
                np.testing.assert_array_equal(tacmap.load_image(path), tacmap.read_pgm(path))
        self.assertEqual(tacmap.rescale(m, 1.0, 2.0).shape, (60, 60))


class TestDocumentation(unittest.TestCase):
    def test_docstrings_and_reprs(self):
        self.assertIn("Localizer", tacmap.__doc__)
        self.assertIn("touch_at", tacmap.Localizer.__doc__)
        self.assertIn("(dx_mm, dy_mm)", tacmap.Localizer.touch.__doc__)
        self.assertIn("Fields and their defaults", tacmap.LocalizerConfig.__doc__)
        self.assertIn("model = 'classic_sift'", tacmap.LocalizerConfig.__doc__)
        self.assertIn("'sift_lite'", tacmap.LocalizerConfig.model.__doc__)
        self.assertIn("'localized'", tacmap.TouchResult.verdict.__doc__)
        cfg = tacmap.LocalizerConfig.paper()
        # The paper's floats are named: 7-bit storage is the descriptor model's default.
        self.assertEqual(cfg.name(),
                         "sift_lite/all_pairs/inverse/per_window/float32/lost=0/wide=0x3mm/broad=0x10mm")
        self.assertIn("model='sift_lite'", repr(cfg))
        cfg.preprocessing.min_peak = 123.0  # nested parameters are attributes of the config
        self.assertEqual(cfg.preprocessing.min_peak, 123.0)
        every = tacmap.LocalizerConfig(
            model="ncc", pairs="all_pairs", shape="inverse", features="shared_dense", tau=0.2,
            tempering=0.5, motion_sigma_mm=2.0, motion_k=4,
            preprocessing=tacmap.PreprocessParams(min_peak=100.0, resize="nearest"),
            confidence=tacmap.ConfidenceParams(radius_mm=3.0), headings=0, turn_sigma_rad=0.1,
            appearance="latent", appearance_switch=0.1, lost_probability=0.01,
            wide_probability=0.0, wide_sigma_mm=5.0)
        self.assertEqual((every.model, every.tau, every.preprocessing.resize),
                         ("ncc", 0.2, "nearest"))
        self.assertEqual(every.confidence.radius_mm, 3.0)


class TestBurst(unittest.TestCase):
    """combine_burst: several frames of one press combined robustly (tactile/burst.hpp)."""

    @staticmethod
    def blob(scale=1.0):
        r, c = np.mgrid[0:14, 0:6]
        return scale * 2000.0 * np.exp(-0.5 * (((r - 6) / 3.0) ** 2 + ((c - 2.5) / 1.5) ** 2))

    def test_settling_head_and_outliers_are_dropped(self):
        rng = np.random.default_rng(1)
        scales = [0.3, 0.7, 1.0, 1.0, 1.0, 1.6, 1.0, 1.0, 1.0, 1.0]
        frames = [tacmap.Frame(np.clip(self.blob(s) + rng.normal(0, 10, (14, 6)), 0, None))
                  for s in scales]
        out = tacmap.combine_burst(frames)
        self.assertEqual(out.status[:3], ["settling", "settling", "used"])
        self.assertEqual(out.status[5], "outlier")
        self.assertEqual(out.used, 7)
        self.assertLess(np.abs(np.asarray(out.frame) - self.blob()).max(), 30.0)
        self.assertAlmostEqual(out.settled_total / self.blob().sum(), 1.0, delta=0.02)
        self.assertIn("used=7 of 10", repr(out))
        # Plain arrays are taken too; the trimmed mean is the other statistic.
        arrays = [np.asarray(f) for f in frames]
        same = tacmap.combine_burst(arrays, statistic="trimmed_mean", trim_fraction=0.0)
        self.assertEqual(same.status, out.status)
        kept = [a for a, s in zip(arrays, out.status) if s == "used"]
        np.testing.assert_allclose(np.asarray(same.frame), np.mean(kept, axis=0), rtol=1e-5)

    def test_bad_bursts_are_refused(self):
        with self.assertRaisesRegex(ValueError, "the burst has no frames"):
            tacmap.combine_burst([])
        with self.assertRaisesRegex(ValueError, "frame 1 of 2 has geometry 10 x 4"):
            tacmap.combine_burst([tacmap.Frame(self.blob()), tacmap.Frame(np.ones((10, 4)))])
        with self.assertRaisesRegex(ValueError, "statistic = 'mean'"):
            tacmap.combine_burst([self.blob()], statistic="mean")
        with self.assertRaisesRegex(ValueError, "outlier_tolerance"):
            tacmap.combine_burst([self.blob()], settle_tolerance=0.5, outlier_tolerance=0.1)


if __name__ == "__main__":
    unittest.main()
