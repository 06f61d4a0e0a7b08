// The scaling table (issue 14, item 6): preparing a map and one touch, from the paper's 120 px
// map to a camera's 640 x 480, in the plane and with 36 headings, in one run.
//
//  * planar: the default model (classic_sift, per window, aligned, exponential) with the
//    Gaussian odometry model — what `bayes_filter` gives by default. One touch: the first touch
//    (the whole grid, from a uniform belief), the same on 2 threads (thread_pool_executor), and
//    a touch once localized with tracking mode on (issue 14, item 3). Beside them, the floor:
//    reading the model's bytes once and doing nothing else, on 1 and 2 threads.
//  * 36 headings: rotated_descriptor_likelihood<classic_sift> over a pose grid, the model the
//    localizer runs for unknown headings: the map's dense field is shared by every heading and
//    window (per-window descriptors for every heading would need 36 x 3 x 128 floats per
//    position, 15 GB at 640 x 480). It has no tracking hook: every touch is a full update.
//
// Wall-clock times, with the whole process's CPU time beside them (CPU / wall: the cores a run
// actually had on a shared machine). Only the 120 x 120 rows run by default (the CTest smoke run
// stays cheap); the others need about 1 GB and seconds each:
//   TACMAP_BENCH_SCALING=1 build/release/bench/tacmap_scaling_bench --benchmark_repetitions=3
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <utility>
#include <vector>
#include <xsimd/xsimd.hpp>

#include "bench_maps.hpp"
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/executor/thread_pool.hpp"
#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/grid/pose_grid.hpp"
#include "tacmap/measurement/descriptor_likelihood.hpp"
#include "tacmap/measurement/detail/quantized_kernel.hpp"
#include "tacmap/measurement/rotated_descriptor_likelihood.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"
#include "tacmap/motion/pose_odometry_gaussian.hpp"

