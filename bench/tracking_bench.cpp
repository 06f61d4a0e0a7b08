// Tracking mode (issue 14, item 3): the first touch (whole grid) and a touch once localized,
// tracked and full, on a camera-resolution map. The map is 160 x 120 px unless
// TACMAP_BENCH_MAP=<cols>x<rows> (e.g. 640x480) is set: the smoke run under CTest stays cheap,
// since preparing 640 x 480 for the default model takes seconds and ~420 MB per filter.
//
//   TACMAP_BENCH_MAP=640x480 build/release/bench/tacmap_tracking_bench --benchmark_repetitions=5
//
// Unknown heading (pose_*): a pose-grid filter with the rotated classic_sift model over 36
// headings — the first touch, a touch once localized (full and tracked: the model's hook then
// computes only the support's headings and field tiles), and the tracked touch's predict and
// update apart (once settled, neither passes over the whole grid: predict moves the boxes
// around the support's clusters, the update searches only where their mass landed).
//
// The first touch also runs on 2 threads (issue 14, item 5): thread_pool_executor and, where
// tacmap::tbb exists, oneTBB — the same filter, so the ratios are of one run:
//   TACMAP_BENCH_MAP=640x480 build/release/bench/tacmap_tracking_bench
//     --benchmark_filter=plain_first_touch --benchmark_repetitions=15 --benchmark_min_time=0.2
//     --benchmark_enable_random_interleaving=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>
#include <random>
#include <type_traits>
#include <utility>
#include <vector>

#include "bench_maps.hpp"
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/executor/thread_pool.hpp"
#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/grid/pose_grid.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/measurement/descriptor_likelihood.hpp"
#include "tacmap/measurement/rotated_descriptor_likelihood.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"
#include "tacmap/motion/pose_odometry_gaussian.hpp"
#ifdef TACMAP_BENCH_TBB
#include "tacmap/executor/tbb_executor.hpp"
#endif

