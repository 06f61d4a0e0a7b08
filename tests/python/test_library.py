"""Tests of tacmap's Python LibraryLocalizer and of the configuration's optional parts
(self-calibration, tracking, the slip recheck, the working resolution, bursts), run by CTest as
test_tacmap.py is (one CTest test per TestCase class; tests/python/CMakeLists.txt).

The library is checked against the single-map Localizer on the same touches (a library of one
object runs the same filter), against the simulated truth, and for what only a library has: the
objects' posteriors and P(none of these) sum to 1, the touched object wins, and an object left
out of the library drives P(none of these) up. Small maps and SIFT-lite on the shared dense
field keep each class to seconds.
"""

import math
import threading
import unittest

import numpy as np

import tacmap
import test_tacmap
from test_tacmap import fast_config, gecko, simulator

blobs = test_tacmap.TestOpenSet.blobs


# A library touches as a Localizer does (touch(frame, motion)): the same sequence driver.
library_sequence = test_tacmap.run_sequence


def check_sums(test, r):
    """Every object's posterior and P(none of these) are probabilities summing to 1."""
    test.assertTrue(np.all(r.object_probability >= 0.0))
    test.assertGreaterEqual(r.probability_unknown, 0.0)
    test.assertAlmostEqual(float(r.object_probability.sum()) + r.probability_unknown, 1.0,
                           places=6)
    test.assertEqual(r.object, int(np.argmax(r.object_probability)))


def check_open_set_steps(test, results, config):
    """From the prior, each touch moves the log odds of "none of these" by -a (S - d): the model
    of an unknown surface (a, d: config.unknown_evidence_weight, unknown_support_margin), S the
    touch's reported log_prediction_support."""
    def logit(q):
        return math.log(q) - math.log1p(-q)

    a, d = config.unknown_evidence_weight, config.unknown_support_margin
    before = logit(config.prior_unknown)
    for r in results:
        test.assertFalse(r.restarted)
        after = logit(r.probability_unknown)
        test.assertAlmostEqual(after - before, -a * (r.log_prediction_support - d), places=5)
        before = after


