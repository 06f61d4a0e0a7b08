// Tests of the open-set hypothesis ("none of these", filter/open_set.hpp) and of the front
// doors that report it: P(unknown) on `library_touch_result`, P(not this object) on
// `touch_result`, and the verdicts that must beat it.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "sim/gecko_protocol.hpp"
#include "tacmap/filter/open_set.hpp"
#include "tacmap/library_localizer.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/sim/random.hpp"
#include "tacmap/sim/tactile_simulator.hpp"
#include "test_support.hpp"

namespace test_open_set {

namespace {

// The shipped measurement model: the open set's model was fitted in its units.
tacmap::localizer_config fast_config() { return {}; }

// A surface unlike the gecko: smooth random blobs (sums of Gaussians at random places), the
// gecko map's size, fixed by `seed`.
tacmap::image<float> blobs(Eigen::Index rows, Eigen::Index cols, std::uint64_t seed) {
  tacmap::sim_rng rng(seed);
  tacmap::image<float> out = tacmap::image<float>::Zero(rows, cols);
  for (int b = 0; b < 60; ++b) {
    const double cy = rng.uniform() * static_cast<double>(rows);
    const double cx = rng.uniform() * static_cast<double>(cols);
    const double s = 2.0 + 4.0 * rng.uniform();
    const double a = rng.uniform() < 0.5 ? -1.0 : 1.0;
    for (Eigen::Index y = 0; y < rows; ++y)
      for (Eigen::Index x = 0; x < cols; ++x) {
        const double d2 = (static_cast<double>(y) - cy) * (static_cast<double>(y) - cy) +
                          (static_cast<double>(x) - cx) * (static_cast<double>(x) - cx);
        out(y, x) += static_cast<float>(a * std::exp(-0.5 * d2 / (s * s)));
      }
  }
  return out;
}

// The library's objects, none of which is the gecko: the gecko turned upside down and two blob
// surfaces.
std::vector<tacmap::library_map> library_without_gecko() {
  const auto& p = tacmap_test::gecko();
  return {{"turned", p.map.reverse(), p.mm_per_px},
          {"blobs", blobs(p.map.rows(), p.map.cols(), 11), p.mm_per_px},
          {"spots", blobs(p.map.rows(), p.map.cols(), 23), p.mm_per_px}};
}

// Runs gecko sequence `q` through `touch(frame, first)`; returns the results.
template <class Touch>
auto run_gecko_sequence(std::size_t q, std::uint64_t seed, Touch&& touch) {
  const auto& p = tacmap_test::gecko();
  tacmap::tactile_simulator sim(p.relief_mm(), p.map_size(), p.mm_per_px, {.seed = seed});
  using result = decltype(touch(std::declval<const tacmap::tactile_frame&>(),
                                std::optional<tacmap::odometry>{}));
  std::vector<result> out;
  for (std::size_t t = 0; t < p.sequences[q].size(); ++t) {
    const auto& step = p.sequences[q][t];
    const auto frame = sim.render(p.locations[step.location].pose());
    out.push_back(touch(frame, t == 0 ? std::optional<tacmap::odometry>{}
                                      : std::optional<tacmap::odometry>{step.measured_motion}));
  }
  return out;
}

}  // namespace

TEST_CASE("open_set: the prior, the touches' factors and the logistic") {
  tacmap::open_set u({.prior_unknown = 0.2});
  CHECK(u.probability_unknown() == doctest::Approx(0.2));
  // A touch the maps explain e^2 times better than an unknown surface: odds 0.25 e^-2.
  u.observe_log_factor(2.0);
  CHECK(u.probability_unknown() ==
        doctest::Approx(0.25 * std::exp(-2.0) / (1.0 + 0.25 * std::exp(-2.0))));
  // The update report gives the factor of eq. 1, a (S - d), from its support S alone.
  u.reset();
  tacmap::update_report report;
  report.log_prediction_support = 1.5;
  report.log_likelihood_max = -10.0;  // the likelihood's level plays no part
  report.log_evidence = -6.0;
  const tacmap::open_set_params fitted;
  const double a = fitted.evidence_weight, d = fitted.support_margin;
  CHECK(u.log_factor(report) == doctest::Approx(a * (1.5 - d)));
  report.log_likelihood_max = -30.0;
  CHECK(u.log_factor(report) == doctest::Approx(a * (1.5 - d)));
  u.observe(report);
  CHECK(u.log_odds() == doctest::Approx(std::log(0.25) - a * (1.5 - d)));
  // a = 1, d = 0: the memoryless unknown, whose factor is the support itself.
  const tacmap::open_set memoryless(
      {.prior_unknown = 0.2, .evidence_weight = 1.0, .support_margin = 0.0});
  CHECK(memoryless.log_factor(report) == doctest::Approx(1.5));
  // A touch must support the prediction by more than d to count for the maps: a first touch
  // (S = 0, a uniform prediction) raises P(U), a touch at the margin leaves it.
  report.log_prediction_support = 0.0;
  CHECK(u.log_factor(report) == doctest::Approx(-a * d));
  report.log_prediction_support = d;
  CHECK(u.log_factor(report) == doctest::Approx(0.0));
  // A touch that contradicted the prediction (-infinity support) is -infinity.
  report.log_prediction_support = -std::numeric_limits<double>::infinity();
  CHECK(u.log_factor(report) == -std::numeric_limits<double>::infinity());
  // Extreme factors neither overflow nor give NaN.
  u.observe_log_factor(1e6);
  CHECK(u.probability_unknown() >= 0.0);
  CHECK(u.probability_unknown() < 1e-300);
  u.observe_log_factor(-std::numeric_limits<double>::infinity());
  CHECK(u.probability_unknown() == 1.0);
  u.reset();
  CHECK(u.probability_unknown() == doctest::Approx(0.2));
  // A restart of the filter restarts the question; a rejected frame (no report) changes nothing.
  u.observe_log_factor(-3.0);
  tacmap::detail::follow_touch(u, false, std::nullopt);
  CHECK(u.log_odds() == doctest::Approx(std::log(0.25) + 3.0));
  tacmap::detail::follow_touch(u, true, report);
  CHECK(u.probability_unknown() == doctest::Approx(0.2));
}

TEST_CASE(
    "open_set, shadow model: b (L - L') + c S - m from the filter's and the shadow's reports") {
  tacmap::open_set u({.model = tacmap::unknown_model::shadow,
                      .shadow_weight = 0.7,
                      .shadow_support_weight = 0.2,
                      .shadow_margin = 0.5});
  tacmap::update_report report, shadow;
  report.log_likelihood_max = -10.0;
  report.log_evidence = -2.0;  // L = -12
  report.log_prediction_support = 1.5;
  shadow.log_likelihood_max = -11.0;
  shadow.log_evidence = -4.0;           // L' = -15
  shadow.log_prediction_support = 9.0;  // the shadow's own support plays no part
  CHECK(u.log_factor(report, shadow) == doctest::Approx(0.7 * 3.0 + 0.2 * 1.5 - 0.5));
  // The likelihood's level cancels: both filters' evidences shift alike.
  report.log_likelihood_max -= 20.0;
  shadow.log_likelihood_max -= 20.0;
  CHECK(u.log_factor(report, shadow) == doctest::Approx(0.7 * 3.0 + 0.2 * 1.5 - 0.5));
  // follow_touch weighs eq. 2 where the shadow reported the touch, eq. 1 where it did not.
  tacmap::detail::follow_touch(u, false, report, shadow);
  CHECK(u.log_odds() == doctest::Approx(-(0.7 * 3.0 + 0.2 * 1.5 - 0.5)));
  u.reset();
  tacmap::detail::follow_touch(u, false, report);
  CHECK(u.log_odds() == doctest::Approx(-u.log_factor(report)));
  tacmap::detail::follow_touch(u, true, report, shadow);
  CHECK(u.log_odds() == doctest::Approx(0.0));
  // The shadow model's settings, each named with its range.
  using tacmap_test::message_of;
  const std::vector<std::pair<tacmap::open_set_params, std::string>> bad = {
      {{.shadow_weight = 0.0}, "shadow_weight = 0; expected a weight in (0, 1]"},
      {{.shadow_support_weight = -0.5},
       "shadow_support_weight = -0.5; expected a weight in [0, 1]"},
      {{.shadow_margin = 21.0}, "shadow_margin = 21; expected nats in [-20, 20]"},
      {{.shadow_margin = std::numeric_limits<double>::infinity()}, "shadow_margin = inf"},
      {{.model = static_cast<tacmap::unknown_model>(7)}, "model = 7; expected"},
  };
  for (const auto& [params, expected] : bad) {
    CAPTURE(expected);
    CHECK(message_of([&] { tacmap::open_set v(params); }).find(expected) != std::string::npos);
  }
}

TEST_CASE("open_set: a bad prior or factor is refused, naming the value") {
  using tacmap_test::message_of;
  for (const double bad : {0.0, 1.0, -0.1, 1.5, std::numeric_limits<double>::quiet_NaN(),
                           std::numeric_limits<double>::infinity()}) {
    CAPTURE(bad);
    const auto m = message_of([&] { tacmap::open_set u({.prior_unknown = bad}); });
    CHECK(m.find("prior_unknown") != std::string::npos);
    CHECK(m.find("expected a probability in (0, 1)") != std::string::npos);
    // The front doors check it with the rest of their configuration, before preparing a map.
    auto c = fast_config();
    c.open_set.prior_unknown = bad;
    CHECK(message_of([&] { c.validate(); }).find("prior_unknown") != std::string::npos);
    const auto& p = tacmap_test::gecko();
    CHECK(message_of([&] { tacmap::localizer loc(p.map, p.mm_per_px, c); }).find("prior_unknown") !=
          std::string::npos);
    CHECK(message_of([&] {
            tacmap::library_localizer loc(library_without_gecko(), c);
          }).find("prior_unknown") != std::string::npos);
  }
  tacmap::open_set u;
  CHECK(message_of([&] {
          u.observe_log_factor(std::numeric_limits<double>::quiet_NaN());
        }).find("nan") != std::string::npos);
  // The model's weights, each named with its range.
  const std::vector<std::pair<tacmap::open_set_params, std::string>> bad_models = {
      {{.evidence_weight = 0.0}, "evidence_weight = 0; expected a weight in (0, 1]"},
      {{.evidence_weight = 1.5}, "evidence_weight = 1.5; expected a weight in (0, 1]"},
      {{.support_margin = -0.1}, "support_margin = -0.1; expected nats in [0, 20]"},
      {{.support_margin = 25.0}, "support_margin = 25; expected nats in [0, 20]"},
      {{.support_margin = std::numeric_limits<double>::quiet_NaN()}, "support_margin = nan"},
  };
  for (const auto& [params, expected] : bad_models) {
    CAPTURE(expected);
    CHECK(message_of([&] { tacmap::open_set v(params); }).find(expected) != std::string::npos);
  }
  CHECK(u.probability_unknown() == doctest::Approx(0.5));  // unchanged by the refused calls
}

TEST_CASE("with_open_set: localized only when the map and the position beat the unknown") {
  const tacmap::confidence_params params;  // threshold 0.9
  tacmap::confidence c;
  c.probability_within = 0.99;
  c.verdict = tacmap::verdict::localized;
  const auto kept = tacmap::with_open_set(c, 0.05, params);
  CHECK(kept.verdict == tacmap::verdict::localized);
  CHECK(kept.probability_within == doctest::Approx(0.99 * 0.95));
  CHECK(tacmap::with_open_set(c, 0.2, params).verdict == tacmap::verdict::uncertain);
  c.verdict = tacmap::verdict::contradicted;
  CHECK(tacmap::with_open_set(c, 0.0, params).verdict == tacmap::verdict::contradicted);
}

TEST_CASE(
    "library_localizer: P(unknown) rises on an object not in the library, falls on one in it") {
  const auto& p = tacmap_test::gecko();
  // The support model (the default) and the shadow model with its fitted weights.
  auto shadow = fast_config();
  shadow.open_set.model = tacmap::unknown_model::shadow;
  for (const auto& config : {fast_config(), shadow})
    for (std::size_t q = 0; q < 3; ++q) {
      CAPTURE(q);
      CAPTURE(static_cast<int>(config.open_set.model));
      // The gecko is not in the library: every "localized" would be false.
      tacmap::library_localizer without(library_without_gecko(), config);
      const auto unknown = run_gecko_sequence(q, 40 + q, [&](const auto& frame, const auto& moved) {
        return moved ? without.touch(frame, *moved) : without.touch(frame);
      });
      // With the gecko in the library.
      auto maps = library_without_gecko();
      maps.push_back({"gecko", p.map, p.mm_per_px});
      tacmap::library_localizer with(maps, config);
      const auto known = run_gecko_sequence(q, 40 + q, [&](const auto& frame, const auto& moved) {
        return moved ? with.touch(frame, *moved) : with.touch(frame);
      });
      for (const auto* run : {&unknown, &known}) {
        for (const auto& r : *run) {
          double sum = r.probability_unknown;
          for (const double k : r.object_probability) sum += k;
          CHECK(sum == doctest::Approx(1.0).epsilon(1e-5));
          CHECK(r.probability_within <= 1.0 - r.probability_unknown + 1e-9);
          // Never "localized" while P(unknown) leaves the threshold out of reach.
          if (r.probability_unknown > 1.0 - config.confidence.threshold)
            CHECK(r.verdict != tacmap::verdict::localized);
        }
      }
      for (const auto& r : unknown) CHECK(r.verdict != tacmap::verdict::localized);
      CHECK(unknown.back().probability_unknown > 0.9);
      CHECK(without.probability_unknown() == unknown.back().probability_unknown);
      CHECK(known.back().probability_unknown < 0.01);
      CHECK(known.back().object_name == "gecko");
      CHECK(known.back().verdict == tacmap::verdict::localized);
      // reset() goes back to the prior.
      with.reset();
      CHECK(with.probability_unknown() == doctest::Approx(0.5));
    }
}

TEST_CASE(
    "library_localizer, shadow model: on mirror-symmetric maps the shadow is the filter itself, "
    "so P(unknown) stays at the prior; a reset restarts the shadow") {
  // Each map is an image beside its own mirror image: mirrored, it is the same map, so a shadow
  // filter that follows the filter's motions and touches gives every touch the filter's own
  // evidence, L' = L (up to the order of float sums), and with b = 1, c = 0, m = 0 P(unknown)
  // does not move. A shadow that skipped a motion, a reset or a touch, or was built at another
  // scale, would not agree. The support model on the same touches does move it.
  const auto& p = tacmap_test::gecko();
  const auto symmetric = [](const tacmap::image<float>& m) {
    tacmap::image<float> out(m.rows(), 2 * m.cols());
    out << m, m.rowwise().reverse();
    return out;
  };
  const std::vector<tacmap::library_map> maps = {
      {"gecko twice", symmetric(p.map), p.mm_per_px},
      {"blobs twice", symmetric(blobs(p.map.rows(), p.map.cols(), 11)), p.mm_per_px}};
  auto config = fast_config();
  config.open_set.model = tacmap::unknown_model::shadow;
  config.open_set.shadow_weight = 1.0;
  config.open_set.shadow_support_weight = 0.0;
  config.open_set.shadow_margin = 0.0;
  tacmap::library_localizer shadowed(maps, config);
  REQUIRE(shadowed.shadow_filter() != nullptr);
  CHECK(shadowed.shadow_filter()->grid().object_name(0) == "mirrored gecko twice");
  tacmap::library_localizer plain(maps, fast_config());
  CHECK(plain.shadow_filter() == nullptr);
  const auto touch = [](auto& loc) {
    return [&loc](const auto& frame, const auto& moved) {
      return moved ? loc.touch(frame, *moved) : loc.touch(frame);
    };
  };
  for (std::size_t q = 0; q < 2; ++q) {
    CAPTURE(q);
    shadowed.reset();
    plain.reset();
    const auto with_shadow = run_gecko_sequence(q, 60 + q, touch(shadowed));
    const auto with_support = run_gecko_sequence(q, 60 + q, touch(plain));
    double moved = 0.0;
    for (std::size_t t = 0; t < with_shadow.size(); ++t) {
      CAPTURE(t);
      REQUIRE(!with_shadow[t].restarted);
      CHECK(with_shadow[t].probability_unknown == doctest::Approx(0.5).epsilon(1e-4));
      moved = std::max(moved, std::abs(with_support[t].probability_unknown - 0.5));
    }
    CHECK(moved > 0.1);
    CHECK(with_shadow.back().object_name == "gecko twice");
  }
}

TEST_CASE(
    "localizer, shadow model: on a mirror-symmetric map the shadow is the filter itself, so P(not "
    "this object) stays at the prior; a reset restarts the shadow") {
  // As the library's case above, for one map: the gecko beside its mirror image.
  const auto& p = tacmap_test::gecko();
  tacmap::image<float> twice(p.map.rows(), 2 * p.map.cols());
  twice << p.map, p.map.rowwise().reverse();
  auto config = fast_config();
  config.open_set.model = tacmap::unknown_model::shadow;
  config.open_set.shadow_weight = 1.0;
  config.open_set.shadow_support_weight = 0.0;
  config.open_set.shadow_margin = 0.0;
  // The identity needs both filters to evaluate the same states: the shadow always evaluates its
  // whole grid, so the filter must too (tracking, the default, restricts it to the path once
  // localized: with it P(not this object) drifted to 0.501 over a sequence).
  config.tracking.reset();
  tacmap::localizer shadowed(twice, p.mm_per_px, config), plain(twice, p.mm_per_px, fast_config());
  const auto touch = [](auto& loc) {
    return [&loc](const auto& frame, const auto& moved) {
      return moved ? loc.touch(frame, *moved) : loc.touch(frame);
    };
  };
  for (std::size_t q = 0; q < 2; ++q) {
    CAPTURE(q);
    shadowed.reset();
    plain.reset();
    const auto with_shadow = run_gecko_sequence(q, 80 + q, touch(shadowed));
    const auto with_support = run_gecko_sequence(q, 80 + q, touch(plain));
    double moved = 0.0;
    for (std::size_t t = 0; t < with_shadow.size(); ++t) {
      CAPTURE(t);
      REQUIRE(!with_shadow[t].restarted);
      CHECK(with_shadow[t].probability_other_object == doctest::Approx(0.5).epsilon(1e-4));
      moved = std::max(moved, std::abs(with_support[t].probability_other_object - 0.5));
    }
    CHECK(moved > 0.1);
  }
}

TEST_CASE("localizer: P(not this object) rises on touches of another object, falls on its own") {
  const auto& p = tacmap_test::gecko();
  const auto other = blobs(p.map.rows(), p.map.cols(), 11);
  // The support model (the default) and the shadow model with its fitted weights.
  auto shadow = fast_config();
  shadow.open_set.model = tacmap::unknown_model::shadow;
  for (const auto& config : {fast_config(), shadow})
    for (std::size_t q = 0; q < 3; ++q) {
      CAPTURE(q);
      CAPTURE(static_cast<int>(config.open_set.model));
      // The gecko's touches on the photograph of another object (the wrong-object case).
      tacmap::localizer wrong(other, p.mm_per_px, config);
      const auto on_other =
          run_gecko_sequence(q, 70 + q, [&](const auto& frame, const auto& moved) {
            return moved ? wrong.touch(frame, *moved) : wrong.touch(frame);
          });
      tacmap::localizer right(p.map, p.mm_per_px, config);
      const auto on_own = run_gecko_sequence(q, 70 + q, [&](const auto& frame, const auto& moved) {
        return moved ? right.touch(frame, *moved) : right.touch(frame);
      });
      for (const auto& r : on_other) CHECK(r.verdict != tacmap::verdict::localized);
      CHECK(on_other.back().probability_other_object > 0.9);
      CHECK(on_own.back().probability_other_object < 0.01);
      CHECK(on_own.back().verdict == tacmap::verdict::localized);
      for (const auto& r : on_own)
        if (r.probability_other_object > 1.0 - config.confidence.threshold)
          CHECK(r.verdict != tacmap::verdict::localized);
    }
}

TEST_CASE(
    "open_set, the shipped model: noise raises P(not this object), the object's own map "
    "lowers it, each touch by a (S - d)") {
  // The measurement model the open set was fitted with (the default configuration, see below). Each
  // touch moves the log odds of "not this object" by exactly -a (S - d), S the touch's reported
  // support: a first touch (a nearly uniform prediction, S near 0) raises P(not this object)
  // whatever the map. A surface of random noise is nothing the gecko's touches can fit where the
  // arm's motion says: P(not this object) ends high. On the gecko's own map it falls to nearly 0.
  // The memoryless model (a = 1, d = 0), a factor of the wrong sign or one that ignored the
  // support would each fail here.
  // The open set's a and d were fitted with the map described as the sensor sees it (the default
  // pad_spread_mm, half the pitch). Blurred, the white noise has texture at the touch's scale
  // and the gecko's touches find chance fits on it: sequence 0 ends at P(not this object) 0.85
  // (sequence 1 above 0.9), hence "high" is 0.8 here. The fit on the unblurred map (a = 0.645,
  // d = 0.769) ended sequence 0 at 0.78.
  const auto& p = tacmap_test::gecko();
  const tacmap::localizer_config config;
  tacmap::sim_rng rng(5);
  tacmap::image<float> noise(p.map.rows(), p.map.cols());
  for (Eigen::Index i = 0; i < noise.size(); ++i)
    noise.data()[i] = static_cast<float>(rng.uniform());
  const double prior = config.open_set.prior_unknown;
  const double a = config.open_set.evidence_weight, d = config.open_set.support_margin;
  const auto logit = [](double q) { return std::log(q) - std::log1p(-q); };
  for (std::size_t q = 0; q < 2; ++q) {
    CAPTURE(q);
    tacmap::localizer on_noise(noise, p.mm_per_px, config), on_own(p.map, p.mm_per_px, config);
    const auto touch = [](auto& loc) {
      return [&loc](const auto& frame, const auto& moved) {
        return moved ? loc.touch(frame, *moved) : loc.touch(frame);
      };
    };
    const auto noisy = run_gecko_sequence(q, 120 + q, touch(on_noise));
    const auto own = run_gecko_sequence(q, 120 + q, touch(on_own));
    for (const auto* run : {&noisy, &own}) {
      double before = logit(prior);
      for (const auto& r : *run) {
        REQUIRE(!r.restarted);
        const double after = logit(r.probability_other_object);
        CHECK(after - before == doctest::Approx(-a * (r.log_prediction_support - d)).epsilon(1e-6));
        before = after;
      }
      CHECK(run->front().probability_other_object > prior);
    }
    for (const auto& r : noisy) CHECK(r.verdict != tacmap::verdict::localized);
    CHECK(noisy.back().probability_other_object > 0.8);
    CHECK(noisy.back().probability_other_object > noisy.front().probability_other_object);
    CHECK(own.back().probability_other_object < 0.01);
    CHECK(own.back().verdict == tacmap::verdict::localized);
  }
}

TEST_CASE("the verdict refuses what the closed set claims while P(unknown) is high") {
  // The same touches on the gecko's own map and on a library holding it: nearly closed (prior
  // 1e-9) the front doors claim "localized"; with a prior of 1 - 1e-6 the touches' evidence
  // leaves P(unknown) high for several touches, and every one of those claims is withdrawn.
  const auto& p = tacmap_test::gecko();
  auto closed = fast_config(), wary = fast_config();
  closed.open_set.prior_unknown = 1e-9;
  wary.open_set.prior_unknown = 1.0 - 1e-6;
  auto maps = library_without_gecko();
  maps.push_back({"gecko", p.map, p.mm_per_px});
  std::size_t withdrawn = 0;
  for (std::size_t q = 0; q < 3; ++q) {
    CAPTURE(q);
    tacmap::localizer a(p.map, p.mm_per_px, closed), b(p.map, p.mm_per_px, wary);
    tacmap::library_localizer la(maps, closed), lb(maps, wary);
    const auto touch = [](auto& loc) {
      return [&loc](const auto& frame, const auto& moved) {
        return moved ? loc.touch(frame, *moved) : loc.touch(frame);
      };
    };
    const auto ra = run_gecko_sequence(q, 90 + q, touch(a));
    const auto rb = run_gecko_sequence(q, 90 + q, touch(b));
    const auto rla = run_gecko_sequence(q, 90 + q, touch(la));
    const auto rlb = run_gecko_sequence(q, 90 + q, touch(lb));
    for (std::size_t t = 0; t < ra.size(); ++t) {
      CAPTURE(t);
      // The filter is the same: only the verdict and the reported probabilities differ.
      CHECK(ra[t].position_mm == rb[t].position_mm);
      CHECK(ra[t].probability_within == rb[t].probability_within);
      CHECK(rla[t].position_mm == rlb[t].position_mm);
      CHECK(rla[t].object_probability[3] / (1.0 - rla[t].probability_unknown) ==
            doctest::Approx(rlb[t].object_probability[3] / (1.0 - rlb[t].probability_unknown)));
      CHECK(rb[t].probability_other_object > ra[t].probability_other_object);
      if (rb[t].probability_other_object > 0.1) {
        CHECK(rb[t].verdict != tacmap::verdict::localized);
        if (ra[t].verdict == tacmap::verdict::localized) ++withdrawn;
      }
      if (rlb[t].probability_unknown > 0.1) {
        CHECK(rlb[t].verdict != tacmap::verdict::localized);
        if (rla[t].verdict == tacmap::verdict::localized) ++withdrawn;
      }
    }
    // Enough touches on the right object outweigh even that prior.
    CHECK(rb.back().probability_other_object < 0.5);
  }
  CHECK(withdrawn > 0);
}

}  // namespace test_open_set
