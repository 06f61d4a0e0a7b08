// Every numeric setting of the localizer and of the models it configures is refused outside the
// range in which its model stays finite, with the value and the range in the message; at the
// edges of each range a touch still gives a finite, normalised belief (issue 37, "No silent
// resets"). Its own program, optimised in every build (it prepares a few small localizers).
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "tacmap/library_localizer.hpp"
#include "tacmap/localizer.hpp"
#include "test_support.hpp"

namespace test_setting_ranges {

namespace {

using tacmap_test::message_of;

constexpr double inf = std::numeric_limits<double>::infinity();
const double nan_value = std::numeric_limits<double>::quiet_NaN();

// The message names the setting with its value and the range.
void check_refused(const std::string& message, const std::string& setting,
                   const std::string& range) {
  CAPTURE(message);
  CHECK(message.find(setting) != std::string::npos);
  CHECK(message.find(range) != std::string::npos);
  CHECK(message.find("the range in which the model stays finite") != std::string::npos);
}

template <class Array>
void check_normalised(const Array& b) {
  REQUIRE(b.size() > 0);
  CHECK(b.isFinite().all());
  CHECK(b.minCoeff() >= 0.0F);
  CHECK(b.template cast<double>().sum() == doctest::Approx(1.0).epsilon(1e-5));
}

// A textured 96 x 96 px map at 1 mm per px (the 14 x 6 array at 3.4 mm: a 48 x 20 px window).
tacmap::image<float> texture_map() {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0F, 1.0F);
  tacmap::image<float> m(96, 96);
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c)
      m(r, c) =
          0.5F +
          0.3F * std::sin(0.31F * static_cast<float>(r)) * std::cos(0.23F * static_cast<float>(c)) +
          0.2F * u(rng);
  return m;
}

// A frame that passes the default thresholds: a pattern of counts up to 3000.
tacmap::tactile_frame pattern_frame(int seed) {
  tacmap::tactile_frame f;
  std::mt19937 rng(static_cast<std::uint32_t>(seed));
  std::uniform_real_distribution<float> u(0.0F, 3000.0F);
  for (Eigen::Index r = 0; r < f.counts.rows(); ++r)
    for (Eigen::Index c = 0; c < f.counts.cols(); ++c) f.counts(r, c) = u(rng);
  f.counts(0, 0) = 3000.0F;
  return f;
}

// Three touches with moves between them (in the sensor's frame for unknown heading); the
// belief stays finite and normalised.
void touch_three_times(const tacmap::localizer_config& config) {
  tacmap::localizer loc(texture_map(), 1.0, config);
  for (int t = 0; t < 3; ++t) {
    CAPTURE(t);
    const tacmap::touch_result r =
        t == 0                ? loc.touch(pattern_frame(t))
        : config.headings > 0 ? loc.touch(pattern_frame(t), tacmap::sensor_odometry{1.3, -0.7, 0.2})
                              : loc.touch(pattern_frame(t), tacmap::odometry{1.3, -0.7});
    CHECK(r.accepted());
    CHECK(std::isfinite(r.entropy_nats));
    CHECK(std::isfinite(r.probability_within));
    check_normalised(loc.belief());
  }
}

}  // namespace

TEST_CASE("the motion models refuse noise outside their finite range, naming value and range") {
  for (const double bad : {1e-160, 0.0, -1.0, 9.9e-4, 1.1e6, 1e300, nan_value, inf}) {
    CAPTURE(bad);
    check_refused(message_of([&] { (void)tacmap::odometry_gaussian({.sigma_mm = bad}); }),
                  "odometry_gaussian: sigma_mm = ", "in [0.001, 1000000] mm");
    check_refused(message_of([&] { (void)tacmap::pose_odometry_gaussian({.sigma_mm = bad}); }),
                  "sigma_mm = ", "in [0.001, 1000000] mm");
  }
  check_refused(message_of([] { (void)tacmap::odometry_gaussian({.sigma_mm = 1e-160}); }),
                "sigma_mm = 1e-160", "[0.001, 1000000]");
  for (const double bad : {1e-300, 0.0, 9.9e-7, 1e300, nan_value}) {
    CAPTURE(bad);
    check_refused(message_of([&] { (void)tacmap::pose_odometry_gaussian({.sigma_rad = bad}); }),
                  "pose_odometry_gaussian: sigma_rad = ", "in [1e-06, 1000000] rad");
  }
  for (const double bad : {1e-300, 0.0, 9.9e-4, 1000.5, nan_value}) {
    CAPTURE(bad);
    check_refused(message_of([&] {
                    tacmap::robust_motion_params{.wide_probability = 0.1,
                                                 .wide_sigma_mm = bad == 1000.5 ? 100.5 : bad}
                        .validate();
                  }),
                  "wide_sigma_mm = ", "in [0.001, 100] mm");
    check_refused(
        message_of([&] {
          tacmap::robust_motion_params{.broad_probability = 0.1, .broad_sigma_mm = bad}.validate();
        }),
        "broad_sigma_mm = ", "in [0.001, 1000] mm");
  }
}

