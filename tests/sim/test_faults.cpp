// Exploration faults (sim/faults.hpp) and what the experiment does with them.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "gecko_protocol.hpp"
#include "tacmap/sim/experiment.hpp"
#include "tacmap/sim/faults.hpp"
#include "tacmap/sim/protocol.hpp"
#include "test_support.hpp"

namespace test_faults {

using tacmap_test::message_of;

namespace {

using tacmap_test::gecko;

tacmap::planar_grid<float> gecko_positions() {
  return {gecko().map_size(), gecko().mm_per_px, tacmap::tactile_window({}, gecko().mm_per_px)};
}

// A fast configuration (SIFT-lite on the shared dense field) whose moves are off by 8 mm with
// probability p.
tacmap::localization_config outlier_config(double p) {
  tacmap::localization_config config;
  config.model = tacmap::measurement_kind::lite;
  config.features = tacmap::window_features::shared_dense;
  config.faults.outlier_probability = p;
  config.faults.outlier_mm = 8.0;
  return config;
}

}  // namespace

TEST_CASE("faults: none leaves the protocol's truth and odometry as they are") {
  tacmap::sim_rng rng(1);
  const auto& seq = gecko().sequences[3];
  const auto f = tacmap::apply_faults(gecko(), seq, gecko_positions(), {}, rng);
  REQUIRE(f.truth.size() == seq.size());
  for (std::size_t t = 0; t < seq.size(); ++t) {
    CHECK(f.truth[t] == gecko().locations[seq[t].location]);
    CHECK(f.reported[t].dx_mm == seq[t].measured_motion.dx_mm);
    CHECK(f.reported[t].dy_mm == seq[t].measured_motion.dy_mm);
    CHECK(f.outlier[t] == 0);
  }
}

TEST_CASE("faults: outliers are off by their size; noise has its sigma") {
  tacmap::exploration_faults outliers;
  outliers.outlier_probability = 1.0;
  outliers.outlier_mm = 8.0;
  tacmap::exploration_faults noisy;
  noisy.odometry_sigma_mm = 3.0;
  double sum2 = 0.0;
  std::size_t moves = 0;
  for (std::size_t q = 0; q < gecko().sequences.size(); ++q) {
    const auto& seq = gecko().sequences[q];
    tacmap::sim_rng a(q), b(q);
    const auto o = tacmap::apply_faults(gecko(), seq, gecko_positions(), outliers, a);
    const auto n = tacmap::apply_faults(gecko(), seq, gecko_positions(), noisy, b);
    for (std::size_t t = 1; t < seq.size(); ++t) {
      CHECK(o.outlier[t] == 1);
      CHECK(std::hypot(o.reported[t].dx_mm - seq[t].measured_motion.dx_mm,
                       o.reported[t].dy_mm - seq[t].measured_motion.dy_mm) == doctest::Approx(8.0));
      const double ex = n.reported[t].dx_mm - seq[t].true_motion.dx_mm;
      const double ey = n.reported[t].dy_mm - seq[t].true_motion.dy_mm;
      sum2 += ex * ex + ey * ey;
      moves += 2;
    }
  }
  // 2 x 132 axis errors: the sample sigma within 15 % of 3 mm.
  CHECK(std::sqrt(sum2 / static_cast<double>(moves)) == doctest::Approx(3.0).epsilon(0.15));
}

TEST_CASE("faults: a slip and a kidnap move every later touch by one offset, on the map") {
  const auto positions = gecko_positions();
  for (std::size_t q = 0; q < gecko().sequences.size(); ++q) {
    const auto& seq = gecko().sequences[q];
    tacmap::exploration_faults slip;
    slip.slip_touch = 4;
    slip.slip_mm = 20.0;
    tacmap::exploration_faults kidnap;
    kidnap.kidnap_touch = 3;
    tacmap::sim_rng a(q + 10), b(q + 10);
    const auto s = tacmap::apply_faults(gecko(), seq, positions, slip, a);
    const auto k = tacmap::apply_faults(gecko(), seq, positions, kidnap, b);
    CHECK(s.slipped);
    CHECK_FALSE(k.slipped);
    for (std::size_t t = 0; t < seq.size(); ++t) {
      const auto& loc = gecko().locations[seq[t].location];
      CHECK(s.reported[t].dx_mm == seq[t].measured_motion.dx_mm);  // odometry does not see it
      const double dx = s.truth[t].x_mm - loc.x_mm, dy = s.truth[t].y_mm - loc.y_mm;
      if (t < 3) {
        CHECK(dx == 0.0);
        CHECK(dy == 0.0);
      } else {
        CHECK(std::hypot(dx, dy) == doctest::Approx(20.0));
        CHECK(dx == doctest::Approx(s.truth[3].x_mm - gecko().locations[seq[3].location].x_mm));
        CHECK(positions.nearest_state(s.truth[t].x_mm, s.truth[t].y_mm).has_value());
      }
      const double kx = k.truth[t].x_mm - loc.x_mm;
      if (t < 2)
        CHECK(kx == 0.0);
      else {
        CHECK(kx == doctest::Approx(k.truth[2].x_mm - gecko().locations[seq[2].location].x_mm));
        CHECK(positions.nearest_state(k.truth[t].x_mm, k.truth[t].y_mm).has_value());
      }
    }
  }
}

TEST_CASE("faults: out-of-range settings are refused with the value") {
  tacmap::exploration_faults f;
  f.outlier_probability = 1.5;
  CHECK(message_of([&] {
          f.validate();
        }).find("outlier_probability = 1.5; expected a probability in [0, 1]") !=
        std::string::npos);
  f = {};
  f.slip_touch = 1;
  CHECK(message_of([&] {
          f.validate();
        }).find("slip_touch = 1; expected 0 (no slip) or a touch >= 2") != std::string::npos);
  f = {};
  f.odometry_sigma_mm = -1.0;
  CHECK(message_of([&] { f.validate(); }).find("odometry_sigma_mm = -1") != std::string::npos);
  f = {};
  f.oracle = tacmap::fault_oracle::told;
  CHECK(message_of([&] { f.validate(); })
            .find("the told oracle with outlier_probability = 0 and no slip; expected outliers "
                  "or a slip") != std::string::npos);
  f.slip_touch = 4;
  CHECK_NOTHROW(f.validate());
  f.oracle = tacmap::fault_oracle::transition;
  CHECK(message_of([&] {
          f.validate();
        }).find("the transition oracle with outlier_probability = 0; expected outliers") !=
        std::string::npos);
  f = {};
  f.kidnap_touch = 40;
  tacmap::sim_rng rng(1);
  CHECK(message_of([&] {
          (void)tacmap::apply_faults(gecko(), gecko().sequences[0], gecko_positions(), f, rng);
        }).find("a fault at touch 40 of a sequence of 7 touches") != std::string::npos);
}

TEST_CASE("recovered: back below the threshold within so many touches, and staying") {
  std::vector<tacmap::touch_record> r(8);
  const double errors[] = {1, 1, 1, 20, 15, 3, 2, 1};
  for (std::size_t i = 0; i < r.size(); ++i) r[i].error_mm = errors[i];
  CHECK(tacmap::recovered(r, 4, 3));  // below from touch 6
  CHECK(tacmap::recovered(r, 4, 2));
  CHECK_FALSE(tacmap::recovered(r, 4, 1));
  r[7].error_mm = 9;  // lost again at the end
  CHECK_FALSE(tacmap::recovered(r, 4, 3));
}

TEST_CASE("experiment: odometry that carries the belief off the map restarts it, no abort") {
  tacmap::localization_config config;
  config.model = tacmap::measurement_kind::lite;
  config.features = tacmap::window_features::shared_dense;
  config.faults.outlier_probability = 1.0;
  config.faults.outlier_mm = 100.0;  // larger than the map: every move leaves it
  config.lost_probability = 0.0;     // the paper's motion model: trusts the odometry
  tacmap::localization_experiment paper(gecko(), config);
  const auto run = paper.run(0);
  REQUIRE(run.touches.size() == gecko().sequences[0].size());
  bool any = false;
  for (const auto& t : run.touches) any = any || t.lost_track;
  CHECK(any);
  // With a floor under the motion the belief is re-spread instead: nothing is refused.
  config.lost_probability = 0.001;
  tacmap::localization_experiment robust(gecko(), config);
  for (const auto& t : robust.run(0).touches) CHECK_FALSE(t.lost_track);
}

TEST_CASE("outlier oracle: the ring moves mass by the outlier's size in every direction") {
  // A 120 px map at the paper's 1.13 mm per px: 103 x 79 positions, two appearance planes.
  tacmap::image<float> map(120, 120);
  for (Eigen::Index r = 0; r < map.rows(); ++r)
    for (Eigen::Index c = 0; c < map.cols(); ++c)
      map(r, c) = static_cast<float>((r * 7 + c * 13) % 17) / 17.0F;
  auto filter = tacmap::make_planar_filter({}, map, 3.4 / 3.0, {.width = 18, .height = 42});
  const auto& grid = filter.grid();
  const Eigen::Index rows = grid.rows(), cols = grid.cols(), plane = rows * cols;
  REQUIRE(filter.belief().size() == 2 * plane);
  const Eigen::Index centre = (rows / 2) * cols + cols / 2;
  const Eigen::Vector2d at = grid.state_mm(centre).head<2>();
  for (const double share : {1.0, 0.25}) {
    CAPTURE(share);
    Eigen::ArrayXd prior = Eigen::ArrayXd::Zero(2 * plane);
    prior(centre) = 0.75;          // appearance 0
    prior(plane + centre) = 0.25;  // appearance 1: each plane on its own
    filter.set_prior(prior);
    tacmap::detail::spread_over_ring(filter, 8.0, share);
    const auto& b = filter.belief();
    CHECK(static_cast<double>(b.sum()) == doctest::Approx(1.0).epsilon(1e-5));
    CHECK(static_cast<double>(b.head(plane).sum()) == doctest::Approx(0.75).epsilon(1e-5));
    CHECK(static_cast<double>(b(centre)) == doctest::Approx(0.75 * (1.0 - share)).epsilon(1e-5));
    // The moved mass: at 8 mm from where it was (bilinear splats: within a pitch), its mean
    // where it was (the ring is symmetric).
    double moved = 0, distance = 0, far = 0;
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (Eigen::Index i = 0; i < plane; ++i) {
      if (i == centre) continue;
      const double p = static_cast<double>(b(i));
      const Eigen::Vector2d d = grid.state_mm(i).head<2>() - at;
      moved += p;
      distance += p * d.norm();
      mean += p * d;
      if (std::abs(d.norm() - 8.0) > 3.4 / 3.0 * 1.5) far += p;
    }
    CHECK(moved == doctest::Approx(0.75 * share).epsilon(1e-5));
    CHECK(distance / moved == doctest::Approx(8.0).epsilon(0.03));
    CHECK(mean.norm() / moved < 0.01);
    CHECK(far == doctest::Approx(0.0));
  }
}

TEST_CASE("faults: a slip no direction keeps on the map is dropped, and says so") {
  // 100 mm on the 136 x 136 mm gecko (positions span about 116 x 89 mm): a sequence whose later
  // touches lie apart cannot slip that far.
  const auto positions = gecko_positions();
  tacmap::exploration_faults slip;
  slip.slip_touch = 2;
  slip.slip_mm = 100.0;
  int dropped = 0;
  for (std::size_t q = 0; q < gecko().sequences.size(); ++q) {
    const auto& seq = gecko().sequences[q];
    tacmap::sim_rng rng(q + 10);
    const auto s = tacmap::apply_faults(gecko(), seq, positions, slip, rng);
    const auto& loc = gecko().locations[seq[1].location];
    const double moved = std::hypot(s.truth[1].x_mm - loc.x_mm, s.truth[1].y_mm - loc.y_mm);
    CHECK(moved == doctest::Approx(s.slipped ? 100.0 : 0.0));
    dropped += s.slipped ? 0 : 1;
  }
  CHECK(dropped > 0);
}

TEST_CASE("outlier oracle: told which moves are outliers, only those moves change") {
  // A third of the moves off by 8 mm: the told filter's touches are those of the filter not
  // told, bit for bit, up to the first outlier; that touch differs (the belief was spread).
  auto config = outlier_config(0.3);
  tacmap::localization_experiment plain(gecko(), config);
  config.faults.oracle = tacmap::fault_oracle::told;
  tacmap::localization_experiment told(gecko(), config);
  int compared = 0;
  for (std::size_t s = 0; s < gecko().sequences.size(); ++s) {
    const auto a = plain.run(s).touches, b = told.run(s).touches;
    REQUIRE(a.size() == b.size());
    for (std::size_t t = 0; t < a.size(); ++t) {
      CAPTURE(s);
      CAPTURE(t);
      REQUIRE(a[t].odometry_outlier == b[t].odometry_outlier);
      if (a[t].odometry_outlier) {
        CHECK(a[t].entropy_nats != b[t].entropy_nats);
        ++compared;
        break;
      }
      CHECK(a[t].entropy_nats == b[t].entropy_nats);
      CHECK(a[t].error_mm == b[t].error_mm);
    }
  }
  CHECK(compared > 5);
}

TEST_CASE("outlier oracle: told which moves are outliers, the filter follows them better") {
  // Every move off by 8 mm; the same sequences with and without being told which moves (all).
  auto config = outlier_config(1.0);
  double error[2] = {0.0, 0.0};
  for (const auto oracle : {tacmap::fault_oracle::none, tacmap::fault_oracle::told}) {
    config.faults.oracle = oracle;
    tacmap::localization_experiment experiment(gecko(), config);
    for (std::size_t s = 0; s < 4; ++s)
      for (const auto& t : experiment.run(s).touches)
        error[oracle == tacmap::fault_oracle::told] += t.error_mm;
  }
  MESSAGE("summed error, not told / told: " << error[0] << " / " << error[1] << " mm");
  CHECK(error[1] < 0.5 * error[0]);
}

}  // namespace test_faults
