// Tests of the working resolution (localizer_config::working_mm_per_px): a photograph finer than
// the sensor resolves is matched at a few pixels per taxel, positions stay in its millimetres;
// a coarse one is used as it is with a warning, a too coarse one refused; the library prepares
// its maps in parallel on an executor with the same models as one after the other.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "tacmap/executor/thread_pool.hpp"
#include "tacmap/library_localizer.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/sim/random.hpp"
#include "tacmap/sim/tactile_simulator.hpp"
#include "test_support.hpp"

namespace test_working_resolution {

namespace {

constexpr double pitch = 3.4;  // the default sensor's

// An object `width_mm` x `height_mm` photographed at `mm_per_px`: 40 smooth blobs of 3-8 mm
// radius, drawn in millimetres, so that every scale shows the same object. Values in [0, 1].
tacmap::image<float> blobs(double width_mm, double height_mm, double mm_per_px,
                           std::uint64_t seed) {
  const auto rows = static_cast<Eigen::Index>(std::lround(height_mm / mm_per_px));
  const auto cols = static_cast<Eigen::Index>(std::lround(width_mm / mm_per_px));
  tacmap::sim_rng rng(seed);
  tacmap::image<float> out = tacmap::image<float>::Zero(rows, cols);
  for (int b = 0; b < 40; ++b) {
    const double x = rng.uniform() * width_mm, y = rng.uniform() * height_mm;
    const double radius = 3.0 + 5.0 * rng.uniform(), amplitude = 0.3 + 0.7 * rng.uniform();
    for (Eigen::Index r = 0; r < rows; ++r)
      for (Eigen::Index c = 0; c < cols; ++c) {
        const double dx = (static_cast<double>(c) + 0.5) * mm_per_px - x;
        const double dy = (static_cast<double>(r) + 0.5) * mm_per_px - y;
        out(r, c) +=
            static_cast<float>(amplitude * std::exp(-(dx * dx + dy * dy) / (2 * radius * radius)));
      }
  }
  return out / out.maxCoeff();
}

// The intensity-weighted centroid of `img` at `mm_per_px`, mm.
Eigen::Vector2d centroid_mm(const tacmap::image<float>& img, double mm_per_px) {
  double sx = 0, sy = 0, total = 0;
  for (Eigen::Index r = 0; r < img.rows(); ++r)
    for (Eigen::Index c = 0; c < img.cols(); ++c) {
      const double v = img(r, c);
      sx += v * (static_cast<double>(c) + 0.5) * mm_per_px;
      sy += v * (static_cast<double>(r) + 0.5) * mm_per_px;
      total += v;
    }
  return {sx / total, sy / total};
}

// Sequences of 6 touches on `photo` (at `mm_per_px`), pressed by the simulator on its relief at
// that scale, localized by `loc`: how many end within 5 mm of the truth.
int localized_sequences(tacmap::localizer& loc, const tacmap::image<float>& photo, double mm_per_px,
                        int sequences) {
  const double w = static_cast<double>(photo.cols()) * mm_per_px;
  const double h = static_cast<double>(photo.rows()) * mm_per_px;
  const double half_w = 3 * pitch, half_h = 7 * pitch;
  tacmap::sim_rng rng(17);
  int within = 0;
  for (int s = 0; s < sequences; ++s) {
    tacmap::tactile_simulator sim(photo * 4.0F, {.width = photo.cols(), .height = photo.rows()},
                                  mm_per_px, {.seed = rng.next_u64()});
    loc.reset();
    tacmap::map_pose at{};
    tacmap::touch_result r;
    for (int t = 0; t < 6; ++t) {
      const tacmap::map_pose to{.x_mm = half_w + rng.uniform() * (w - 2 * half_w),
                                .y_mm = half_h + rng.uniform() * (h - 2 * half_h)};
      const auto frame = sim.render(to);
      r = t == 0 ? loc.touch(frame)
                 : loc.touch(frame, tacmap::odometry{.dx_mm = to.x_mm - at.x_mm,
                                                     .dy_mm = to.y_mm - at.y_mm});
      at = to;
    }
    within += (r.position_mm - Eigen::Vector2d(at.x_mm, at.y_mm)).norm() <= 5.0 ? 1 : 0;
  }
  return within;
}

}  // namespace

TEST_CASE("working resolution: a fine photograph is matched at pitch / 3, in its own millimetres") {
  // 120 x 90 mm at 0.25 mm per px: 480 x 360 px, resampled to the default 3 px per taxel.
  const double fine = 0.25;
  const tacmap::image<float> photo = blobs(120.0, 90.0, fine, 3);
  tacmap::localizer_config config;
  config.model = tacmap::measurement_kind::ncc;  // cheap: the scale, not the model, is tested
  tacmap::localizer loc(photo, fine, config);
  CHECK(loc.photo_mm_per_px() == fine);
  // The longer side a whole number of working pixels: 120 mm / (3.4 / 3) = 105.9 -> 106 px.
  CHECK(loc.map().cols() == 106);
  CHECK(loc.mm_per_px() == doctest::Approx(120.0 / 106.0));
  // The shorter side whole working pixels too: 90 mm / (120 / 106) = 79.5 -> 79 (the last
  // 0.57 mm left out), so that both axes have the one scale.
  CHECK(loc.map().rows() == 79);
  CHECK(loc.config().preprocessing.mm_per_px == loc.mm_per_px());
  CHECK(loc.window().height == 42);  // 14 taxels x 3 px
  CHECK(loc.warnings().empty());
  // The working map shows the object where the photograph does, in millimetres: a smooth spot
  // at (80, 60) mm is at (80, 60) mm on it to 0.05 mm (one scale on both axes; stretching the
  // 79.5 px side to 80 px would put it 0.4 mm lower).
  tacmap::image<float> spot(photo.rows(), photo.cols());
  for (Eigen::Index r = 0; r < spot.rows(); ++r)
    for (Eigen::Index c = 0; c < spot.cols(); ++c) {
      const double dx = (static_cast<double>(c) + 0.5) * fine - 80.0;
      const double dy = (static_cast<double>(r) + 0.5) * fine - 60.0;
      spot(r, c) = static_cast<float>(std::exp(-(dx * dx + dy * dy) / (2.0 * 4.0 * 4.0)));
    }
  const tacmap::localizer spotted(spot, fine, config);
  CHECK((centroid_mm(spot, fine) - Eigen::Vector2d(80.0, 60.0)).norm() < 0.01);
  CHECK((centroid_mm(spotted.map(), spotted.mm_per_px()) - Eigen::Vector2d(80.0, 60.0)).norm() <
        0.05);
  // Positions are the photograph's millimetres: the grid spans its extent.
  const auto& g = loc.positions();
  const Eigen::Index last = g.size() - 1;
  const double right_edge =
      g.state_mm(last).x() + 0.5 * static_cast<double>(g.window_size().width) * loc.mm_per_px();
  CHECK(right_edge == doctest::Approx(120.0).epsilon(1e-9));
  // Matching at full resolution is a setting away.
  tacmap::localizer_config full = config;
  full.working_mm_per_px = fine;
  tacmap::localizer as_is(photo, fine, full);
  CHECK(as_is.mm_per_px() == fine);
  CHECK(as_is.map().cols() == photo.cols());
}

TEST_CASE("working resolution: touches on a fine photograph are localized at its millimetres") {
  // The default model (classic_sift, latent appearance) on an 100 x 80 mm object photographed
  // at 0.4 mm per px; the simulator presses it at that scale, the localizer matches at 1.13.
  const double fine = 0.4;
  const tacmap::image<float> photo = blobs(100.0, 80.0, fine, 11);
  tacmap::localizer loc(photo, fine);
  REQUIRE(loc.mm_per_px() > 1.1);
  CHECK(localized_sequences(loc, photo, fine, 3) == 3);
}

TEST_CASE("working resolution: as accurate as matching at full resolution on a small map") {
  // 80 x 60 mm at 0.567 mm per px (6 px per taxel): the default working resolution (3) against
  // the photograph's own, the same sequences. Measured on held-out photographs (docs/
  // photographs.md) the working resolution localizes more; here it must not localize fewer
  // than one sequence less.
  const double fine = pitch / 6.0;
  const tacmap::image<float> photo = blobs(80.0, 60.0, fine, 23);
  tacmap::localizer working(photo, fine);
  tacmap::localizer_config full_config;
  full_config.working_mm_per_px = fine;
  tacmap::localizer full(photo, fine, full_config);
  CHECK(static_cast<double>(working.map().cols() * 2) ==
        doctest::Approx(static_cast<double>(full.map().cols())).epsilon(0.02));
  const int at_working = localized_sequences(working, photo, fine, 4);
  const int at_full = localized_sequences(full, photo, fine, 4);
  CHECK(at_working >= at_full - 1);
  CHECK(at_working >= 3);
}

TEST_CASE("working resolution: a coarse photograph is used as it is, with a warning") {
  tacmap::localizer_config config;
  config.model = tacmap::measurement_kind::ncc;
  const double coarse = 1.5;  // 2.27 px per taxel
  const tacmap::image<float> photo = blobs(120.0, 90.0, coarse, 5);
  tacmap::localizer loc(photo, coarse, config);
  CHECK(loc.mm_per_px() == coarse);
  CHECK(loc.map().cols() == photo.cols());
  REQUIRE(loc.warnings().size() == 1);
  CHECK(loc.warnings()[0].find("1.5 mm per px is coarser than the working resolution") !=
        std::string::npos);
  // At the working resolution exactly (3.4 / 3, however it is written): no warning.
  const tacmap::image<float> at_working = blobs(120.0, 90.0, pitch / 3.0, 5);
  CHECK(tacmap::localizer(at_working, 1.1333333333333333, config).warnings().empty());
}

TEST_CASE("working resolution: fewer than 2 px per taxel is refused, naming the scale") {
  const tacmap::image<float> photo = blobs(200.0, 150.0, 2.0, 7);
  const std::string message = tacmap_test::message_of([&] { tacmap::localizer loc(photo, 2.0); });
  CHECK(message.find("the photograph's scale is 2 mm per px") != std::string::npos);
  CHECK(message.find("expected at most 1.7 mm per px") != std::string::npos);
  tacmap::localizer_config config;
  config.working_mm_per_px = 2.5;
  const std::string setting = tacmap_test::message_of(
      [&] { tacmap::localizer loc(blobs(120.0, 90.0, 0.5, 7), 0.5, config); });
  CHECK(setting.find("working_mm_per_px = 2.5") != std::string::npos);
  config.working_mm_per_px = -1.0;
  CHECK(tacmap_test::message_of([&] { config.validate(); }).find("working_mm_per_px = -1") !=
        std::string::npos);
  // A setting outside the scales the models stay finite at is refused with the range.
  config.working_mm_per_px = 2e3;
  const std::string range = tacmap_test::message_of([&] { config.validate(); });
  CHECK(range.find("working_mm_per_px = 2000") != std::string::npos);
  CHECK(range.find("in [1e-06, 1000]") != std::string::npos);
  // A sensor whose default working scale (pitch / 3) would leave that range: the default stops
  // at its end, so a valid photograph builds and is matched at 1000 mm per px.
  const tacmap::taxel_geometry giant{.rows = 14, .cols = 6, .pitch_mm = 3600.0};
  CHECK(tacmap::localizer_config{}.working_scale(giant) == 1e3);
  const tacmap::image<float> field = blobs(120.0, 90.0, 1.0, 7);
  tacmap::localizer_config ncc;
  ncc.model = tacmap::measurement_kind::ncc;
  const double km = 800.0;  // the same 120 x 90 px photograph as a 96 x 72 km field
  const tacmap::localizer huge(field, km, ncc, giant);
  CHECK(huge.mm_per_px() == doctest::Approx(1e3).epsilon(0.01));
  CHECK(huge.photo_mm_per_px() == km);
  // The library refuses such a map by name.
  const std::vector<tacmap::library_map> maps{{"board", photo, 2.0}};
  const std::string library = tacmap_test::message_of([&] { tacmap::library_localizer loc(maps); });
  CHECK(library.find("'board'") != std::string::npos);
  CHECK(library.find("expected at most 1.7 mm per px") != std::string::npos);
}

TEST_CASE("working resolution: the library matches fine photographs at it, prepared in parallel") {
  tacmap::localizer_config config;
  config.model = tacmap::measurement_kind::lite;
  config.features = tacmap::window_features::shared_dense;
  const std::vector<tacmap::library_map> maps{{"a", blobs(90.0, 70.0, 0.5, 31), 0.5},
                                              {"b", blobs(80.0, 80.0, 0.6, 37), 0.6},
                                              {"c", blobs(70.0, 90.0, 0.45, 41), 0.45}};
  tacmap::library_localizer serial(maps, config);
  CHECK(serial.mm_per_px() == doctest::Approx(pitch / 3.0));
  CHECK(serial.warnings().empty());
  tacmap::thread_pool_executor pool(2);
  tacmap::library_localizer parallel(maps, config, {}, {}, {}, {}, pool);
  // The same models: the same likelihoods, so the same beliefs bit for bit.
  tacmap::tactile_simulator sim(maps[1].map * 4.0F,
                                {.width = maps[1].map.cols(), .height = maps[1].map.rows()},
                                maps[1].mm_per_px, {.seed = 3});
  const auto frame = sim.render({.x_mm = 40.0, .y_mm = 40.0});
  const auto a = serial.touch(frame), b = parallel.touch(frame);
  CHECK(a.object_probability == b.object_probability);
  for (Eigen::Index k = 0; k < serial.objects(); ++k)
    CHECK((serial.object_belief_image(k) == parallel.object_belief_image(k)).all());
  CHECK(serial.filter().belief().size() == parallel.filter().belief().size());
}

}  // namespace test_working_resolution
