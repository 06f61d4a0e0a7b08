// Per-touch costs of the frame-level components of issue 34, beside preprocess (the per-touch
// step they sit in front of), in one run so their ratios hold on a noisy machine:
//  * combine_burst: the paper's 20 readings of one press combined into one frame;
//  * self_calibration::observe: one touch added to a 64-touch window and the estimate redone;
//  * self_calibration::correct: one frame corrected and its dead taxels inpainted.
#include <benchmark/benchmark.h>

#include <vector>

#include "tacmap/sim/tactile_simulator.hpp"
#include "tacmap/tactile/burst.hpp"
#include "tacmap/tactile/preprocess.hpp"
#include "tacmap/tactile/self_calibration.hpp"

namespace {

tacmap::image<float> bench_relief() {
  tacmap::image<float> r = tacmap::image<float>::Zero(120, 120);
  r.block(30, 40, 20, 8).setConstant(4.0F);
  r.block(55, 52, 6, 25).setConstant(4.0F);
  r.block(70, 45, 15, 5).setConstant(4.0F);
  r.block(20, 70, 30, 10).setConstant(4.0F);
  return r;
}

std::vector<tacmap::tactile_frame> bench_frames(std::size_t n, bool same_pose) {
  tacmap::simulator_params p;
  p.noise_counts = 40.0;
  p.gain_variation = 0.15;
  p.dead_fraction = 0.1;
  tacmap::tactile_simulator sim(bench_relief(), {120, 120}, 3.4 / 3.0, p);
  std::vector<tacmap::tactile_frame> out;
  for (std::size_t i = 0; i < n; ++i) {
    const double k = same_pose ? 0.0 : static_cast<double>(i % 16);
    out.push_back(sim.render({40.0 + 3.0 * k, 50.0 + 2.0 * k, 0.0}));
  }
  return out;
}

void preprocess_frame(benchmark::State& state) {
  const auto frames = bench_frames(1, true);
  for (auto _ : state) benchmark::DoNotOptimize(tacmap::preprocess(frames[0]));
}
BENCHMARK(preprocess_frame);

void combine_burst_20(benchmark::State& state) {
  const auto frames = bench_frames(20, true);
  for (auto _ : state) benchmark::DoNotOptimize(tacmap::combine_burst(frames));
}
BENCHMARK(combine_burst_20);

void self_calibration_observe(benchmark::State& state) {
  const auto frames = bench_frames(80, false);
  tacmap::self_calibration cal;
  for (std::size_t i = 0; i < 64; ++i) cal.observe(frames[i]);  // a full window
  std::size_t i = 64;
  for (auto _ : state) {
    cal.observe(frames[i]);
    i = i + 1 < frames.size() ? i + 1 : 0;
  }
}
BENCHMARK(self_calibration_observe);

void self_calibration_correct(benchmark::State& state) {
  const auto frames = bench_frames(64, false);
  tacmap::self_calibration cal;
  for (const auto& f : frames) cal.observe(f);
  for (auto _ : state) benchmark::DoNotOptimize(cal.correct(frames[3]));
}
BENCHMARK(self_calibration_correct);

}  // namespace
