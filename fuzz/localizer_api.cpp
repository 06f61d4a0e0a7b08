// Fuzz target: tacmap::localizer's public API — a random localizer_config, sensor, small map and
// scale, then a sequence of touches (with no motion, map-frame odometry, sensor-frame odometry or
// arm poses), resets and belief queries, all decoded from the input (localizer_input.hpp).
//
// Besides "no crash, no sanitizer report", it checks:
//  * only std::invalid_argument or std::domain_error escapes, each with a message;
//  * a call that throws leaves the belief and the touch count as they were;
//  * every touch_result is free of NaN: probabilities in [0, 1], positions, covariance and
//    entropy finite (entropy at most log of the state count), the appearance posteriors a
//    distribution, the verdict "rejected_frame" exactly when the frame was rejected, and
//    log_prediction_support finite unless the filter restarted;
//  * the belief stays finite, non-negative and sums to 1 (per heading layer too); reset() makes
//    it uniform again.
//
// Speed: a built localizer is cached under the bytes that described it (a few dozen), so inputs
// that differ only in their touches skip the preparation; each reuse starts with reset(), which
// must restore the state of a new localizer. TACMAP_FUZZ_NO_CACHE=1 in the environment turns the
// cache off (to confirm that a finding does not depend on it).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <map>
#include <memory>
#include <vector>

#include "fuzz_check.hpp"
#include "fuzz_input.hpp"
#include "localizer_input.hpp"
#include "tacmap/localizer.hpp"