namespace {

// The map's scale: 0.2 mm/px unless TACMAP_BENCH_MM_PER_PX says otherwise (issue 36's cases:
// 0.28, a 640 x 480 photograph of an object about 180 mm wide; 1.13, a 725 mm panel). It sets
// how many cells robust motion's 3 mm wide component spans.
const double mm_per_px = [] {
  if (const char* env = std::getenv("TACMAP_BENCH_MM_PER_PX")) {
    const double v = std::atof(env);
    if (v > 0.0 && v < 100.0) return v;
  }
  return 0.2;
}();
constexpr tacmap::pixel_size window{.width = 18, .height = 42};

const tacmap::image<float>& map() {
  static const tacmap::image<float> m = [] {
    Eigen::Index cols = 160, rows = 120;
    if (const char* env = std::getenv("TACMAP_BENCH_MAP")) {
      long c = 0, r = 0;
      if (std::sscanf(env, "%ldx%ld", &c, &r) == 2 && c >= 60 && r >= 60) {
        cols = c;
        rows = r;
      }
    }
    return tacmap_bench::bench_map(rows, cols);
  }();
  return m;
}

// The window `dc` px right of the map's centre.
tacmap::image<float> cut(Eigen::Index dc = 0) {
  return map().block(map().rows() / 2 - window.height / 2, map().cols() / 2 + dc, window.height,
                     window.width);
}

// The default descriptor model (classic_sift, per window, aligned, exponential) in the plane.
using plain_filter = tacmap::bayes_filter<tacmap::planar_grid<float>, tacmap::odometry_gaussian,
                                          tacmap::descriptor_likelihood<tacmap::classic_sift>>;

plain_filter& plain() {
  static std::unique_ptr<plain_filter> f = [] {
    const tacmap::planar_grid<float> grid({.width = map().cols(), .height = map().rows()},
                                          mm_per_px, window);
    return std::make_unique<plain_filter>(
        grid, tacmap::odometry_gaussian({.sigma_mm = 1.0, .k = 8}),
        tacmap::descriptor_likelihood<tacmap::classic_sift>(tacmap::classic_sift{}, map(), window));
  }();
  return *f;
}

// The localizer's filter (latent appearance, both signs in one pass), with the default motion
// (floor and wide component) or without them (`floor` false): tracking needs a concentrated
// prediction, which the floor's lost_probability spread over every state is not.
tacmap::planar_localizer_filter& latent(bool floor) {
  static std::unique_ptr<tacmap::planar_localizer_filter> with, without;
  auto& f = floor ? with : without;
  if (!f) {
    tacmap::localizer_config config;
    if (!floor) {
      config.lost_probability = 0.0;
      config.wide_probability = 0.0;
    }
    f = std::make_unique<tacmap::planar_localizer_filter>(
        tacmap::make_planar_filter(config, map(), mm_per_px, window));
  }
  return *f;
}

// Unknown heading: the rotated classic_sift model over 36 headings (10 degree steps), the
// default pose motion. The touch is cut from the map at heading 0 (layer 0).
using pose_filter =
    tacmap::bayes_filter<tacmap::pose_grid<float>, tacmap::pose_odometry_gaussian,
                         tacmap::rotated_descriptor_likelihood<tacmap::classic_sift>>;

pose_filter& pose() {
  static std::unique_ptr<pose_filter> f = [] {
    const tacmap::pose_grid<float> grid(
        tacmap::planar_grid<float>({.width = map().cols(), .height = map().rows()}, mm_per_px,
                                   window),
        36);
    return std::make_unique<pose_filter>(
        grid, tacmap::pose_odometry_gaussian{},
        tacmap::rotated_descriptor_likelihood<tacmap::classic_sift>(tacmap::classic_sift{}, map(),
                                                                    grid));
  }();
  return *f;
}

// 4 px right and back: in the map frame (planar odometry) or the sensor's (pose odometry; the
// touch is at heading 0, so the same move).
template <class Filter>
std::pair<typename Filter::control_type, typename Filter::control_type> moves() {
  if constexpr (std::is_same_v<typename Filter::control_type, tacmap::sensor_odometry>)
    return {{.du_mm = 4 * mm_per_px}, {.du_mm = -4 * mm_per_px}};
  else
    return {{.dx_mm = 4 * mm_per_px}, {.dx_mm = -4 * mm_per_px}};
}

// Localized: three full updates at the touch position.
template <class Filter>
void localize(Filter& f) {
  f.set_tracking({});
  f.reset();
  for (int k = 0; k < 3; ++k) f.update(cut());
}

template <class Filter>
void first_touch(benchmark::State& state, Filter& f) {
  tacmap_bench::time_first_touch(state, f, cut());
}

// The window `dc` px right of the centre with Gaussian noise of sigma 0.05 (the map spans
// [0, 1]), a different draw per `seed`: a touch as a sensor gives it, not an exact cut.
tacmap::image<float> noisy_cut(Eigen::Index dc, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0F, 0.05F);
  tacmap::image<float> z = cut(dc);
  for (float& v : z.reshaped()) v += noise(rng);
  return z;
}

// A touch once localized: predict 4 px right or back, update with the window there (exact
// cuts, or 16 noisy draws of each in turn).
template <class Filter>
void localized_touch(benchmark::State& state, Filter& f, bool tracking, bool noisy = false,
                     double epsilon = 1e-6,
                     std::optional<tacmap::tracking_params> params = std::nullopt) {
  localize(f);
  if (tracking) f.set_tracking(params ? *params : tacmap::tracking_params{.epsilon = epsilon});
  std::vector<tacmap::image<float>> as, bs;
  for (unsigned k = 0; k < (noisy ? 16U : 1U); ++k) {
    as.push_back(noisy ? noisy_cut(0, 2 * k + 1) : cut());
    bs.push_back(noisy ? noisy_cut(4, 2 * k + 2) : cut(4));
  }
  const auto [there, back] = moves<Filter>();
  bool at_a = true;
  std::size_t draw = 0;
  double evaluated = 0.0, tracked = 0.0, touches = 0.0;
  for (auto _ : state) {
    f.predict(at_a ? there : back);
    const tacmap::update_report r = f.update(at_a ? bs[draw] : as[draw]);
    at_a = !at_a;
    if (at_a) draw = (draw + 1) % as.size();
    evaluated += static_cast<double>(r.evaluated_states);
    tracked += r.path == tacmap::update_path::tracked ? 1.0 : 0.0;
    touches += 1.0;
    benchmark::DoNotOptimize(f.belief().data());
  }
  state.counters["evaluated"] = evaluated / touches;
  state.counters["tracked"] = tracked / touches;
  f.set_tracking({});
}