namespace {

constexpr double mm_per_px = 0.2;
constexpr tacmap::pixel_size window{.width = 18, .height = 42};
constexpr int headings = 36;

using planar_model = tacmap::descriptor_likelihood<tacmap::classic_sift>;
using pose_model = tacmap::rotated_descriptor_likelihood<tacmap::classic_sift>;
using planar_filter =
    tacmap::bayes_filter<tacmap::planar_grid<float>, tacmap::odometry_gaussian, planar_model>;
using pose_filter =
    tacmap::bayes_filter<tacmap::pose_grid<float>, tacmap::pose_odometry_gaussian, pose_model>;

const tacmap::image<float>& map_of(Eigen::Index cols, Eigen::Index rows) {
  static std::map<std::pair<Eigen::Index, Eigen::Index>, tacmap::image<float>> maps;
  auto it = maps.find({cols, rows});
  if (it == maps.end())
    it = maps.emplace(std::pair{cols, rows}, tacmap_bench::bench_map(rows, cols)).first;
  return it->second;
}

tacmap::planar_grid<float> planar_grid_of(const tacmap::image<float>& map) {
  return {{.width = map.cols(), .height = map.rows()}, mm_per_px, window};
}

// One filter per map size, built once (the touches reuse it; preparation is timed on its own).
// Only the most recently used one is kept: 640 x 480 per window takes about 0.5 GB.
template <class Filter, class Make>
Filter& cached(Eigen::Index cols, Eigen::Index rows, Make make) {
  static std::unique_ptr<Filter> filter;
  static std::pair<Eigen::Index, Eigen::Index> size{0, 0};
  if (!filter || size != std::pair{cols, rows}) {
    filter.reset();
    filter = std::make_unique<Filter>(make(map_of(cols, rows)));
    size = {cols, rows};
  }
  return *filter;
}

planar_filter& planar(Eigen::Index cols, Eigen::Index rows) {
  return cached<planar_filter>(cols, rows, [](const tacmap::image<float>& map) {
    return planar_filter(planar_grid_of(map), tacmap::odometry_gaussian({.sigma_mm = 1.0, .k = 8}),
                         planar_model({}, map, window));
  });
}

pose_filter& pose(Eigen::Index cols, Eigen::Index rows) {
  return cached<pose_filter>(cols, rows, [](const tacmap::image<float>& map) {
    const tacmap::pose_grid<float> grid(planar_grid_of(map), headings);
    return pose_filter(grid, tacmap::pose_odometry_gaussian{}, pose_model({}, map, grid));
  });
}

// The window `dc` px right of the map's centre.
tacmap::image<float> cut(const tacmap::image<float>& map, Eigen::Index dc = 0) {
  return map.block(map.rows() / 2 - window.height / 2, map.cols() / 2 + dc, window.height,
                   window.width);
}

// Bytes of the default model's per-window descriptors on a map of that size (int8 storage).
std::size_t model_bytes(Eigen::Index cols, Eigen::Index rows) {
  return static_cast<std::size_t>(planar_grid_of(map_of(cols, rows)).size()) * 3 *
         static_cast<std::size_t>(tacmap::detail::quantized_tiles::bytes_per_position(128));
}

void planar_prepare(benchmark::State& state, Eigen::Index cols, Eigen::Index rows) {
  const auto& map = map_of(cols, rows);
  for (auto _ : state) {
    const planar_model model({}, map, window);
    benchmark::DoNotOptimize(&model);
  }
  state.counters["states"] = static_cast<double>(planar_grid_of(map).size());
}

void pose_prepare(benchmark::State& state, Eigen::Index cols, Eigen::Index rows) {
  const auto& map = map_of(cols, rows);
  for (auto _ : state) {
    const pose_model model({}, map, window, headings);
    benchmark::DoNotOptimize(&model);
  }
  state.counters["states"] = static_cast<double>(planar_grid_of(map).size() * headings);
}

void planar_first_touch(benchmark::State& state, Eigen::Index cols, Eigen::Index rows) {
  tacmap_bench::time_first_touch(state, planar(cols, rows), cut(map_of(cols, rows)));
}

void planar_first_touch_2_threads(benchmark::State& state, Eigen::Index cols, Eigen::Index rows) {
  tacmap::thread_pool_executor pool(2);
  auto& f = planar(cols, rows);
  f.set_executor(pool);
  tacmap_bench::time_first_touch(state, f, cut(map_of(cols, rows)));
  f.set_executor({});
}

void pose_first_touch(benchmark::State& state, Eigen::Index cols, Eigen::Index rows) {
  tacmap_bench::time_first_touch(state, pose(cols, rows), cut(map_of(cols, rows)));
}

// A touch once localized (three full updates at the centre first): predict 4 px right or back,
// update with the window there, tracking mode on (epsilon 1e-6).
void planar_tracked_touch(benchmark::State& state, Eigen::Index cols, Eigen::Index rows) {
  auto& f = planar(cols, rows);
  const auto& map = map_of(cols, rows);
  f.set_tracking({});
  f.reset();
  for (int k = 0; k < 3; ++k) f.update(cut(map));
  f.set_tracking({.epsilon = 1e-6});
  const auto a = cut(map), b = cut(map, 4);
  const tacmap::odometry there{.dx_mm = 4 * mm_per_px}, back{.dx_mm = -4 * mm_per_px};
  bool at_a = true;
  double tracked = 0.0, touches = 0.0;
  for (auto _ : state) {
    f.predict(at_a ? there : back);
    const tacmap::update_report r = f.update(at_a ? b : a);
    at_a = !at_a;
    tracked += r.path == tacmap::update_path::tracked ? 1.0 : 0.0;
    touches += 1.0;
    benchmark::DoNotOptimize(f.belief().data());
  }
  state.counters["tracked"] = tracked / touches;
  f.set_tracking({});
}

// The floor under the first touch: reading as many bytes as the default model streams per
// touch (its int8 per-window descriptors: 3 patches x (128 + 4) bytes per window), with one
// 32-byte load per row and nothing else, on one thread and on the same 2-thread pool. A first
// touch cannot beat this, so the 2-thread figure's ceiling on a given machine is the ratio of
// these two rows (issue 14, item 5), not the core count.
void read_floor(benchmark::State& state, std::size_t bytes, std::size_t threads) {
  using batch = xsimd::batch<std::int32_t>;
  constexpr std::size_t lanes = batch::size;
  std::vector<std::int32_t, xsimd::aligned_allocator<std::int32_t, 64>> data(
      bytes / sizeof(std::int32_t) / (2 * lanes) * (2 * lanes));
  for (std::size_t i = 0; i < data.size(); ++i) data[i] = static_cast<std::int32_t>(i);
  tacmap::thread_pool_executor pool(threads);
  std::vector<std::int32_t> sums(threads * 16);  // 64 bytes apart: no false sharing
  for (auto _ : state) {
    pool.parallel_for(threads, [&](std::size_t begin, std::size_t end) {
      for (std::size_t c = begin; c < end; ++c) {
        const std::size_t pairs = data.size() / (2 * lanes);
        const std::size_t from = pairs * c / threads * 2 * lanes;
        const std::size_t to = pairs * (c + 1) / threads * 2 * lanes;
        batch a(0), b(0);
        for (std::size_t i = from; i < to; i += 2 * lanes) {
          a += batch::load_aligned(data.data() + i);
          b += batch::load_aligned(data.data() + i + lanes);
        }
        sums[c * 16] = xsimd::hadd(a + b);
      }
    });
    benchmark::DoNotOptimize(sums.data());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) *
                          static_cast<std::int64_t>(data.size() * sizeof(std::int32_t)));
}

