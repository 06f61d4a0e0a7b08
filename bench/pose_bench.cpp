// (x, y, theta) localization (issue 6): one full measurement update — the tactile image rotated
// to every heading and matched against the map's dense descriptors, then the posterior — on the
// paper's 120 x 120 map with 36 headings (target: <= 2 ms on one core, float), and how it scales
// with map size and number of headings. `planar_update_shared` is the known-orientation model's
// update (shared dense features) on the same map in the same run: the 36-heading update's cost
// per heading is its ratio / 36.
#include <benchmark/benchmark.h>

#include "bench_maps.hpp"
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/grid/pose_grid.hpp"
#include "tacmap/measurement/rotated_descriptor_likelihood.hpp"
#include "tacmap/motion/pose_odometry_gaussian.hpp"
#include "tacmap/tacmap.hpp"

namespace {

using pose_grid_t = tacmap::pose_grid<float>;
using model_t = tacmap::rotated_descriptor_likelihood<tacmap::sift_lite>;

pose_grid_t grid_for(Eigen::Index side, int angles) {
  return {tacmap::planar_grid<float>({.width = side, .height = side}, 3.4 / 3.0,
                                     {.width = 18, .height = 42}),
          angles};
}

// range(0): map side in px; range(1): headings.
void pose_update(benchmark::State& state) {
  const Eigen::Index side = state.range(0);
  const auto angles = static_cast<int>(state.range(1));
  const auto map = tacmap_bench::bench_map(side, side);
  const auto grid = grid_for(side, angles);
  tacmap::bayes_filter filter(grid, tacmap::pose_odometry_gaussian{}, model_t({}, map, grid));
  const tacmap::image<float> z = map.block(30, 40, 42, 18);
  for (auto _ : state) {
    filter.reset();
    benchmark::DoNotOptimize(filter.update(z));
  }
  state.SetItemsProcessed(state.iterations() * grid.size());
  state.counters["states"] = static_cast<double>(grid.size());
}
BENCHMARK(pose_update)
    ->ArgNames({"map_px", "angles"})
    ->Args({120, 36})
    ->Args({120, 12})
    ->Args({120, 72})
    ->Args({240, 36})
    ->Args({480, 36})
    ->Unit(benchmark::kMicrosecond);

// The measurement alone (tactile rotation + description + distances), 120 px, 36 headings.
void pose_measurement(benchmark::State& state) {
  const auto map = tacmap_bench::bench_map();
  const auto grid = grid_for(120, 36);
  const model_t model({}, map, grid);
  const tacmap::image<float> z = map.block(30, 40, 42, 18);
  Eigen::ArrayXf ll(grid.size());
  for (auto _ : state) {
    model.log_likelihood(grid, z, ll);
    benchmark::DoNotOptimize(ll.data());
  }
}
BENCHMARK(pose_measurement)->Unit(benchmark::kMicrosecond);

// Just the tactile side: 36 rotated canvases described at their 3 patches each.
void pose_tactile_descriptors(benchmark::State& state) {
  const auto map = tacmap_bench::bench_map();
  const auto grid = grid_for(120, 36);
  const model_t model({}, map, grid);
  const tacmap::image<float> z = map.block(30, 40, 42, 18);
  for (auto _ : state) benchmark::DoNotOptimize(model.tactile_descriptors(z).data());
}
BENCHMARK(pose_tactile_descriptors)->Unit(benchmark::kMicrosecond);

// The control update over 36 layers (sensor-frame odometry, turn with noise).
void pose_predict(benchmark::State& state) {
  const auto map = tacmap_bench::bench_map();
  const auto grid = grid_for(120, 36);
  tacmap::bayes_filter filter(grid, tacmap::pose_odometry_gaussian{}, model_t({}, map, grid));
  for (auto _ : state) {
    filter.reset();
    benchmark::DoNotOptimize(filter.predict({.du_mm = 2.3, .dv_mm = -1.1, .dtheta_rad = 0.05}));
  }
}
BENCHMARK(pose_predict)->Unit(benchmark::kMicrosecond);

// One whole step of Table 1 on 120 px, 36 headings: the control update (a move and a turn)
// then the measurement update.
void pose_step(benchmark::State& state) {
  const auto map = tacmap_bench::bench_map();
  const auto grid = grid_for(120, 36);
  tacmap::bayes_filter filter(grid, tacmap::pose_odometry_gaussian{}, model_t({}, map, grid));
  const tacmap::image<float> z = map.block(30, 40, 42, 18);
  for (auto _ : state) {
    filter.reset();
    benchmark::DoNotOptimize(filter.step({.du_mm = 2.3, .dv_mm = -1.1, .dtheta_rad = 0.05}, z));
  }
}
BENCHMARK(pose_step)->Unit(benchmark::kMicrosecond);

// The known-orientation (planar) update with shared dense features on the same map.
void planar_update_shared(benchmark::State& state) {
  const auto map = tacmap_bench::bench_map();
  const auto grid = tacmap::planar_grid<float>::paper();
  tacmap::bayes_filter filter(
      grid, tacmap::odometry_gaussian{},
      tacmap::descriptor_likelihood<tacmap::sift_lite>(
          {}, map, grid.window_size(), {.features = tacmap::window_features::shared_dense}));
  const tacmap::image<float> z = map.block(30, 40, 42, 18);
  for (auto _ : state) {
    filter.reset();
    benchmark::DoNotOptimize(filter.update(z));
  }
}
BENCHMARK(planar_update_shared)->Unit(benchmark::kMicrosecond);

}  // namespace
