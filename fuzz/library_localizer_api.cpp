// Fuzz target: tacmap::library_localizer's public API — one to three small maps (each its own
// size, content and scale, names that may repeat), an optional prior and library scale, a random
// localizer_config, then touches (with no motion or with odometry), resets and per-object belief
// queries, all decoded from the input (localizer_input.hpp).
//
// Besides "no crash, no sanitizer report", it checks:
//  * only std::invalid_argument or std::domain_error escapes, each with a message;
//  * a touch that throws leaves the belief and the touch count as they were;
//  * every library_touch_result is free of NaN: the object and appearance posteriors are
//    distributions, the most probable object is the most probable one and named, tied objects
//    are as probable, probability_within is a probability not above the object's, the position
//    is finite, log_prediction_support finite unless the filter restarted;
//  * the most probable object's conditioned belief is finite, non-negative and sums to 1.
//
// A built library is cached under the bytes that described it, as in localizer_api.cpp
// (TACMAP_FUZZ_NO_CACHE=1 turns the cache off).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fuzz_check.hpp"
#include "fuzz_input.hpp"
#include "localizer_input.hpp"
#include "tacmap/library_localizer.hpp"

namespace {

using tacmap_fuzz::input;

std::map<std::vector<std::uint8_t>, std::unique_ptr<tacmap::library_localizer>>& cache() {
  static std::map<std::vector<std::uint8_t>, std::unique_ptr<tacmap::library_localizer>> c;
  return c;
}

bool cache_on() {
  static const bool on = std::getenv("TACMAP_FUZZ_NO_CACHE") == nullptr;
  return on;
}

void check_result(const tacmap::library_localizer& loc, const tacmap::library_touch_result& r,
                  std::size_t touches) {
  using tacmap_fuzz::probability;
  TACMAP_FUZZ_CHECK((r.verdict == tacmap::verdict::rejected_frame) == !r.accepted());
  TACMAP_FUZZ_CHECK(r.object >= 0 && r.object < loc.objects());
  TACMAP_FUZZ_CHECK(r.object_name == loc.filter().grid().object_name(r.object));
  TACMAP_FUZZ_CHECK(static_cast<Eigen::Index>(r.object_probability.size()) == loc.objects());
  tacmap_fuzz::check_distribution(r.object_probability);
  const double leader = r.object_probability[static_cast<std::size_t>(r.object)];
  for (const double p : r.object_probability) TACMAP_FUZZ_CHECK(p <= leader);
  for (const Eigen::Index k : r.tied_objects) {
    TACMAP_FUZZ_CHECK(k >= 0 && k < loc.objects() && k != r.object);
    TACMAP_FUZZ_CHECK(std::abs(r.object_probability[static_cast<std::size_t>(k)] - leader) <=
                      1e-5 * leader);
  }
  tacmap_fuzz::check_distribution(r.appearance_probability);
  TACMAP_FUZZ_CHECK(r.position_mm.allFinite());
  TACMAP_FUZZ_CHECK_MSG(probability(r.probability_within) &&
                            r.probability_within <= leader + tacmap_fuzz::sum_tolerance,
                        "probability_within %.17g, object posterior %.17g", r.probability_within,
                        leader);
  TACMAP_FUZZ_CHECK_MSG(!std::isnan(r.log_prediction_support) &&
                            (r.restarted || std::isfinite(r.log_prediction_support)),
                        "log_prediction_support %g, restarted %d", r.log_prediction_support,
                        static_cast<int>(r.restarted));
  TACMAP_FUZZ_CHECK(r.touches == touches);
}

/// The belief vector and touch count, to check that a refused touch changed nothing.
struct snapshot {
  Eigen::ArrayXf belief;
  explicit snapshot(const tacmap::library_localizer& loc) : belief(loc.filter().belief()) {}
  [[nodiscard]] bool same(const tacmap::library_localizer& loc) const {
    const auto& now = loc.filter().belief();
    return now.size() == belief.size() && (now == belief).all();
  }
};

void run_ops(input& in, tacmap::library_localizer& loc, const tacmap::taxel_geometry& sensor) {
  std::size_t touches = 0;  // what the result must report: accepted frames since reset
  for (int step = 0; step < 24 && !in.empty(); ++step) {
    const std::uint8_t op = in.byte();
    const snapshot before(loc);
    std::optional<tacmap::library_touch_result> r;
    const tacmap_fuzz::refusal threw = tacmap_fuzz::refused([&] {
      switch (op % 6) {
        case 0:
          r = loc.touch(tacmap_fuzz::read_frame(in, sensor));
          break;
        case 1:
        case 2:
        case 3: {
          const tacmap::odometry moved{.dx_mm = in.real(-10.0, 10.0),
                                       .dy_mm = in.real(-10.0, 10.0)};
          r = loc.touch(tacmap_fuzz::read_frame(in, sensor), moved);
          break;
        }
        case 4:
          loc.reset();
          touches = 0;
          break;
        default: {  // a frame of another sensor
          tacmap::tactile_frame f = tacmap_fuzz::read_frame(in, sensor);
          f.geometry.rows += 1;
          r = loc.touch(f);
          break;
        }
      }
    });
    if (threw != tacmap_fuzz::refusal::none) {
      // A refused call changes nothing (the touches are all or nothing, as in localizer_api).
      TACMAP_FUZZ_CHECK_MSG(before.same(loc), "operation %d (step %d) threw, belief changed",
                            op % 6, step);
      continue;
    }
    if (!r) continue;
    if (r->accepted()) ++touches;
    check_result(loc, *r, touches);
    // The leader's belief, conditioned on it (its posterior is > 0: it leads).
    tacmap_fuzz::check_belief(loc.object_belief_image(r->object));
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  input in(data, size);
  const std::size_t start = in.position();
  tacmap::localizer_config config = tacmap_fuzz::read_config(in);
  if (in.byte() < 224) config.headings = 0;  // the library refuses others: rarely test that
  const tacmap::taxel_geometry sensor = tacmap_fuzz::read_sensor(in);
  const int objects = in.between(0, 3);
  std::vector<tacmap::library_map> maps;
  for (int k = 0; k < objects; ++k) {
    tacmap::library_map m;
    m.name = in.byte() < 240 ? "object " + std::to_string(k) : "object";
    m.mm_per_px = in.real(1.0, 4.0);
    m.map = tacmap_fuzz::read_map(in);
    maps.push_back(std::move(m));
  }
  std::vector<double> prior;
  if (in.byte() >= 224)
    for (int k = 0; k < objects; ++k) prior.push_back(in.real(0.0, 1.0));
  const std::optional<double> scale = in.byte() >= 224 ? in.maybe_real(1.0, 4.0) : std::nullopt;
  std::vector<std::uint8_t> key = in.read_since(start);

  tacmap::library_localizer* loc = nullptr;
  std::unique_ptr<tacmap::library_localizer> own;
  if (cache_on()) {
    if (const auto hit = cache().find(key); hit != cache().end()) {
      if (!hit->second) return 0;  // refused before
      loc = hit->second.get();
      loc->reset();
    }
  }
  if (loc == nullptr) {
    const bool refused = tacmap_fuzz::throws_documented([&] {
      own = std::make_unique<tacmap::library_localizer>(maps, config, sensor, prior, scale);
    });
    if (refused) TACMAP_FUZZ_CHECK(own == nullptr);
    if (cache_on()) {
      if (cache().size() >= 256) cache().clear();
      auto& entry = cache()[std::move(key)];
      entry = std::move(own);
      loc = entry.get();
    } else {
      loc = own.get();
    }
    if (loc == nullptr) return 0;
    TACMAP_FUZZ_CHECK(loc->objects() == objects);
    TACMAP_FUZZ_CHECK(loc->filter().belief().allFinite());
  }
  run_ops(in, *loc, sensor);
  return 0;
}