namespace {

using tacmap_fuzz::input;

struct built {
  std::unique_ptr<tacmap::localizer> loc;  // null: the description was refused
};

std::map<std::vector<std::uint8_t>, built>& cache() {
  static std::map<std::vector<std::uint8_t>, built> c;
  return c;
}

bool cache_on() {
  static const bool on = std::getenv("TACMAP_FUZZ_NO_CACHE") == nullptr;
  return on;
}

void check_result(const tacmap::localizer& loc, const tacmap::touch_result& r) {
  using tacmap_fuzz::probability;
  TACMAP_FUZZ_CHECK((r.verdict == tacmap::verdict::rejected_frame) == !r.accepted());
  TACMAP_FUZZ_CHECK(r.position_mm.allFinite() && r.most_probable_mm.allFinite());
  TACMAP_FUZZ_CHECK(r.covariance_mm2.allFinite());
  TACMAP_FUZZ_CHECK(r.covariance_mm2(0, 0) >= -1e-9 && r.covariance_mm2(1, 1) >= -1e-9);
  TACMAP_FUZZ_CHECK(std::isfinite(r.heading_rad));
  TACMAP_FUZZ_CHECK(probability(r.probability_within) && probability(r.heading_probability));
  const auto states = static_cast<double>(loc.belief().size()) *
                      std::max(1, loc.config().headings) *
                      static_cast<double>(r.appearance_probability.size());
  TACMAP_FUZZ_CHECK_MSG(std::isfinite(r.entropy_nats) && r.entropy_nats >= -1e-6 &&
                            r.entropy_nats <= std::log(states) + 1e-3,
                        "entropy %.17g nats over %.0f states", r.entropy_nats, states);
  tacmap_fuzz::check_distribution(r.appearance_probability);
  TACMAP_FUZZ_CHECK_MSG(
      !std::isnan(r.log_prediction_support) && !std::isnan(r.log_marginal_likelihood) &&
          r.log_marginal_likelihood < std::numeric_limits<double>::infinity() &&
          (r.restarted || std::isfinite(r.log_prediction_support)),
      "log_prediction_support %g, log_marginal_likelihood %g, restarted %d",
      r.log_prediction_support, r.log_marginal_likelihood, static_cast<int>(r.restarted));
  TACMAP_FUZZ_CHECK(r.touches == loc.touches());
}

/// Belief and touch count, to check that a refused call changed nothing.
struct snapshot {
  tacmap::image<float> belief;
  std::size_t touches = 0;
  explicit snapshot(const tacmap::localizer& loc) : belief(loc.belief()), touches(loc.touches()) {}
  bool same(const tacmap::localizer& loc) const {
    const tacmap::image<float> now = loc.belief();
    return touches == loc.touches() && now.rows() == belief.rows() && now.cols() == belief.cols() &&
           (now == belief).all();
  }
};

void run_ops(input& in, tacmap::localizer& loc) {
  const tacmap::taxel_geometry sensor = loc.sensor();
  for (int step = 0; step < 24 && !in.empty(); ++step) {
    const std::uint8_t op = in.byte();
    const snapshot before(loc);
    tacmap::touch_result r;
    bool touched = false;
    const tacmap_fuzz::refusal threw = tacmap_fuzz::refused([&] {
      switch (op % 8) {
        case 0:
          r = loc.touch(tacmap_fuzz::read_frame(in, sensor));
          touched = true;
          break;
        case 1:
        case 2: {
          const tacmap::odometry moved{.dx_mm = in.real(-10.0, 10.0),
                                       .dy_mm = in.real(-10.0, 10.0)};
          r = loc.touch(tacmap_fuzz::read_frame(in, sensor), moved);
          touched = true;
          break;
        }
        case 3: {
          const tacmap::sensor_odometry moved{.du_mm = in.real(-10.0, 10.0),
                                              .dv_mm = in.real(-10.0, 10.0),
                                              .dtheta_rad = in.flag() ? in.real(-0.5, 0.5) : 0.0};
          r = loc.touch(tacmap_fuzz::read_frame(in, sensor), moved);
          touched = true;
          break;
        }
        case 4:
        case 5: {
          const tacmap::arm_pose where{.x_mm = in.real(-50.0, 50.0),
                                       .y_mm = in.real(-50.0, 50.0),
                                       .theta_rad = in.real(-0.1, 0.1)};
          r = loc.touch_at(tacmap_fuzz::read_frame(in, sensor), where);
          touched = true;
          break;
        }
        case 6: {
          loc.reset();
          TACMAP_FUZZ_CHECK(loc.touches() == 0);
          const tacmap::image<float> b = loc.belief();
          tacmap_fuzz::check_belief(b);
          TACMAP_FUZZ_CHECK(b.maxCoeff() - b.minCoeff() <= 1e-6F * b.maxCoeff());
          break;
        }
        default: {  // a frame of another sensor
          tacmap::tactile_frame f = tacmap_fuzz::read_frame(in, sensor);
          f.geometry.pitch_mm *= 1.5;
          r = loc.touch(f);
          touched = true;
          break;
        }
      }
    });
    if (threw != tacmap_fuzz::refusal::none) {
      // A refused call changes nothing: the touches are all or nothing (detail::localizer_step
      // restores the belief and the counters, also when the update throws after the motion was
      // predicted).
      TACMAP_FUZZ_CHECK_MSG(before.same(loc),
                            "operation %d (step %d) threw, touches %zu -> %zu, belief changed",
                            op % 8, step, before.touches, loc.touches());
      continue;
    }
    tacmap_fuzz::check_belief(loc.belief());
    if (touched) check_result(loc, r);
  }
  // Per heading: the layers together are the belief.
  const std::vector<tacmap::image<float>> layers = loc.heading_belief();
  TACMAP_FUZZ_CHECK(static_cast<int>(layers.size()) == std::max(1, loc.config().headings));
  double sum = 0.0;
  for (const auto& layer : layers) {
    TACMAP_FUZZ_CHECK(layer.allFinite() && (layer >= 0.0F).all());
    sum += layer.cast<double>().sum();
  }
  TACMAP_FUZZ_CHECK_MSG(std::abs(sum - 1.0) < tacmap_fuzz::sum_tolerance,
                        "heading layers sum to %.17g", sum);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  input in(data, size);
  const std::size_t start = in.position();
  const tacmap::localizer_config config = tacmap_fuzz::read_config(in);
  const tacmap::taxel_geometry sensor = tacmap_fuzz::read_sensor(in);
  const double mm_per_px = in.real(1.0, 4.0);
  tacmap::image<float> map = tacmap_fuzz::read_map(in);
  std::vector<std::uint8_t> key = in.read_since(start);

  tacmap::localizer* loc = nullptr;
  std::unique_ptr<tacmap::localizer> own;
  if (cache_on()) {
    if (const auto hit = cache().find(key); hit != cache().end()) {
      if (!hit->second.loc) return 0;  // refused before
      loc = hit->second.loc.get();
      loc->reset();
    }
  }
  if (loc == nullptr) {
    const bool refused = tacmap_fuzz::throws_documented([&] {
      own = std::make_unique<tacmap::localizer>(std::move(map), mm_per_px, config, sensor);
    });
    if (refused) TACMAP_FUZZ_CHECK(own == nullptr);
    if (cache_on()) {
      if (cache().size() >= 256) cache().clear();
      auto& entry = cache()[std::move(key)];
      entry.loc = std::move(own);
      loc = entry.loc.get();
    } else {
      loc = own.get();
    }
    if (loc == nullptr) return 0;
    // A new localizer: uniform belief, no touches.
    TACMAP_FUZZ_CHECK(loc->touches() == 0);
    tacmap_fuzz::check_belief(loc->belief());
  }
  run_ops(in, *loc);
  return 0;
}