TEST_CASE("the likelihoods refuse a tau, tempering or epsilon that overflows a float touch") {
  for (const double bad : {1e-300, 0.0, -0.1, 9.9e-7, 1.1e6, nan_value, inf}) {
    CAPTURE(bad);
    check_refused(message_of([&] { tacmap::descriptor_likelihood_params{.tau = bad}.validate(); }),
                  "descriptor_likelihood_params: tau = ", "in [1e-06, 1000000]");
    check_refused(message_of([&] { tacmap::ncc_params{.tau = bad}.validate(); }),
                  "ncc_params: tau = ", "in [1e-06, 1000000]");
    check_refused(message_of([&] { tacmap::rotated_likelihood_params{.tau = bad}.validate(); }),
                  "tau = ", "in [1e-06, 1000000]");
  }
  for (const double bad : {1e300, 1000.5, -1e-9, nan_value, inf}) {
    CAPTURE(bad);
    check_refused(
        message_of([&] { tacmap::descriptor_likelihood_params{.tempering = bad}.validate(); }),
        "descriptor_likelihood_params: tempering = ", "in [0, 1000]");
    check_refused(message_of([&] { tacmap::ncc_params{.tempering = bad}.validate(); }),
                  "ncc_params: tempering = ", "in [0, 1000]");
    check_refused(
        message_of([&] { tacmap::rotated_likelihood_params{.tempering = bad}.validate(); }),
        "tempering = ", "in [0, 1000]");
  }
  for (const double bad : {1e-300, 0.0, 1e31, nan_value}) {
    CAPTURE(bad);
    check_refused(
        message_of([&] { tacmap::descriptor_likelihood_params{.epsilon = bad}.validate(); }),
        "descriptor_likelihood_params: epsilon = ", "in [1e-30, 1e+30]");
  }
  // The edges themselves are accepted.
  tacmap::descriptor_likelihood_params{.epsilon = 1e-30, .tau = 1e-6, .tempering = 1e3}.validate();
  tacmap::descriptor_likelihood_params{.epsilon = 1e30, .tau = 1e6, .tempering = 0.0}.validate();
  tacmap::ncc_params{.tau = 1e-6, .tempering = 1e3}.validate();
}

TEST_CASE("localizer_config::validate refuses each degenerate setting up front, naming it") {
  const auto refused = [](auto change, const std::string& setting, const std::string& range) {
    tacmap::localizer_config c;
    change(c);
    check_refused(message_of([&] { c.validate(); }), setting, range);
    // ... and so does the localizer's constructor, before preparing anything.
    check_refused(message_of([&] { tacmap::localizer loc(texture_map(), 1.0, c); }), setting,
                  range);
  };
  // The three: each made every touch -inf/NaN or "moved all mass off the grid", and the
  // localizer restarted silently.
  refused([](auto& c) { c.motion_sigma_mm = 1e-160; }, "localizer_config: motion_sigma_mm = 1e-160",
          "in [0.001, 1000000] mm");
  refused([](auto& c) { c.tempering = 1e300; }, "localizer_config: tempering = 1e+300",
          "in [0, 1000]");
  refused([](auto& c) { c.tau = 1e-300; }, "localizer_config: tau = 1e-300", "in [1e-06, 1000000]");
  refused([](auto& c) { c.motion_sigma_mm = nan_value; }, "motion_sigma_mm = nan",
          "in [0.001, 1000000] mm");
  refused([](auto& c) { c.tempering = -1.0; }, "tempering = -1", "in [0, 1000]");
  refused([](auto& c) { c.tau = 2e6; }, "tau = 2000000", "in [1e-06, 1000000]");
  refused(
      [](auto& c) {
        c.headings = 36;
        c.turn_sigma_rad = 1e-300;
      },
      "localizer_config: turn_sigma_rad = 1e-300", "in [1e-06, 1000000] rad");
  refused([](auto& c) { c.wide_sigma_mm = 1e-300; }, "wide_sigma_mm = 1e-300",
          "in [0.001, 100] mm");
  refused([](auto& c) { c.pad_spread_mm = -1e-9; }, "localizer_config: pad_spread_mm = -1e-09",
          "in [0, 100] mm");
  refused([](auto& c) { c.pad_spread_mm = nan_value; }, "pad_spread_mm = nan", "in [0, 100] mm");
  refused(
      [](auto& c) {
        c.broad_probability = 0.05;
        c.broad_sigma_mm = 1e-300;
      },
      "broad_sigma_mm = 1e-300", "in [0.001, 1000] mm");
  // Settings refused without a range of their own, also up front.
  tacmap::localizer_config c;
  c.motion_k = 7;
  CHECK(message_of([&] { c.validate(); }).find("k = 7 neighbours is not supported") !=
        std::string::npos);
  c = {};
  c.patch_spacing = 0;
  CHECK(message_of([&] { c.validate(); }).find("patch_spacing = 0") != std::string::npos);
  c = {};
  c.preprocessing.min_peak = std::numeric_limits<float>::quiet_NaN();
  CHECK(message_of([&] { c.validate(); }).find("min_peak = nan") != std::string::npos);
}