class TestLibraryLocalizer(unittest.TestCase):
    def test_one_object_library_runs_the_localizers_filter(self):
        # A library of one map is the Localizer's filter over one block: the same positions,
        # beliefs, verdicts and P(not this object) touch by touch. A binding that swapped x and
        # y, mixed up the motion or misread the result would part them.
        p = gecko()
        lib = tacmap.LibraryLocalizer([("gecko", p.map, p.mm_per_px)], fast_config())
        # Untracked, as the library's filter is (tracking is the Localizer's alone).
        loc = tacmap.Localizer(p.map, p.mm_per_px, fast_config(tracking=None))
        self.assertEqual(lib.mm_per_px, loc.mm_per_px)
        on_lib, truths = library_sequence(lib, simulator(21), 0)
        on_loc, _ = test_tacmap.run_sequence(loc, simulator(21), 0)
        for a, b in zip(on_lib, on_loc):
            check_sums(self, a)
            self.assertEqual((a.object, a.object_name), (0, "gecko"))
            np.testing.assert_allclose(a.position_mm, b.position_mm, atol=1e-6)
            self.assertAlmostEqual(a.probability_unknown, b.probability_other_object, places=6)
            self.assertAlmostEqual(a.probability_within,
                                   (1.0 - b.probability_other_object) * b.probability_within,
                                   places=5)
            self.assertEqual(a.verdict, b.verdict)
            np.testing.assert_allclose(a.appearance_probability, b.appearance_probability,
                                       atol=1e-6)
            self.assertEqual(a.touches, b.touches)
        np.testing.assert_allclose(lib.object_belief(0), loc.belief(), atol=1e-6)
        np.testing.assert_allclose(lib.object_belief("gecko"), loc.belief(), atol=1e-6)
        self.assertEqual(lib.object_extent_mm(0), loc.extent_mm)
        self.assertLess(np.linalg.norm(on_lib[-1].position_mm - truths[-1]), 5.0)
        self.assertEqual(on_lib[-1].verdict, "localized")

    def test_the_touched_object_wins_in_either_order(self):
        p = gecko()
        decoys = [("blobs a", blobs(p.map.shape, 3), p.mm_per_px),
                  ("blobs b", blobs(p.map.shape, 4), p.mm_per_px)]
        for k in (0, 2):  # the gecko first, then last: the names and order are kept
            maps = decoys[:k] + [("gecko", p.map, p.mm_per_px)] + decoys[k:]
            lib = tacmap.LibraryLocalizer(maps, fast_config())
            self.assertEqual(lib.names, [m[0] for m in maps])
            results, truths = library_sequence(lib, simulator(30), 1)
            # Each touch moves the log odds of "none of these" by -a (S - d) (the fitted
            # model of an unknown surface), S the touch's reported support.
            check_open_set_steps(self, results, fast_config())
            for r in results:
                check_sums(self, r)
            last = results[-1]
            self.assertEqual((last.object, last.object_name), (k, "gecko"))
            self.assertGreater(last.object_probability[k], 0.95)
            self.assertLess(last.probability_unknown, 0.05)
            self.assertLess(np.linalg.norm(last.position_mm - truths[-1]), 5.0)
            self.assertEqual(last.verdict, "localized")
            self.assertEqual(lib.probability_unknown, last.probability_unknown)
        # A dict names the objects too, in its order.
        d = tacmap.LibraryLocalizer({"gecko": (p.map, p.mm_per_px),
                                     "blobs a": decoys[0][1:]}, fast_config())
        self.assertEqual(d.names, ["gecko", "blobs a"])
        self.assertEqual(library_sequence(d, simulator(30), 1)[0][-1].object_name, "gecko")

    def test_an_object_left_out_is_none_of_these(self):
        # The gecko touched, but only other objects in the library: P(none of these) rises and
        # the library never claims "localized".
        p = gecko()
        lib = tacmap.LibraryLocalizer([("blobs a", blobs(p.map.shape, 5), p.mm_per_px),
                                       ("blobs b", blobs(p.map.shape, 6), p.mm_per_px)],
                                      fast_config())
        results, _ = library_sequence(lib, simulator(31), 0)
        for r in results:
            check_sums(self, r)
            self.assertNotEqual(r.verdict, "localized")
        self.assertGreater(results[-1].probability_unknown, 0.9)
        # The prior is configured: the first touch starts from it.
        config = fast_config(prior_unknown=0.2)
        lib = tacmap.LibraryLocalizer([("gecko", p.map, p.mm_per_px)], config)
        r = lib.touch(simulator(31).render(*p.locations[0]))
        check_open_set_steps(self, [r], config)
        # The memoryless model (a = 1, d = 0): a first touch's uniform prediction leaves it.
        config = fast_config(prior_unknown=0.2, unknown_evidence_weight=1.0,
                             unknown_support_margin=0.0)
        self.assertEqual((config.unknown_evidence_weight, config.unknown_support_margin),
                         (1.0, 0.0))
        lib = tacmap.LibraryLocalizer([("gecko", p.map, p.mm_per_px)], config)
        r = lib.touch(simulator(31).render(*p.locations[0]))
        check_open_set_steps(self, [r], config)
        # Object priors are taken (and, normalised, checked by the C++ library).
        lib = tacmap.LibraryLocalizer([("gecko", p.map, p.mm_per_px),
                                       ("blobs", blobs(p.map.shape, 5), p.mm_per_px)],
                                      fast_config(), prior=[0.9, 0.1])
        np.testing.assert_allclose(lib.touch(np.zeros((14, 6))).object_probability,
                                   [0.45, 0.05], atol=1e-6)

    def test_the_shadow_model(self):
        # unknown_model 'shadow': a second filter over the mirrored maps weighs each touch. The
        # gecko left out of the library: P(none of these) rises, no claim; in it: P falls.
        p = gecko()
        config = fast_config(unknown_model="shadow")
        self.assertEqual(config.unknown_model, "shadow")
        self.assertEqual(fast_config().unknown_model, "support")
        self.assertEqual((config.unknown_shadow_weight, config.unknown_shadow_support_weight,
                          config.unknown_shadow_margin), (0.538, 0.241, 0.618))
        others = [("blobs a", blobs(p.map.shape, 5), p.mm_per_px),
                  ("blobs b", blobs(p.map.shape, 6), p.mm_per_px)]
        results, _ = library_sequence(tacmap.LibraryLocalizer(others, config), simulator(31), 0)
        for r in results:
            check_sums(self, r)
            self.assertNotEqual(r.verdict, "localized")
        self.assertGreater(results[-1].probability_unknown, 0.9)
        lib = tacmap.LibraryLocalizer(others + [("gecko", p.map, p.mm_per_px)], config)
        results, _ = library_sequence(lib, simulator(31), 0)
        self.assertLess(results[-1].probability_unknown, 0.1)
        self.assertEqual(results[-1].object_name, "gecko")
        # A single map's P(not this object) too.
        loc = tacmap.Localizer(p.map, p.mm_per_px, config)
        results, _ = library_sequence(loc, simulator(31), 0)
        self.assertLess(results[-1].probability_other_object, 0.1)
        with self.assertRaisesRegex(ValueError, "unknown_model = 'mirror'; expected 'support'"):
            fast_config(unknown_model="mirror")

    def test_touch_at_and_bursts_give_the_same_touches(self):
        p = gecko()
        maps = [("gecko", p.map, p.mm_per_px), ("blobs", blobs(p.map.shape, 7), p.mm_per_px)]
        by_motion = tacmap.LibraryLocalizer(maps, fast_config())
        by_pose = tacmap.LibraryLocalizer(maps, fast_config())
        by_burst = tacmap.LibraryLocalizer(maps, fast_config())
        sim = simulator(32)
        arm = np.array([300.0, 40.0])  # any origin
        for t, step in enumerate(p.sequences[2]):
            frame = np.asarray(sim.render(*p.locations[step.location]), dtype=np.float64)
            moved = step.measured_motion if t > 0 else None
            if t > 0:
                arm = arm + step.measured_motion
            a = by_motion.touch(frame, moved)
            b = by_pose.touch_at(frame, arm[0], arm[1], 0.02)
            # A press settling, three settled readings and an outlier: one touch of 3 frames.
            c = by_burst.touch_burst(np.stack([frame / 3, frame, frame, frame, 2 * frame]),
                                     moved)
            self.assertEqual((a.frames_combined, c.frames_combined), (1, 3))
            for other in (b, c):
                np.testing.assert_allclose(other.position_mm, a.position_mm, atol=1e-9)
                np.testing.assert_allclose(other.object_probability, a.object_probability,
                                           atol=1e-9)
        # A turned arm breaks the known heading: refused, nothing changed.
        with self.assertRaisesRegex(ValueError, "yaw changed by 28.6.* degrees"):
            by_pose.touch_at(frame, arm[0], arm[1], 0.52)
        with self.assertRaisesRegex(ValueError, "not finite"):
            by_pose.touch_at(frame, math.nan, arm[1])
        self.assertEqual(by_pose.touches, by_motion.touches)
        b = by_pose.touch_at_burst([frame, frame], arm[0] + 1.0, arm[1])
        a = by_motion.touch(frame, (1.0, 0.0))
        np.testing.assert_allclose(b.position_mm, a.position_mm, atol=1e-9)
        # reset() forgets the pose: the next touch_at has no motion.
        by_pose.reset()
        by_motion.reset()
        np.testing.assert_allclose(by_pose.touch_at(frame, 0.0, 0.0).position_mm,
                                   by_motion.touch(frame).position_mm, atol=1e-9)
        with self.assertRaisesRegex(ValueError, "the burst has no frames"):
            by_burst.touch_burst([])
        with self.assertRaisesRegex(ValueError, r"touch_burst: frame 1: shape \(6, 14\)"):
            by_burst.touch_burst([frame, frame.T])

    def test_next_touch_ranks_moves_over_objects_and_positions(self):
        p = gecko()
        lib = tacmap.LibraryLocalizer([("gecko", p.map, p.mm_per_px),
                                       ("blobs", blobs(p.map.shape, 8), p.mm_per_px)],
                                      fast_config())
        lib.touch(simulator(33).render(*p.locations[0]))
        before = [lib.object_belief(k) for k in range(2)]
        xs, ys = np.meshgrid(np.arange(-20.0, 21.0, 10.0), np.arange(-20.0, 21.0, 10.0))
        moves = np.stack([xs.ravel(), ys.ravel()], axis=1)
        r = lib.next_touch(moves, objective="entropy")
        self.assertIsInstance(r, tacmap.NextTouchRanking)
        self.assertEqual(r.score.shape, (25,))
        self.assertEqual(sorted(r.order.tolist()), list(range(25)))
        self.assertTrue(np.all(np.diff(r.score[r.order]) <= 0.0))
        self.assertFalse(r.uninformative)
        v = lib.next_touch(moves.tolist(), hypotheses=32)  # the verdict's objective
        self.assertTrue(np.all((v.score >= 0.0) & (v.score <= 1.0 + 1e-9)))
        self.assertFalse(np.allclose(v.score, lib.next_touch(moves, hypotheses=32,
                                                             objective="entropy").score))
        # A reachable rectangle gives the same lattice (x fastest); the ranking keeps its moves.
        region = tacmap.touch_region(-20.0, 20.0, -20.0, 20.0, step_mm=10.0)
        np.testing.assert_array_equal(region, moves)
        ranked = lib.next_touch(region, objective="entropy")
        np.testing.assert_array_equal(ranked.candidates, region)
        np.testing.assert_array_equal(ranked.score, r.score)
        loc = tacmap.Localizer(p.map, p.mm_per_px, fast_config())
        loc.touch(simulator(33).render(*p.locations[0]))
        np.testing.assert_array_equal(loc.next_touch(region).candidates, region)
        with self.assertRaisesRegex(ValueError, "expected min <= max"):
            tacmap.touch_region(1.0, -1.0, 0.0, 1.0)
        with self.assertRaisesRegex(ValueError, "step_mm = 0"):
            tacmap.touch_region(0.0, 1.0, 0.0, 1.0, step_mm=0.0)
        with self.assertRaisesRegex(ValueError, "not finite"):
            tacmap.touch_region(0.0, math.inf, 0.0, 1.0)
        for k in range(2):
            np.testing.assert_array_equal(lib.object_belief(k), before[k])
        with self.assertRaisesRegex(ValueError, "candidate 1 moves .* not finite"):
            lib.next_touch([(1.0, 0.0), (math.nan, 0.0)])
        with self.assertRaisesRegex(ValueError, "LibraryLocalizer.next_touch: candidates"):
            lib.next_touch([1.0, 2.0, 3.0])
        with self.assertRaisesRegex(ValueError, "objective = 'best'"):
            lib.next_touch(moves, objective="best")

    def test_reset_and_accessors(self):
        p = gecko()
        lib = tacmap.LibraryLocalizer([("gecko", p.map, p.mm_per_px),
                                       ("blobs", blobs(p.map.shape, 9), p.mm_per_px)],
                                      fast_config(), threads=2)
        self.assertEqual((lib.objects, len(lib)), (2, 2))
        self.assertEqual(lib.photo_mm_per_px, [p.mm_per_px, p.mm_per_px])
        self.assertEqual(lib.warnings, [])
        self.assertIsNone(lib.sensor_calibration)
        self.assertEqual(lib.sensor, tacmap.TaxelGeometry())
        self.assertAlmostEqual(lib.config.preprocessing.mm_per_px, lib.mm_per_px)
        lib.touch(simulator(34).render(*p.locations[0]))
        self.assertEqual(lib.touches, 1)
        self.assertEqual(lib.restarts, 0)
        self.assertIn("LibraryLocalizer(['gecko', 'blobs'] at", repr(lib))
        self.assertIn("object_name='", repr(lib.touch(np.zeros((14, 6)))))
        lib.reset()
        self.assertEqual(lib.touches, 0)
        self.assertAlmostEqual(lib.probability_unknown, 0.5)
        b = lib.object_belief(1)
        self.assertAlmostEqual(float(b.sum(dtype=np.float64)), 1.0, places=5)
        self.assertAlmostEqual(float(b.max() - b.min()), 0.0, places=7)  # uniform again
        with self.assertRaisesRegex(IndexError, "object 2; expected 0 .. 1"):
            lib.object_belief(2)
        with self.assertRaisesRegex(KeyError, "no object named 'mug'"):
            lib.object_belief("mug")
        with self.assertRaisesRegex(TypeError, "an index"):
            lib.object_extent_mm(1.5)
        self.assertEqual(lib.object_extent_mm(np.int64(1)), lib.object_extent_mm("blobs"))

    def test_restarts_are_counted_by_both_front_doors(self):
        # Without the motion floor, a move off the map carries every state away: the filter
        # starts again from uniform, says so in the result and counts it.
        p = gecko()
        cfg = fast_config(lost_probability=0.0, wide_probability=0.0)
        frame = simulator(39).render(*p.locations[0])
        for front_door in (tacmap.Localizer(p.map, p.mm_per_px, cfg),
                           tacmap.LibraryLocalizer([("gecko", p.map, p.mm_per_px)], cfg)):
            self.assertFalse(front_door.touch(frame).restarted)
            self.assertEqual(front_door.restarts, 0)
            self.assertTrue(front_door.touch(frame, (200.0, 0.0)).restarted)
            self.assertEqual(front_door.restarts, 1)
            front_door.reset()
            self.assertEqual(front_door.restarts, 0)


