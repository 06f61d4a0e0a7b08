// What the benchmarks share. A reproducible textured map for the benchmarks: random bars (edges in
// both directions) over a slanted sine, normalised to [0, 1]. Shared by every bench that needs a
// map.
#pragma once

#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "tacmap/image.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"
#include "tacmap/tactile/frame.hpp"

namespace tacmap_bench {

inline tacmap::image<float> bench_map(Eigen::Index rows = 120, Eigen::Index cols = 120,
                                      unsigned seed = 9) {
  std::mt19937 rng(seed);
  tacmap::image<float> map = tacmap::image<float>::Zero(rows, cols);
  const auto bars = static_cast<int>(20 * (rows * cols) / (120 * 120));
  for (int bar = 0; bar < bars; ++bar)
    map.block(static_cast<Eigen::Index>(rng() % static_cast<unsigned>(rows - 20)),
              static_cast<Eigen::Index>(rng() % static_cast<unsigned>(cols - 20)),
              static_cast<Eigen::Index>(3 + rng() % 17),
              static_cast<Eigen::Index>(3 + rng() % 17)) += 1.0F;
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index c = 0; c < cols; ++c)
      map(r, c) += 0.2F * std::sin(0.2F * static_cast<float>(r + 2 * c));
  map -= map.minCoeff();
  return map / map.maxCoeff();
}

// Times touches (predict then update), alternating two windows 4 px apart so that predict
// moves the belief and update sees a new image.
template <class Filter>
void time_touches(benchmark::State& state, Filter& filter, const tacmap::image<float>& map,
                  const typename Filter::control_type& there,
                  const typename Filter::control_type& back) {
  const tacmap::image<float> a = map.block(30, 40, 42, 18);
  const tacmap::image<float> b = map.block(30, 44, 42, 18);
  bool at_a = true;
  for (auto _ : state) {
    filter.predict(at_a ? there : back);
    filter.update(at_a ? b : a);
    at_a = !at_a;
    benchmark::DoNotOptimize(filter.belief().data());
  }
}

// Times the first touch: the update of a uniform belief with touch `z` (the whole grid; tracking
// off), the reset outside the timing. Counter `states`: the grid's size.
template <class Filter>
void time_first_touch(benchmark::State& state, Filter& filter, const tacmap::image<float>& z) {
  filter.set_tracking({});
  for (auto _ : state) {
    state.PauseTiming();
    filter.reset();
    state.ResumeTiming();
    filter.update(z);
    benchmark::DoNotOptimize(filter.belief().data());
  }
  state.counters["states"] = static_cast<double>(filter.grid().size());
}

// A raw 14 x 6 frame of the paper's array pressed on `map` with its top-left taxel at (row, col)
// (3 px per taxel: the bench map's 1.13 mm per px): counts 300 + 3000 x the taxel's mean.
inline tacmap::tactile_frame frame_at(const tacmap::image<float>& map, Eigen::Index row,
                                      Eigen::Index col) {
  tacmap::tactile_frame f;
  for (Eigen::Index r = 0; r < 14; ++r)
    for (Eigen::Index c = 0; c < 6; ++c)
      f.counts(r, c) = 300.0F + 3000.0F * map.block(row + 3 * r, col + 3 * c, 3, 3).mean();
  return f;
}

// Times a front door's `touch` (preprocessing, predict, update, estimate, verdict) on the bench
// map, alternating two places 4.5 mm apart as time_touches does; one touch first, untimed.
template <class Localizer>
void time_localizer_touches(benchmark::State& state, Localizer& loc,
                            const tacmap::image<float>& map) {
  const auto a = frame_at(map, 30, 40), b = frame_at(map, 30, 44);
  const tacmap::odometry there{.dx_mm = 4.5, .dy_mm = 0.0};
  const tacmap::odometry back{.dx_mm = -there.dx_mm, .dy_mm = 0.0};
  (void)loc.touch(a);
  bool at_a = true;
  for (auto _ : state) {
    const auto r = loc.touch(at_a ? b : a, at_a ? there : back);
    at_a = !at_a;
    benchmark::DoNotOptimize(r.position_mm.data());
  }
}

}  // namespace tacmap_bench