// The parts of a tracked touch: predict alone (after a tracked update only the support's box
// moves: counter `windowed`), update alone.
template <class Filter>
void localized_part(benchmark::State& state, Filter& f, bool update_only) {
  localize(f);
  f.set_tracking({.epsilon = 1e-6});
  const auto a = cut(), b = cut(4);
  const auto [there, back] = moves<Filter>();
  bool at_a = true;
  double windowed = 0.0, touches = 0.0;
  for (auto _ : state) {
    if (update_only) state.PauseTiming();
    windowed += f.predict(at_a ? there : back).windowed ? 1.0 : 0.0;
    touches += 1.0;
    if (update_only) {
      state.ResumeTiming();
      f.update(at_a ? b : a);
    } else {
      state.PauseTiming();
      f.update(at_a ? b : a);
      state.ResumeTiming();
    }
    at_a = !at_a;
    benchmark::DoNotOptimize(f.belief().data());
  }
  state.counters["windowed"] = windowed / touches;
  f.set_tracking({});
}

void plain_first_touch(benchmark::State& state) { first_touch(state, plain()); }
// The first touch with the whole-grid likelihood on an executor of 2 threads (the caller and
// one more), owned here as a user would own it.
template <class Executor>
void first_touch_on(benchmark::State& state, Executor& e) {
  plain().set_executor(e);
  first_touch(state, plain());
  plain().set_executor({});
}
void plain_first_touch_2_threads(benchmark::State& state) {
  tacmap::thread_pool_executor pool(2);
  first_touch_on(state, pool);
}
#ifdef TACMAP_BENCH_TBB
void plain_first_touch_tbb_2_threads(benchmark::State& state) {
  tacmap::tbb_executor tbb(2);
  first_touch_on(state, tbb);
}
#endif
void plain_predict(benchmark::State& state) { localized_part(state, plain(), false); }
void plain_update_tracked(benchmark::State& state) { localized_part(state, plain(), true); }
// The same predict with tracking off: the whole grid, for the same-run ratio.
void plain_predict_whole(benchmark::State& state) {
  plain_filter& f = plain();
  localize(f);
  const tacmap::odometry there{.dx_mm = 4 * mm_per_px}, back{.dx_mm = -4 * mm_per_px};
  bool at_a = true;
  for (auto _ : state) {
    f.predict(at_a ? there : back);
    at_a = !at_a;
    benchmark::DoNotOptimize(f.belief().data());
  }
}
void plain_touch_full(benchmark::State& state) { localized_touch(state, plain(), false); }
void plain_touch_tracked(benchmark::State& state) { localized_touch(state, plain(), true); }
void plain_touch_tracked_noisy(benchmark::State& state) {
  localized_touch(state, plain(), true, true, std::pow(10.0, -static_cast<double>(state.range(0))));
}
void pose_first_touch(benchmark::State& state) { first_touch(state, pose()); }
void pose_touch_full(benchmark::State& state) { localized_touch(state, pose(), false); }
void pose_touch_tracked(benchmark::State& state) { localized_touch(state, pose(), true); }
void pose_touch_tracked_noisy(benchmark::State& state) {
  localized_touch(state, pose(), true, true, std::pow(10.0, -static_cast<double>(state.range(0))));
}
void pose_predict(benchmark::State& state) { localized_part(state, pose(), false); }
void pose_update_tracked(benchmark::State& state) { localized_part(state, pose(), true); }
void latent_first_touch(benchmark::State& state) { first_touch(state, latent(false)); }
void latent_touch_full(benchmark::State& state) { localized_touch(state, latent(false), false); }
void latent_touch_tracked(benchmark::State& state) { localized_touch(state, latent(false), true); }
void default_filter_touch_full(benchmark::State& state) {
  localized_touch(state, latent(true), false);
}
void default_filter_touch_tracking_on(benchmark::State& state) {
  localized_touch(state, latent(true), true);
}
// Tracking under the default (issue 36): the same filter with `default_tracking()` (the floor
// carried as one number, the whole grid every 16 touches and on doubt); exact and noisy touches.
void default_filter_touch_tracked(benchmark::State& state) {
  localized_touch(state, latent(true), true, false, 0.0, tacmap::default_tracking());
}
void default_filter_touch_tracked_noisy(benchmark::State& state) {
  localized_touch(state, latent(true), true, true, 0.0, tacmap::default_tracking());
}
void default_filter_touch_full_noisy(benchmark::State& state) {
  localized_touch(state, latent(true), false, true);
}

