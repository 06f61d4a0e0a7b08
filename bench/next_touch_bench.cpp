// Choosing where to touch next (filter/next_touch.hpp): `localizer::next_touch` ranking 100
// candidate moves on the paper's grid (120 x 120 px map, 79 x 103 positions, the default
// classic SIFT model), beside one `localizer::touch` of the same localizer in the same run, so
// that the ranking's cost can be quoted as a ratio of a touch's. The target: 100 candidates in
// at most 20 ms.
#include <benchmark/benchmark.h>

#include <span>
#include <vector>

#include "bench_maps.hpp"
#include "tacmap/localizer.hpp"

namespace {

using tacmap_bench::bench_map;
using tacmap_bench::frame_at;
using tacmap_bench::time_localizer_touches;

// 100 moves: a 10 x 10 lattice of +-40 mm.
std::vector<tacmap::odometry> hundred_moves() {
  return tacmap::touch_region{
      .x_min_mm = -40.0, .x_max_mm = 41.0, .y_min_mm = -40.0, .y_max_mm = 41.0, .step_mm = 9.0}
      .candidates();
}

// After one touch (the bench map's touch leaves few distinct hypotheses) or none (a uniform
// belief: every hypothesis distinct, the worst case).
void rank(benchmark::State& state, bool touched, int hypotheses,
          tacmap::next_touch_objective objective) {
  const auto map = bench_map();
  tacmap::localizer loc(map, 3.4 / 3.0);
  if (touched) (void)loc.touch(frame_at(map, 30, 40));
  const auto moves = hundred_moves();
  const tacmap::next_touch_params params{.hypotheses = hypotheses, .objective = objective};
  std::size_t drawn = 0;
  for (auto _ : state) {
    const auto r = loc.next_touch(std::span<const tacmap::odometry>(moves), params);
    drawn = r.hypotheses;
    benchmark::DoNotOptimize(r.order.data());
  }
  state.counters["candidates"] = static_cast<double>(moves.size());
  state.counters["hypotheses"] = static_cast<double>(drawn);  // distinct ones drawn
}

void next_touch_100_after_one_touch(benchmark::State& state) {
  rank(state, true, 64, tacmap::next_touch_objective::entropy);
}
BENCHMARK(next_touch_100_after_one_touch)->Unit(benchmark::kMillisecond);

void next_touch_100_uniform(benchmark::State& state) {
  rank(state, false, 64, tacmap::next_touch_objective::entropy);
}
BENCHMARK(next_touch_100_uniform)->Unit(benchmark::kMillisecond);

void next_touch_100_verdict(benchmark::State& state) {
  rank(state, false, 64, tacmap::next_touch_objective::verdict);
}
BENCHMARK(next_touch_100_verdict)->Unit(benchmark::kMillisecond);

void next_touch_100_uniform_k128(benchmark::State& state) {
  rank(state, false, 128, tacmap::next_touch_objective::entropy);
}
BENCHMARK(next_touch_100_uniform_k128)->Unit(benchmark::kMillisecond);

// The reference in the same run: one touch of the same localizer (predict + update + verdict).
void localizer_touch(benchmark::State& state) {
  const auto map = bench_map();
  tacmap::localizer loc(map, 3.4 / 3.0);
  time_localizer_touches(state, loc, map);
}
BENCHMARK(localizer_touch)->Unit(benchmark::kMillisecond);

}  // namespace
