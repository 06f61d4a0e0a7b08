// The front door at camera resolution: `tacmap::localizer` built from a 640 x 480 photograph, as
// a user builds it, at two scales — 0.283 mm per px (an object about 180 x 136 mm: matched at the
// working resolution, 3 px per taxel, after resampling) and 1.13 mm per px (a 725 x 544 mm
// panel: already at the working resolution, all 640 x 480 px matched) — and on the paper's
// 120 x 120 px grid; known heading and 36 headings. Rows: building the localizer (preparing the
// map), the first touch, a touch once localized (`default`: the default configuration, which
// tracks once localized; `untracked`: localizer_config::tracking empty, every touch the whole
// grid, the default before tracking was turned on).
//
// The photographs: the bench texture (bench_maps.hpp) at 1.13 mm per px, enlarged to 640 x 480
// px for the fine one (the same object seen by a closer camera: texture the sensor can feel at
// both scales). Touches are frames from the simulator pressing the photograph's relief (height =
// intensity x 4 mm) at its own scale. Counter `localized`: the share of timed touches whose
// verdict was `localized` (the timing is of a localized filter when it is 1).
#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "bench_maps.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/sim/gecko.hpp"
#include "tacmap/sim/tactile_simulator.hpp"

namespace {

constexpr double panel_mm_per_px = 3.4 / 3.0;
constexpr double photo_mm_per_px = 3.4 / 12.0;  // 0.283: 640 px = 181 mm

// case 0: 640 x 480 at 0.283 mm/px; 1: 640 x 480 at 1.13 mm/px; 2: the paper's 120 x 120 at 1.13.
struct photograph {
  tacmap::image<float> pixels;
  double mm_per_px;
};

const photograph& photo(int which) {
  static const std::vector<photograph> all = [] {
    std::vector<photograph> p;
    p.push_back({tacmap::rescale(tacmap_bench::bench_map(120, 160), panel_mm_per_px,
                                 panel_mm_per_px * 160.0 / 640.0),
                 panel_mm_per_px * 160.0 / 640.0});
    p.push_back({tacmap_bench::bench_map(480, 640), panel_mm_per_px});
    p.push_back({tacmap::make_gecko_map(), panel_mm_per_px});
    return p;
  }();
  return all.at(static_cast<std::size_t>(which));
}

// Frames at the corners of a 4 mm square at the photograph's centre, in path order (right, down,
// left, up: a walk in both directions tells the heading too).
constexpr double square_mm[4][2] = {{0.0, 0.0}, {4.0, 0.0}, {4.0, 4.0}, {0.0, 4.0}};

std::vector<tacmap::tactile_frame> frames(int which) {
  const photograph& p = photo(which);
  tacmap::tactile_simulator sim(p.pixels * 4.0F,
                                {.width = p.pixels.cols(), .height = p.pixels.rows()}, p.mm_per_px,
                                {.seed = 7});
  const double x = 0.5 * static_cast<double>(p.pixels.cols()) * p.mm_per_px;
  const double y = 0.5 * static_cast<double>(p.pixels.rows()) * p.mm_per_px;
  std::vector<tacmap::tactile_frame> out;
  for (const auto& corner : square_mm)
    out.push_back(sim.render({.x_mm = x + corner[0], .y_mm = y + corner[1]}));
  return out;
}

// The move from corner k to corner k + 1 (sensor frame = map frame at heading 0).
tacmap::sensor_odometry step_from(std::size_t k) {
  const std::size_t n = (k + 1) % 4;
  return {.du_mm = square_mm[n][0] - square_mm[k][0], .dv_mm = square_mm[n][1] - square_mm[k][1]};
}

tacmap::localizer_config config_for(int headings, bool tracked) {
  tacmap::localizer_config c;
  c.headings = headings;
  if (!tracked) c.tracking.reset();
  return c;
}

// One localizer per (photograph, headings, tracked), built once and kept: 640 x 480 at 1.13 with
// 36 headings holds a few hundred MB.
tacmap::localizer& localizer_for(int which, int headings, bool tracked) {
  static std::map<std::tuple<int, int, bool>, std::unique_ptr<tacmap::localizer>> built;
  auto& slot = built[{which, headings, tracked}];
  if (!slot)
    slot = std::make_unique<tacmap::localizer>(photo(which).pixels, photo(which).mm_per_px,
                                               config_for(headings, tracked));
  return *slot;
}

// Building the localizer from the photograph: resampling to the working resolution and
// preparing the map.
void localizer_build(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  const int headings = static_cast<int>(state.range(1));
  const photograph& p = photo(which);
  const tacmap::localizer_config c = config_for(headings, true);
  for (auto _ : state) {
    tacmap::localizer loc(p.pixels, p.mm_per_px, c);
    benchmark::DoNotOptimize(&loc);
  }
  state.counters["working_px"] =
      static_cast<double>(tacmap::localizer(p.pixels, p.mm_per_px, c).map().size());
}

// The first touch of an exploration (a uniform belief; the reset outside the timing).
void localizer_first_touch(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  const int headings = static_cast<int>(state.range(1));
  tacmap::localizer& loc = localizer_for(which, headings, true);
  const auto touches = frames(which);
  for (auto _ : state) {
    state.PauseTiming();
    loc.reset();
    state.ResumeTiming();
    benchmark::DoNotOptimize(loc.touch(touches[0]).position_mm);
  }
}

// A touch once localized: twelve touches around the square first, then on around it, each with
// the arm's motion (in the sensor's frame for 36 headings: heading 0).
void localizer_touch_localized(benchmark::State& state, bool tracked) {
  const int which = static_cast<int>(state.range(0));
  const int headings = static_cast<int>(state.range(1));
  tacmap::localizer& loc = localizer_for(which, headings, tracked);
  const auto touches = frames(which);
  loc.reset();
  (void)loc.touch(touches[0]);
  std::size_t at = 0;
  const auto next = [&] {
    const tacmap::sensor_odometry moved = step_from(at);
    at = (at + 1) % 4;
    return loc.touch(touches[at], moved);
  };
  for (int k = 0; k < 11; ++k) (void)next();
  double localized = 0.0, tracked_path = 0.0, count = 0.0;
  for (auto _ : state) {
    const tacmap::touch_result r = next();
    localized += r.verdict == tacmap::verdict::localized ? 1.0 : 0.0;
    tracked_path += r.path == tacmap::update_path::tracked ? 1.0 : 0.0;
    count += 1.0;
  }
  state.counters["localized"] = localized / count;
  // The share of timed touches that took the tracked path (0 untracked).
  state.counters["tracked"] = tracked_path / count;
}
void localizer_touch_localized_default(benchmark::State& state) {
  localizer_touch_localized(state, true);
}
void localizer_touch_localized_untracked(benchmark::State& state) {
  localizer_touch_localized(state, false);
}

// Args: {photograph (0: 640 x 480 at 0.283, 1: 640 x 480 at 1.13, 2: paper 120 x 120), headings}.
void cases(benchmark::internal::Benchmark* b) {
  b->ArgNames({"photo", "headings"});
  for (const int which : {0, 1, 2})
    for (const int headings : {0, 36}) b->Args({which, headings});
}

}  // namespace

BENCHMARK(localizer_build)->Apply(cases)->Unit(benchmark::kMillisecond);
BENCHMARK(localizer_first_touch)->Apply(cases)->Unit(benchmark::kMillisecond);
BENCHMARK(localizer_touch_localized_default)->Apply(cases)->Unit(benchmark::kMicrosecond);
BENCHMARK(localizer_touch_localized_untracked)->Apply(cases)->Unit(benchmark::kMicrosecond);
