// Hot paths of the Bayes filter on the paper's grid (120 x 120 map, 42 x 18 window: 8,137
// states), float. Targets on one core: predict <= 20 us, update with a given likelihood <= 10 us.
//
// `predict_per_cell_baseline` is the textbook histogram-filter loop (for each state, scatter its
// mass over the shifted stencil) measured in the same run, for the ratio in README.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "tacmap/detail/mass_sum.hpp"
#include "tacmap/tacmap.hpp"

namespace {

using grid_t = tacmap::planar_grid<float>;

struct given_likelihood {  // measurement = the log-likelihood itself
  using measurement_type = Eigen::ArrayXf;
  void log_likelihood(const grid_t&, const measurement_type& z, Eigen::ArrayXf& out) const {
    out = z;
  }
};

using filter_t = tacmap::bayes_filter<grid_t, tacmap::odometry_gaussian, given_likelihood>;

filter_t paper_filter(int k = 8) {
  return filter_t(grid_t::paper(), tacmap::odometry_gaussian({.sigma_mm = 1.5, .k = k}),
                  given_likelihood{});
}

Eigen::ArrayXf random_log_likelihood(Eigen::Index n) {
  std::mt19937 rng(42);
  Eigen::ArrayXf ll(n);
  for (Eigen::Index i = 0; i < n; ++i) ll(i) = -static_cast<float>(rng() % 2000) / 100.0F;
  return ll;
}

void predict_paper(benchmark::State& state) {
  auto f = paper_filter(static_cast<int>(state.range(0)));
  f.update_log_likelihood(random_log_likelihood(f.grid().size()));
  const tacmap::odometry moves[2] = {{2.3, -1.7}, {-2.3, 1.7}};  // sub-pixel, stays centred
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(f.predict(moves[i]));
    i ^= 1;
  }
  state.SetItemsProcessed(state.iterations() * f.grid().size());
}
BENCHMARK(predict_paper)->Arg(8)->Arg(24)->ArgName("k");

void update_given_likelihood(benchmark::State& state) {
  auto f = paper_filter();
  const Eigen::ArrayXf ll = random_log_likelihood(f.grid().size());
  const Eigen::ArrayXf flat = Eigen::ArrayXf::Zero(f.grid().size());
  int i = 0;
  for (auto _ : state) {
    // Alternate with a flat likelihood so the belief does not collapse to one state.
    benchmark::DoNotOptimize(f.update_log_likelihood(i ? flat : ll));
    i ^= 1;
  }
  state.SetItemsProcessed(state.iterations() * f.grid().size());
}
BENCHMARK(update_given_likelihood);

// The paper's motion under robust_motion with `params`: one move after another.
void predict_robust_with(benchmark::State& state, tacmap::robust_motion_params params) {
  using robust_t = tacmap::bayes_filter<grid_t, tacmap::robust_motion<tacmap::odometry_gaussian>,
                                        given_likelihood>;
  robust_t f(grid_t::paper(),
             tacmap::robust_motion<tacmap::odometry_gaussian>(
                 tacmap::odometry_gaussian({.sigma_mm = 1.5, .k = 8}), params),
             given_likelihood{});
  f.update_log_likelihood(random_log_likelihood(f.grid().size()));
  const tacmap::odometry moves[2] = {{2.3, -1.7}, {-2.3, 1.7}};
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(f.predict(moves[i]));
    i ^= 1;
  }
  state.SetItemsProcessed(state.iterations() * f.grid().size());
}

// With a floor under every state (lost probability 0.001, the experiment's default): one more
// pass over the belief.
void predict_robust(benchmark::State& state) {
  predict_robust_with(state, {.lost_probability = 0.001});
}
BENCHMARK(predict_robust);

// ... and with a wide component (w = 0.1, 3 mm): three box passes per axis on top.
void predict_wide(benchmark::State& state) {
  predict_robust_with(state,
                      {.lost_probability = 0.001, .wide_probability = 0.1, .wide_sigma_mm = 3.0});
}
BENCHMARK(predict_wide);

