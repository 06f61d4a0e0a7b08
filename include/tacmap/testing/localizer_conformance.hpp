// tacmap: a user's descriptor checked INSIDE the front door (doctest): what
// `descriptor_localizer<D>` (tacmap/localizer.hpp) does with it, beyond what the descriptor
// conformance suite (tacmap/testing/conformance.hpp) checks of D alone.
//
// Usage, in ONE test translation unit of your project (doctest's main elsewhere):
//
//   #include <doctest/doctest.h>
//   #include <tacmap/testing/localizer_conformance.hpp>
//   TEST_CASE_TEMPLATE_INVOKE(tacmap_localizer_conformance, my_descriptor);
//   // or, with your own descriptor value and configuration (e.g. your fitted tau):
//   TEST_CASE("my descriptor in the localizer") {
//     tacmap::testing::check_in_localizer(my_descriptor{...}, config);
//   }
//
// The map is the conformance suite's test pattern at the taxels' resolution, with a lattice of
// pixels at 1 and 0 so that every touch's peak-normalised image IS its window of the map (up to
// the borders' interpolation); the touches are raw frames of the paper's 14 x 6 array, pressed
// at taxel-aligned places with exact odometry. Checked, each with what it would catch:
//  * the first touch is accepted and leaves a normalised belief (the descriptor plugs in);
//  * after ten touches along a path the verdict is "localized" within the verdict's radius of
//    the truth (the descriptor tells windows apart well enough for the filter's verdict);
//  * with the paper's motion (no floor), a move off the map restarts the filter, counted by
//    `restarts()` (the shared step's restart);
//  * touches whose raised parts are the pattern's DARK parts: the "inverted" appearance
//    hypothesis wins and the track is localized (the latent appearance, through the contrast
//    hook where D declares one, else the inverted touch described).
// D must tolerate the peak normalisation of touches (scale changes) only as far as every
// localizer does: here each touch's peak is exactly the map's, so raw intensities work too.
#pragma once

#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "tacmap/localizer.hpp"
#include "tacmap/testing/conformance.hpp"