TEST_CASE("at the edges of every range a localizer's touches stay finite and normalised") {
  // A localizer whose descriptors are cheap to prepare; each edge on its own.
  tacmap::localizer_config base;
  base.model = tacmap::measurement_kind::lite;
  base.features = tacmap::window_features::shared_dense;
  SUBCASE("the sharpest likelihood: tau 1e-6, tempering 1e3") {
    auto c = base;
    c.tau = 1e-6;
    c.tempering = 1e3;
    touch_three_times(c);
    c.model = tacmap::measurement_kind::ncc;
    touch_three_times(c);
  }
  SUBCASE("the flattest likelihood: tau 1e6, tempering 0") {
    auto c = base;
    c.tau = 1e6;
    touch_three_times(c);
    c.tempering = 0.0;
    touch_three_times(c);
  }
  SUBCASE("the paper's configuration at the smallest and largest motion noise") {
    for (const double sigma : {1e-3, 1e6}) {
      CAPTURE(sigma);
      auto c = tacmap::localizer_config::paper();
      c.features = tacmap::window_features::shared_dense;
      c.motion_sigma_mm = sigma;
      touch_three_times(c);
    }
  }
  SUBCASE("the narrowest and widest robust components, the widest confidence disc") {
    auto c = base;
    c.wide_sigma_mm = 1e-3;
    c.broad_probability = 0.05;
    c.broad_sigma_mm = 1e-3;
    touch_three_times(c);
    c.wide_sigma_mm = 100.0;
    c.broad_sigma_mm = 1000.0;
    c.confidence.radius_mm = 1e300;  // the disc covers the grid (was an integer overflow)
    touch_three_times(c);
  }
  SUBCASE("the map as photographed and blurred by the widest sensor spread, 100 mm") {
    for (const double spread : {0.0, 100.0}) {
      CAPTURE(spread);
      auto c = base;
      c.pad_spread_mm = spread;
      touch_three_times(c);
    }
  }
  SUBCASE("unknown heading at the smallest and largest turn noise") {
    for (const double sigma : {1e-6, 1e6}) {
      CAPTURE(sigma);
      auto c = base;
      c.features = tacmap::window_features::per_window;
      c.headings = 4;
      c.turn_sigma_rad = sigma;
      touch_three_times(c);
    }
  }
}

TEST_CASE("the motion stencils stay finite when the noise is far below a grid's pitch") {
  // sigma 1e-3 mm on a grid of 1e160 mm per px: sigma^2 in pixels underflows to 0, and the
  // stencils' 1 / (2 sigma^2) used to make every weight NaN ("moves all mass off the grid").
  using grid_t = tacmap::planar_grid<float>;
  const grid_t g({.width = 12, .height = 10}, 1e160, {.width = 3, .height = 3});
  Eigen::ArrayXf in = Eigen::ArrayXf::Zero(g.size());
  in(g.size() / 2) = 0.75F;
  in(3) = 0.25F;
  for (const int k : {8, 12}) {  // the separable and the general stencil
    CAPTURE(k);
    const tacmap::odometry_gaussian m({.sigma_mm = 1e-3, .k = k});
    Eigen::ArrayXf out(g.size());
    const tacmap::prediction_report r = m.predict(g, in, out, {.dx_mm = 0.0, .dy_mm = 0.0});
    check_normalised(out);
    CHECK(r.mass_lost == 0.0);
    CHECK(out(g.size() / 2) == doctest::Approx(0.75F));  // a delta stencil: nothing moves
  }
  // The robust broad component's blur on blocks of that grid: no blur, no NaN.
  tacmap::robust_motion<tacmap::odometry_gaussian> robust(
      tacmap::odometry_gaussian({.sigma_mm = 1e-3}), {.lost_probability = 0.0,
                                                      .wide_probability = 0.0,
                                                      .broad_probability = 0.1,
                                                      .broad_sigma_mm = 1e-3});
  Eigen::ArrayXf out(g.size());
  (void)robust.predict(g, in, out, {.dx_mm = 0.0, .dy_mm = 0.0});
  check_normalised(out);
  CHECK(out(g.size() / 2) == doctest::Approx(0.75F));
}