// ... and the broad component (b = 0.05 of 10 mm, the measured choice; off by default): on
// block centres 4 states apart, interpolated back.
void predict_broad(benchmark::State& state) {
  predict_robust_with(state, {.lost_probability = 0.001,
                              .wide_probability = 0.1,
                              .wide_sigma_mm = 3.0,
                              .broad_probability = 0.05,
                              .broad_sigma_mm = 10.0});
}
BENCHMARK(predict_broad);

// The wide component's spread, in mm (argument): radius 2, 3, 4, 5, 7 and 10 px of the paper's
// 1.13 mm grid. Small radii sum the taps directly, larger ones use sliding sums
// (robust_motion's `direct_radius`): this row is where the two were compared.
void predict_wide_sigma(benchmark::State& state) {
  predict_robust_with(state, {.lost_probability = 0.001,
                              .wide_probability = 0.1,
                              .wide_sigma_mm = static_cast<double>(state.range(0))});
}
BENCHMARK(predict_wide_sigma)->Arg(3)->Arg(4)->Arg(5)->Arg(6)->Arg(9)->Arg(12);

// The confidence of the estimate (filter/confidence.hpp): the most probable 5 mm disc and its
// mass, after every touch.
void assess_paper(benchmark::State& state) {
  auto f = paper_filter();
  f.update_log_likelihood(random_log_likelihood(f.grid().size()));
  for (auto _ : state) benchmark::DoNotOptimize(tacmap::assess(f));
}
BENCHMARK(assess_paper);

void estimate_paper(benchmark::State& state) {
  auto f = paper_filter();
  f.update_log_likelihood(random_log_likelihood(f.grid().size()));
  for (auto _ : state) benchmark::DoNotOptimize(f.estimate());
}
BENCHMARK(estimate_paper);

// The sum of a whole belief (issue 37): detail::mass_sum (float chunks of 16 registers, their
// totals in double) against the flat float sum it replaced (Eigen's .sum(): one running total per
// lane over the whole belief, off by 2 % at 16 million states). Arg: the number of states
// (8,137: the paper's grid; 16 million: a 4,000^2 grid).
void belief_sum(benchmark::State& state, bool chunked) {
  const auto n = static_cast<Eigen::Index>(state.range(0));
  const Eigen::ArrayXf b = Eigen::ArrayXf::Random(n).abs() / static_cast<float>(n);
  for (auto _ : state) {
    const double s = chunked ? tacmap::detail::mass_sum(b) : static_cast<double>(b.sum());
    benchmark::DoNotOptimize(s);
  }
  state.SetItemsProcessed(state.iterations() * n);
}
BENCHMARK_CAPTURE(belief_sum, mass_sum, true)->Arg(8137)->Arg(4000 * 4000);
BENCHMARK_CAPTURE(belief_sum, flat_float, false)->Arg(8137)->Arg(4000 * 4000);

// The per-cell loop a straightforward histogram filter would run: same maths (3 x 3 Gaussian,
// whole-pixel shift), one state at a time.
void predict_per_cell_baseline(benchmark::State& state) {
  const grid_t g = grid_t::paper();
  Eigen::ArrayXf in = Eigen::ArrayXf::Constant(g.size(), 1.0F / static_cast<float>(g.size()));
  Eigen::ArrayXf out(g.size());
  float w[3][3];
  float sum = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx)
      sum += w[dy + 1][dx + 1] = std::exp(-static_cast<float>(dx * dx + dy * dy) / 2.0F);
  for (auto& row : w)
    for (float& v : row) v /= sum;
  const Eigen::Index shift_x = 2;
  const Eigen::Index shift_y = -1;
  for (auto _ : state) {
    out.setZero();
    for (Eigen::Index i = 0; i < g.size(); ++i) {
      const tacmap::grid_cell c = g.cell(i);
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const tacmap::grid_cell t{c.row + shift_y + dy, c.col + shift_x + dx};
          if (g.contains(t)) out(g.index(t)) += w[dy + 1][dx + 1] * in(i);
        }
    }
    out /= out.sum();
    in.swap(out);
    benchmark::DoNotOptimize(in.data());
  }
  state.SetItemsProcessed(state.iterations() * g.size());
}
BENCHMARK(predict_per_cell_baseline);

}  // namespace