namespace tacmap::testing {

/// The map of `check_in_localizer` at the taxels' resolution (rows x cols taxels): the test
/// pattern scaled into [0.1, 0.9], with a 1 at every (5i, 5j) and a 0 at every (5i + 2, 5j + 2)
/// so that each 14 x 6 block holds both (its peak is 1, its inversion's too).
[[nodiscard]] inline image<float> localizer_test_taxels(Eigen::Index rows, Eigen::Index cols,
                                                        std::uint32_t seed) {
  image<float> c = 0.1F + 0.8F * conformance_image(rows, cols, seed).array();
  for (Eigen::Index i = 0; i < rows; ++i)
    for (Eigen::Index j = 0; j < cols; ++j) {
      if (i % 5 == 0 && j % 5 == 0) c(i, j) = 1.0F;
      if (i % 5 == 2 && j % 5 == 2) c(i, j) = 0.0F;
    }
  return c;
}

/// The checks in the file comment, for the descriptor value `d` in a localizer configured by
/// `config` (the latent appearance is forced on; the motion model is the config's, except for
/// the restart check, which runs the paper's).
template <descriptor D>
void check_in_localizer(D d = D{}, localizer_config config = {}) {
  config.appearance = appearance_handling::latent;
  const double mm_per_px = 3.4 / 3.0;  // 3 px per taxel pitch
  const taxel_geometry sensor{};       // 14 x 6 at 3.4 mm: a 42 x 18 px window
  const image<float> taxels = localizer_test_taxels(26, 22, 9);
  const image<float> map =
      detail::resize_taxels(taxels, 3 * taxels.rows(), 3 * taxels.cols(), resize_method::bilinear);
  descriptor_localizer<D> loc(map, mm_per_px, config, sensor, d);
  const auto frame_at = [&](Eigen::Index tr, Eigen::Index tc, bool inverted) {
    tactile_frame f;
    f.geometry = sensor;
    const image<float> block = taxels.block(tr, tc, sensor.rows, sensor.cols);
    f.counts = 3000.0F * (inverted ? image<float>(1.0F - block) : block);
    return f;
  };
  const auto truth_mm = [&](Eigen::Index tr, Eigen::Index tc) {
    const auto& g = loc.positions();
    return g.state_mm(g.index(grid_cell{3 * tr, 3 * tc}));
  };
  const std::vector<std::pair<Eigen::Index, Eigen::Index>> path{
      {2, 3}, {5, 3}, {5, 8}, {9, 8}, {9, 12}, {6, 12}, {6, 6}, {3, 6}, {3, 10}, {8, 10}};
  const auto run = [&](bool inverted) {
    loc.reset();
    touch_result r;
    for (std::size_t t = 0; t < path.size(); ++t) {
      const auto [tr, tc] = path[t];
      const tactile_frame f = frame_at(tr, tc, inverted);
      if (t == 0) {
        r = loc.touch(f);
        CHECK_MESSAGE(r.accepted(), "the first touch was rejected");
        CHECK(r.touches == 1);
        const auto b = loc.belief();
        CHECK(b.allFinite());
        CHECK(static_cast<double>(b.sum()) == doctest::Approx(1.0).epsilon(1e-4));
      } else {
        const auto [pr, pc] = path[t - 1];
        r = loc.touch(f, odometry{.dx_mm = 3.4 * static_cast<double>(tc - pc),
                                  .dy_mm = 3.4 * static_cast<double>(tr - pr)});
      }
    }
    const auto [tr, tc] = path.back();
    const double error = (r.position_mm - truth_mm(tr, tc)).norm();
    return std::pair{r, error};
  };

  SUBCASE("touches of the pattern: localized, as photographed") {
    const auto out = run(false);
    const touch_result& r = out.first;
    const double error = out.second;
    CHECK_MESSAGE(r.verdict == verdict::localized, "after 10 touches the verdict is "
                                                       << to_string(r.verdict)
                                                       << " with P = " << r.probability_within);
    CHECK_MESSAGE(error <= config.confidence.radius_mm,
                  "the estimate is " << error << " mm from the truth");
    REQUIRE(r.appearance_probability.size() == 2);
    CHECK(r.appearance_probability[0] > 0.5);
    CHECK(loc.restarts() == 0);
  }

  SUBCASE("touches whose raised parts are the pattern's dark ones: the inverted hypothesis") {
    const auto out = run(true);
    const touch_result& r = out.first;
    const double error = out.second;
    REQUIRE(r.appearance_probability.size() == 2);
    CHECK_MESSAGE(r.appearance_probability[1] > 0.5,
                  "P(inverted) = " << r.appearance_probability[1]
                                   << " after 10 inverted touches: the latent appearance does not "
                                      "reach this descriptor");
    CHECK(r.verdict == verdict::localized);
    CHECK(error <= config.confidence.radius_mm);
  }

  SUBCASE("a move off the map restarts the paper's motion model, counted") {
    localizer_config paper = config;
    paper.lost_probability = 0.0;
    paper.wide_probability = 0.0;
    paper.broad_probability = 0.0;
    descriptor_localizer<D> strict(map, mm_per_px, paper, sensor, d);
    CHECK_FALSE(strict.touch(frame_at(4, 4, false)).restarted);
    const touch_result r = strict.touch(frame_at(4, 4, false), odometry{.dx_mm = 1000.0});
    CHECK(r.restarted);
    CHECK(strict.restarts() == 1);
    CHECK(r.touches == 2);
    CHECK(static_cast<double>(strict.belief().sum()) == doctest::Approx(1.0).epsilon(1e-4));
    strict.reset();
    CHECK(strict.restarts() == 0);
  }
}

}  // namespace tacmap::testing

TEST_CASE_TEMPLATE_DEFINE("tacmap descriptor in the localizer", D, tacmap_localizer_conformance) {
  tacmap::testing::check_in_localizer<D>();
}