class TestLibraryThreads(unittest.TestCase):
    def test_maps_prepared_in_parallel_and_one_library_shared(self):
        # Preparing the maps on two threads gives the same library (the same touches give the
        # same posteriors); one library shared by two Python threads serialises their touches.
        p = gecko()
        maps = [("gecko", p.map, p.mm_per_px), ("blobs", blobs(p.map.shape, 12), p.mm_per_px),
                ("horse", tacmap.read_pgm(test_tacmap.DATA + "/horse/horse.pgm"), p.mm_per_px)]
        one = tacmap.LibraryLocalizer(maps, fast_config())
        two = tacmap.LibraryLocalizer(maps, fast_config(), threads=2)
        a, _ = library_sequence(one, simulator(40), 3)
        b, _ = library_sequence(two, simulator(40), 3)
        for x, y in zip(a, b):
            np.testing.assert_array_equal(x.object_probability, y.object_probability)
            np.testing.assert_array_equal(x.position_mm, y.position_mm)
        frame = simulator(41).render(*p.locations[1])
        errors = []

        def touch_many():
            try:
                for _ in range(10):
                    r = two.touch(frame, (0.0, 0.0))
                    check_sums(self, r)
            except Exception as e:  # noqa: BLE001 (reported below)
                errors.append(e)

        two.reset()
        threads = [threading.Thread(target=touch_many) for _ in range(2)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        self.assertEqual(errors, [])
        self.assertEqual(two.touches, 20)


class TestLibraryBadInput(unittest.TestCase):
    """A bad library is refused with a message naming the entry and what was expected."""

    def test_libraries(self):
        p = gecko()
        cfg = fast_config()
        m, s = p.map, p.mm_per_px
        with self.assertRaisesRegex(ValueError, "the library is empty"):
            tacmap.LibraryLocalizer([], cfg)
        with self.assertRaisesRegex(ValueError, "the library is empty"):
            tacmap.LibraryLocalizer({}, cfg)
        with self.assertRaisesRegex(TypeError, "maps is a str"):
            tacmap.LibraryLocalizer("gecko", cfg)
        with self.assertRaisesRegex(ValueError, "objects 0 and 1 are both named 'gecko'"):
            tacmap.LibraryLocalizer([("gecko", m, s), ("gecko", blobs(m.shape, 1), s)], cfg)
        with self.assertRaisesRegex(ValueError, "maps\\[1\\]: the name is empty"):
            tacmap.LibraryLocalizer([("gecko", m, s), ("", blobs(m.shape, 1), s)], cfg)
        with self.assertRaisesRegex(TypeError, "maps\\[0\\]: the name is a int"):
            tacmap.LibraryLocalizer([(7, m, s)], cfg)
        with self.assertRaisesRegex(ValueError, "mm_per_px = nan for 'gecko' \\(object 0\\)"):
            tacmap.LibraryLocalizer([("gecko", m, math.nan)], cfg)
        with self.assertRaisesRegex(ValueError, "mm_per_px = -1 for 'b' \\(object 1\\)"):
            tacmap.LibraryLocalizer([("a", m, s), ("b", blobs(m.shape, 1), -1.0)], cfg)
        with self.assertRaisesRegex(TypeError, "mm_per_px = '1.13' for 'gecko'.*not a number"):
            tacmap.LibraryLocalizer([("gecko", m, "1.13")], cfg)
        with self.assertRaisesRegex(ValueError, r"maps\[0\] is a tuple of 2 values; expected "
                                    r"\(name, map, mm_per_px\)"):
            tacmap.LibraryLocalizer([("gecko", m)], cfg)
        with self.assertRaisesRegex(ValueError,
                                    r"maps\['gecko'\] is a ndarray.*\(map, mm_per_px\)"):
            tacmap.LibraryLocalizer({"gecko": m}, cfg)
        with self.assertRaisesRegex(TypeError,
                                    "the map of 'gecko' \\(maps\\[0\\]\\): dtype complex"):
            tacmap.LibraryLocalizer([("gecko", m.astype(np.complex64), s)], cfg)
        with self.assertRaisesRegex(ValueError, "the map of 'gecko' \\(maps\\[0\\]\\): a 3-D"):
            tacmap.LibraryLocalizer([("gecko", np.stack([m] * 3, axis=-1), s)], cfg)
        nan_map = m.copy()
        nan_map[5, 5] = np.nan
        with self.assertRaisesRegex(ValueError, "the map of 'gecko' \\(object 0\\) has non-finite"):
            tacmap.LibraryLocalizer([("gecko", nan_map, s)], cfg)
        with self.assertRaisesRegex(ValueError, "the map of 'tiny' \\(object 0\\) is empty"):
            tacmap.LibraryLocalizer([("tiny", np.zeros((0, 0)), s)], cfg)
        with self.assertRaisesRegex(ValueError, "'a' \\(object 0\\) and 'b' \\(object 1\\) are "
                                    "the same image"):
            tacmap.LibraryLocalizer([("a", m, s), ("b", m.copy(), s)], cfg)
        with self.assertRaisesRegex(ValueError, "headings = 4"):
            tacmap.LibraryLocalizer([("gecko", m, s)], fast_config(headings=4))
        with self.assertRaisesRegex(ValueError, "prior"):
            tacmap.LibraryLocalizer([("gecko", m, s), ("b", blobs(m.shape, 1), s)], cfg,
                                    prior=[0.5, 0.2])
        with self.assertRaisesRegex(ValueError, "threads = 0"):
            tacmap.LibraryLocalizer([("gecko", m, s)], cfg, threads=0)
        with self.assertRaisesRegex(ValueError, "scale is nan"):
            tacmap.LibraryLocalizer([("gecko", m, s)], cfg, mm_per_px=math.nan)

    def test_touches(self):
        p = gecko()
        lib = tacmap.LibraryLocalizer([("gecko", p.map, p.mm_per_px)], fast_config())
        frame = simulator(35).render(*p.locations[0])
        lib.touch(frame)
        with self.assertRaisesRegex(ValueError, r"LibraryLocalizer.touch: frame: shape \(6, 14\); "
                                    r"expected \(14, 6\) \(the library's sensor"):
            lib.touch(frame.counts.T)
        with self.assertRaisesRegex(TypeError, "LibraryLocalizer.touch: frame: dtype complex"):
            lib.touch(frame.counts + 1j)
        with self.assertRaisesRegex(ValueError, "10 x 4 taxels"):
            lib.touch(tacmap.Frame(np.ones((10, 4)) * 1000))
        bad = frame.counts.copy()
        bad[2, 3] = np.nan
        with self.assertRaisesRegex(ValueError, r"taxel \(2, 3\)"):
            lib.touch(bad, (1.0, 0.0))
        with self.assertRaisesRegex(ValueError, "a turn of 0.1 rad; a library is localized with "
                                    "a known heading"):
            lib.touch(frame, (1.0, 0.0, 0.1))
        with self.assertRaisesRegex(ValueError, "not finite"):
            lib.touch(frame, (math.inf, 0.0))
        with self.assertRaisesRegex(TypeError, "moved: got str"):
            lib.touch(frame, "left")
        with self.assertRaisesRegex(TypeError, "touch_burst: frames is a Frame; expected a "
                                    "sequence"):
            lib.touch_burst(frame)
        # Nothing changed: the refused touches left the count and the belief alone.
        self.assertEqual(lib.touches, 1)
        r = lib.touch(frame, (0.0, 0.0, 0.0))  # a zero turn is a map-frame move
        self.assertEqual(r.touches, 2)


class TestConfigurationParts(unittest.TestCase):
    """LocalizerConfig's optional parts: bound, validated, and reaching the C++ localizer."""

    def test_optional_parts_take_none_true_or_parameters(self):
        cfg = tacmap.LocalizerConfig()
        for name in ("calibrate_sensor", "slip_recheck", "working_mm_per_px", "pad_spread_mm"):
            self.assertIsNone(getattr(cfg, name), name)
            self.assertIn(name + "=None", repr(cfg))
            self.assertIn(name + " = None", tacmap.LocalizerConfig.__doc__)
        # Tracking is on by default (TrackingParams.default()); None turns it off, and the
        # paper's configuration evaluates the whole grid.
        self.assertEqual(repr(cfg.tracking), repr(tacmap.TrackingParams.default()))
        self.assertIsNone(tacmap.LocalizerConfig(tracking=None).tracking)
        self.assertIsNone(tacmap.LocalizerConfig.paper().tracking)
        cfg = tacmap.LocalizerConfig(calibrate_sensor=True, tracking=True, slip_recheck=True,
                                     working_mm_per_px=0.5,
                                     burst=tacmap.BurstParams(statistic="trimmed_mean"))
        self.assertIsInstance(cfg.calibrate_sensor, tacmap.SelfCalibrationParams)
        self.assertEqual(cfg.calibrate_sensor.window, 64)
        self.assertEqual(cfg.tracking.epsilon, 1e-9)  # True: TrackingParams.default()
        self.assertEqual(repr(cfg.tracking), repr(tacmap.TrackingParams.default()))
        self.assertEqual(tacmap.TrackingParams().epsilon, 0.0)  # default-constructed: off
        self.assertEqual((cfg.slip_recheck.doubt, cfg.slip_recheck.broad_probability),
                         (-1.0, 0.3))
        self.assertEqual(cfg.working_mm_per_px, 0.5)
        # The map as the sensor sees it: None is half the pitch; paper() matches the photograph.
        self.assertEqual(tacmap.LocalizerConfig.default_pad_spread_pitches, 0.5)
        self.assertEqual(tacmap.LocalizerConfig.paper().pad_spread_mm, 0.0)
        self.assertEqual(tacmap.LocalizerConfig(pad_spread_mm=1.2).pad_spread_mm, 1.2)
        self.assertEqual(cfg.burst.statistic, "trimmed_mean")
        # Nested parameters are views into the configuration, as preprocessing is.
        cfg.calibrate_sensor.window = 16
        cfg.tracking.recheck_every = 4
        self.assertEqual((cfg.calibrate_sensor.window, cfg.tracking.recheck_every), (16, 4))
        cfg.calibrate_sensor = tacmap.SelfCalibrationParams(min_touches=3)
        self.assertEqual((cfg.calibrate_sensor.window, cfg.calibrate_sensor.min_touches), (64, 3))
        cfg.tracking = False
        cfg.slip_recheck = None
        self.assertIsNone(cfg.tracking)
        self.assertIsNone(cfg.slip_recheck)
        # The simulated experiment's configuration takes the same keywords.
        self.assertEqual(tacmap.LocalizationConfig(tracking=True).tracking.recheck_every, 64)

    def test_bad_parts_are_refused_naming_the_value(self):
        with self.assertRaisesRegex(TypeError, "calibrate_sensor = 'yes' has the wrong type"):
            tacmap.LocalizerConfig(calibrate_sensor="yes")
        cfg = tacmap.LocalizerConfig()
        with self.assertRaisesRegex(TypeError, "LocalizerConfig.tracking = 1 \\(a int\\); "
                                    "expected None \\(off\\), True"):
            cfg.tracking = 1
        with self.assertRaisesRegex(TypeError, "expected None \\(off\\), True \\(the defaults\\) "
                                    "or a SlipRecheckParams"):
            cfg.slip_recheck = tacmap.TrackingParams()
        with self.assertRaisesRegex(ValueError, "window = 0"):
            tacmap.SelfCalibrationParams(window=0)
        with self.assertRaisesRegex(ValueError, "epsilon = 0.7"):
            tacmap.TrackingParams(epsilon=0.7)
        with self.assertRaisesRegex(ValueError, "doubt = 1"):
            tacmap.SlipRecheckParams(doubt=1.0)
        with self.assertRaisesRegex(ValueError, "statistic = 'mean'"):
            tacmap.BurstParams(statistic="mean")
        with self.assertRaisesRegex(ValueError, "working_mm_per_px = nan"):
            tacmap.LocalizerConfig(working_mm_per_px=math.nan)
        with self.assertRaisesRegex(ValueError, "working_mm_per_px = -1"):
            tacmap.LocalizerConfig(working_mm_per_px=-1.0)
        with self.assertRaisesRegex(ValueError, "pad_spread_mm = -1"):
            tacmap.LocalizerConfig(pad_spread_mm=-1.0)
        # Validated as a whole: a recheck's share with the motion's must stay below 1.
        with self.assertRaisesRegex(ValueError, "slip_recheck.broad_probability = 0.95"):
            tacmap.LocalizerConfig(slip_recheck=tacmap.SlipRecheckParams(broad_probability=0.95))
        # Set later, checked when used.
        cfg.calibrate_sensor = True
        cfg.calibrate_sensor.iterations = 0
        p = gecko()
        with self.assertRaisesRegex(ValueError, "iterations = 0"):
            tacmap.Localizer(p.map, p.mm_per_px, cfg)
        with self.assertRaisesRegex(ValueError, "iterations = 0"):
            tacmap.LibraryLocalizer([("gecko", p.map, p.mm_per_px)], cfg)

    def test_working_resolution_and_warnings(self):
        p = gecko()
        # A photograph at half the gecko's pixel size is matched at the working resolution (the
        # sensor's pitch / 3, the gecko's own scale): the same grid, positions still in mm.
        fine = np.kron(p.map, np.ones((2, 2), dtype=np.float32))
        loc = tacmap.Localizer(fine, p.mm_per_px / 2, fast_config())
        self.assertAlmostEqual(loc.mm_per_px, 3.4 / 3)
        self.assertEqual(loc.photo_mm_per_px, p.mm_per_px / 2)
        self.assertEqual(loc.map.shape, (120, 120))
        self.assertEqual(loc.warnings, [])
        results, truths = test_tacmap.run_sequence(loc, simulator(38), 0)
        self.assertLess(np.linalg.norm(results[-1].position_mm - truths[-1]), 5.0)
        # Asked to match at the photograph's own scale, it does.
        full = tacmap.Localizer(fine, p.mm_per_px / 2,
                                fast_config(working_mm_per_px=p.mm_per_px / 2))
        self.assertEqual(full.map.shape, (240, 240))
        self.assertEqual(full.mm_per_px, p.mm_per_px / 2)
        self.assertEqual(full.window, (36, 84))
        # A photograph coarser than the working resolution is used as it is, with a warning
        # (NCC: the descriptors' 18 px patches would not fit the smaller window).
        ncc = tacmap.LocalizerConfig(model="ncc")
        coarse = tacmap.Localizer(p.map, 1.6, ncc)
        self.assertEqual((coarse.mm_per_px, coarse.photo_mm_per_px), (1.6, 1.6))
        self.assertEqual(len(coarse.warnings), 1)
        self.assertIn("1.6 mm per px is coarser than the working resolution", coarse.warnings[0])
        lib = tacmap.LibraryLocalizer([("coarse", p.map, 1.6)], ncc)
        self.assertEqual(len(lib.warnings), 1)
        self.assertIn("'coarse'", lib.warnings[0])
        self.assertEqual((lib.mm_per_px, lib.photo_mm_per_px), (1.6, [1.6]))
        with self.assertRaisesRegex(ValueError, "the photograph's scale is 2 mm per px.* 1.7 px "
                                    "each; expected at most 1.7 mm per px"):
            tacmap.Localizer(p.map, 2.0, fast_config())  # 1.7 px per taxel: too coarse

    def test_burst_parameters_reach_the_localizers(self):
        p = gecko()
        frame = np.asarray(simulator(36).render(*p.locations[1]), dtype=np.float64)
        frames = np.stack([frame, frame, frame, frame, 1.3 * frame])  # the last: 30 % off
        keep_all = fast_config(burst=tacmap.BurstParams(outlier_tolerance=0.5))
        for config, kept in ((fast_config(), 4), (keep_all, 5)):
            loc = tacmap.Localizer(p.map, p.mm_per_px, config)
            self.assertEqual(loc.touch_burst(frames).frames_combined, kept)
            self.assertEqual(loc.touch_at_burst(frames, 0.0, 0.0).frames_combined, kept)
            lib = tacmap.LibraryLocalizer([("gecko", p.map, p.mm_per_px)], config)
            self.assertEqual(lib.touch_burst(frames).frames_combined, kept)
        with self.assertRaisesRegex(ValueError, "the burst has no frames"):
            loc.touch_at_burst([], 0.0, 0.0)

    def test_a_dead_taxel_is_found_by_the_self_calibration(self):
        # Touches at random places on the gecko with taxel (7, 2) dead: the estimate (the default
        # parameters) calls it dead and keeps it from voting, and leaves every other taxel live.
        p = gecko()
        loc = tacmap.Localizer(p.map, p.mm_per_px, fast_config(calibrate_sensor=True))
        lib = tacmap.LibraryLocalizer([("gecko", p.map, p.mm_per_px)],
                                      fast_config(calibrate_sensor=True))
        self.assertIsNone(tacmap.Localizer(p.map, p.mm_per_px, fast_config()).sensor_calibration)
        sim = simulator(37)
        rng = np.random.default_rng(5)
        left, right, bottom, top = loc.extent_mm
        for k in range(32):
            x, y = rng.uniform(left + 1, right - 1), rng.uniform(top + 1, bottom - 1)
            counts = np.asarray(sim.render(x, y), dtype=np.float64)
            counts[7, 2] = 0.0
            loc.touch(counts)
            lib.touch(counts)
            loc.reset()  # the calibration outlives reset()
        for c in (loc.sensor_calibration, lib.sensor_calibration):
            self.assertIsInstance(c, tacmap.SensorCalibration)
            self.assertEqual(c.touches, 32)
            self.assertEqual(c.status[7][2], "dead")
            self.assertFalse(c.live[7, 2])
            self.assertEqual(c.gain.shape, (14, 6))
            self.assertEqual(int((~c.live).sum()), 1)
            self.assertIn("dead", c.reason(7, 2))
            self.assertIn("unestimated", {s for row in c.status for s in row})
            with self.assertRaisesRegex(IndexError, "row < 14"):
                c.reason(14, 0)
        loc.reset_sensor_calibration()
        lib.reset_sensor_calibration()
        self.assertEqual(loc.sensor_calibration.touches, 0)
        self.assertEqual(lib.sensor_calibration.touches, 0)


if __name__ == "__main__":
    unittest.main()
