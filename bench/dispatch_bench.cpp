// Instruction sets: the default filter's hot paths built three ways from this one file
// (bench/CMakeLists.txt), timed in the same session for the README's "Instruction sets":
//  * tacmap_dispatch_bench: -march=x86-64-v3, header-only (the README's other timings);
//  * tacmap_dispatch_bench_default: the compiler's default flags, header-only (SSE2 kernels);
//  * tacmap_dispatch_bench_precompiled: default flags + tacmap::precompiled (the float kernels
//    dispatched at run time to the CPU's best level).
// Issue target: the precompiled default-flags build within 1.2x of the x86-64-v3 build. Each
// case's label says what the kernels ran on (tacmap::simd_info()).
#include <benchmark/benchmark.h>

#include <string>

#include "bench_maps.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/simd.hpp"

namespace {

using tacmap_bench::bench_map;

std::string simd_label() {
  const tacmap::simd_report r = tacmap::simd_info();
  return std::string("compiled ") + std::string(r.compiled) + ", dispatched " +
         std::string(r.dispatched);
}

tacmap::planar_localizer_filter default_filter(const tacmap::image<float>& map) {
  return tacmap::make_planar_filter({}, map, 3.4 / 3.0, {.width = 18, .height = 42});
}

// One touch (predict + update) of the localizer's default filter, as appearance_bench's
// planar_touch_default_filter.
void default_touch(benchmark::State& state) {
  const auto map = bench_map();
  auto filter = default_filter(map);
  tacmap_bench::time_touches(state, filter, map, {.dx_mm = 4.5, .dy_mm = 0.0},
                             {.dx_mm = -4.5, .dy_mm = 0.0});
  state.SetLabel(simd_label());
}
BENCHMARK(default_touch)->Unit(benchmark::kMicrosecond);

// The default model's measurement alone (both appearances, classic SIFT per window): the
// distance kernels.
void default_measurement(benchmark::State& state) {
  const auto map = bench_map();
  const auto filter = default_filter(map);
  const tacmap::image<float> z = map.block(30, 40, 42, 18);
  Eigen::ArrayXf ll(filter.grid().size());
  for (auto _ : state) {
    filter.measurement_model().log_likelihood(filter.grid(), z, ll);
    benchmark::DoNotOptimize(ll.data());
  }
  state.SetLabel(simd_label());
}
BENCHMARK(default_measurement)->Unit(benchmark::kMicrosecond);

// The update with a given log-likelihood: the posterior kernels (scan, exp and weighting).
void default_update_given_likelihood(benchmark::State& state) {
  const auto map = bench_map();
  auto filter = default_filter(map);
  const tacmap::image<float> z = map.block(30, 40, 42, 18);
  Eigen::ArrayXf ll(filter.grid().size());
  filter.measurement_model().log_likelihood(filter.grid(), z, ll);
  const Eigen::ArrayXf flat = Eigen::ArrayXf::Zero(ll.size());
  int i = 0;
  for (auto _ : state) {
    // Alternate with a flat likelihood so the belief does not collapse to one state.
    benchmark::DoNotOptimize(filter.update_log_likelihood(i ? flat : ll));
    i ^= 1;
  }
  state.SetLabel(simd_label());
}
BENCHMARK(default_update_given_likelihood)->Unit(benchmark::kMicrosecond);

}  // namespace