void read_floor_1_thread(benchmark::State& state, Eigen::Index cols, Eigen::Index rows) {
  read_floor(state, model_bytes(cols, rows), 1);
}

void read_floor_2_threads(benchmark::State& state, Eigen::Index cols, Eigen::Index rows) {
  read_floor(state, model_bytes(cols, rows), 2);
}

// Registered at start-up: 120 x 120 always, the larger maps with TACMAP_BENCH_SCALING set.
[[maybe_unused]] const int registered = [] {
  std::vector<std::pair<Eigen::Index, Eigen::Index>> sizes{{120, 120}};
  if (std::getenv("TACMAP_BENCH_SCALING") != nullptr)
    sizes.insert(sizes.end(), {{240, 240}, {320, 240}, {640, 480}});
  using fn = void (*)(benchmark::State&, Eigen::Index, Eigen::Index);
  const std::tuple<const char*, fn, benchmark::TimeUnit> cases[] = {
      {"planar_prepare", planar_prepare, benchmark::kMillisecond},
      {"planar_first_touch", planar_first_touch, benchmark::kMicrosecond},
      {"planar_first_touch_2_threads", planar_first_touch_2_threads, benchmark::kMicrosecond},
      {"read_floor_1_thread", read_floor_1_thread, benchmark::kMicrosecond},
      {"read_floor_2_threads", read_floor_2_threads, benchmark::kMicrosecond},
      {"planar_tracked_touch", planar_tracked_touch, benchmark::kMicrosecond},
      {"pose36_prepare", pose_prepare, benchmark::kMillisecond},
      {"pose36_touch", pose_first_touch, benchmark::kMicrosecond},
  };
  // Size by size, so that each size's filters are built once.
  for (const auto& [cols, rows] : sizes)
    for (const auto& [name, f, unit] : cases) {
      const std::string label =
          std::string(name) + "/" + std::to_string(cols) + "x" + std::to_string(rows);
      benchmark::RegisterBenchmark(label.c_str(), [f = f, cols = cols, rows = rows](
                                                      benchmark::State& s) { f(s, cols, rows); })
          ->Unit(unit)
          ->UseRealTime()
          ->MeasureProcessCPUTime();
    }
  return 0;
}();

}  // namespace