// What the slip recheck (localizer_config::slip_recheck) adds to every touch of a localizer:
// a copy of the default filter's belief before the move (the recheck's second predict and
// update run only at a touch that doubts its prediction).
void default_filter_belief_copy(benchmark::State& state) {
  auto& f = latent(true);
  localize(f);
  for (auto _ : state) {
    auto before = f.belief();
    benchmark::DoNotOptimize(before.data());
  }
}

}  // namespace

// Wall-clock time, and the CPU time of the whole process: CPU / wall is the number of cores the
// touch actually had (about 2 when the other core was free, less when other work took it).
BENCHMARK(plain_first_touch)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime();
BENCHMARK(plain_first_touch_2_threads)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MeasureProcessCPUTime();
#ifdef TACMAP_BENCH_TBB
BENCHMARK(plain_first_touch_tbb_2_threads)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MeasureProcessCPUTime();
#endif
BENCHMARK(plain_touch_full)->Unit(benchmark::kMicrosecond);
BENCHMARK(plain_touch_tracked)->Unit(benchmark::kMicrosecond);
BENCHMARK(plain_touch_tracked_noisy)->Arg(6)->Arg(9)->Unit(benchmark::kMicrosecond);
BENCHMARK(plain_predict)->Unit(benchmark::kMicrosecond);
BENCHMARK(plain_predict_whole)->Unit(benchmark::kMicrosecond);
BENCHMARK(plain_update_tracked)->Unit(benchmark::kMicrosecond);
BENCHMARK(pose_first_touch)->Unit(benchmark::kMillisecond);
BENCHMARK(pose_touch_full)->Unit(benchmark::kMicrosecond);
BENCHMARK(pose_touch_tracked)->Unit(benchmark::kMicrosecond);
BENCHMARK(pose_touch_tracked_noisy)->Arg(6)->Arg(9)->Unit(benchmark::kMicrosecond);
BENCHMARK(pose_predict)->Unit(benchmark::kMicrosecond);
BENCHMARK(pose_update_tracked)->Unit(benchmark::kMicrosecond);
BENCHMARK(latent_first_touch)->Unit(benchmark::kMillisecond);
BENCHMARK(latent_touch_full)->Unit(benchmark::kMicrosecond);
BENCHMARK(latent_touch_tracked)->Unit(benchmark::kMicrosecond);
BENCHMARK(default_filter_touch_full)->Unit(benchmark::kMicrosecond);
BENCHMARK(default_filter_touch_tracking_on)->Unit(benchmark::kMicrosecond);
BENCHMARK(default_filter_touch_tracked)->Unit(benchmark::kMicrosecond);
BENCHMARK(default_filter_touch_full_noisy)->Unit(benchmark::kMicrosecond);
BENCHMARK(default_filter_touch_tracked_noisy)->Unit(benchmark::kMicrosecond);
BENCHMARK(default_filter_belief_copy)->Unit(benchmark::kMicrosecond);
