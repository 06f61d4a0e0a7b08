// What the benchmarks share. A reproducible textured map for the benchmarks: random bars (edges in
// both directions) over a slanted sine, normalised to [0, 1]. Shared by every bench that needs a
// map.
#pragma once

#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "tacmap/image.hpp"

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

}  // namespace tacmap_bench