TEST_CASE("tactile_window names the scale range for a scale that makes the window overflow") {
  const tacmap::taxel_geometry sensor;  // 14 x 6 taxels of 3.4 mm: 47.6 mm long
  for (const double bad : {1e-300, 1e-5}) {
    CAPTURE(bad);
    const std::string m = message_of([&] { (void)tacmap::tactile_window(sensor, bad); });
    CAPTURE(m);
    CHECK(m.find("mm_per_px = ") != std::string::npos);
    CHECK(m.find("expected a scale in [0.0007263183594, infinity) mm per px") != std::string::npos);
    CHECK(m.find("less than one pixel") == std::string::npos);
  }
  // The edge: 47.6 mm / 65536 px is accepted, as the long side's 65536 px.
  CHECK(tacmap::tactile_window(sensor, 47.6 / 65536.0).height == 65536);
  CHECK(message_of([] {
          (void)tacmap::tactile_window(tacmap::taxel_geometry{}, nan_value);
        }).find("mm_per_px = nan") != std::string::npos);
}

TEST_CASE("a map scale outside [1e-6, 1e3] mm per px is refused up front, naming the range") {
  // The fuzz finding (fuzz/README.md, finding 5): a 6 x 6 array of 1e-160 mm taxels on a map of
  // 1e-160 mm per px covers 6 px, so the window check passed; the robust motion's broad spread
  // then came to 1e157 states, past Eigen::Index (undefined behaviour).
  const tacmap::taxel_geometry tiny{.rows = 6, .cols = 6, .pitch_mm = 1e-160};
  for (const double bad : {1e-160, 5e-7, 2e3}) {
    CAPTURE(bad);
    const tacmap::taxel_geometry sensor =
        bad < 1.0 ? tiny : tacmap::taxel_geometry{.rows = 6, .cols = 6, .pitch_mm = 1e4};
    const std::string m =
        message_of([&] { tacmap::localizer loc(texture_map(), bad, {}, sensor); });
    check_refused(m, "localizer: mm_per_px = ", "in [1e-06, 1000] mm per px");
    CHECK(m.find("the map's scale") != std::string::npos);
    check_refused(message_of([&] {
                    tacmap::library_localizer lib({{"a", texture_map(), bad}}, {}, sensor);
                  }),
                  "mm_per_px = ", "in [1e-06, 1000] mm per px");
  }
  // The edges themselves build (a sensor whose footprint fits the 96 px map), each at the
  // default working resolution of 3 px per taxel, so that the map is used as it is.
  tacmap::localizer fine(texture_map(), 1e-6, {}, {.rows = 6, .cols = 6, .pitch_mm = 3e-6});
  CHECK(fine.window().width == 18);
  CHECK(fine.mm_per_px() == 1e-6);
  tacmap::localizer coarse(texture_map(), 1e3, {}, {.rows = 6, .cols = 6, .pitch_mm = 3e3});
  CHECK(coarse.window().width == 18);
  CHECK(coarse.mm_per_px() == 1e3);
}

TEST_CASE("the robust motion's spreads in states are clamped on a grid of 1e-160 mm steps") {
  // A grid built by hand may still have such a step: the wide and broad spreads (10 mm: 1e161
  // states) are clamped before their conversion to Eigen::Index (UBSan flagged it), and a spread
  // far beyond the grid is flat over it.
  using grid_t = tacmap::planar_grid<float>;
  const grid_t g({.width = 12, .height = 10}, 1e-160, {.width = 3, .height = 3});
  Eigen::ArrayXf in = Eigen::ArrayXf::Zero(g.size());
  in(g.size() / 2) = 1.0F;
  tacmap::robust_motion<tacmap::odometry_gaussian> robust(
      tacmap::odometry_gaussian({.sigma_mm = 1e-3}), {.lost_probability = 0.0,
                                                      .wide_probability = 0.2,
                                                      .wide_sigma_mm = 10.0,
                                                      .broad_probability = 0.1,
                                                      .broad_sigma_mm = 10.0});
  Eigen::ArrayXf out(g.size());
  (void)robust.predict(g, in, out, {.dx_mm = 0.0, .dy_mm = 0.0});
  check_normalised(out / out.sum());
}

}  // namespace test_setting_ranges
