// tacmap: the support of a concentrated belief, for the filter's tracking mode
// (`bayes_filter::set_tracking`): states with p >= t for a threshold t below which the belief
// holds at most epsilon of its mass, found with whole-grid passes (no sort of 300,000 states).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <vector>
#include <xsimd/xsimd.hpp>

#include "tacmap/measurement/concept.hpp"
#include "tacmap/simd.hpp"

namespace tacmap::detail {

/// Candidate thresholds tried in one pass: geometric between epsilon / n (below which the mass
/// is < n * epsilon / n = epsilon whatever the belief) and the belief's maximum.
inline constexpr std::size_t support_candidates = 16;

/// mass[k] = sum of the p(i) < t[k] (one pass, every candidate at once). Float lanes summed over
/// blocks of 1024 states, then in double: the sums of small masses keep ~1e-6 relative error.
template <class T>
std::array<double, support_candidates> mass_below(const T* p, Eigen::Index n,
                                                  const std::array<T, support_candidates>& t) {
  using batch = xsimd::batch<T, kernel_arch<T>>;
  constexpr auto width = static_cast<Eigen::Index>(batch::size);
  constexpr std::size_t K = support_candidates;
  std::array<double, K> out{};
  std::array<batch, K> tb;
  for (std::size_t k = 0; k < K; ++k) tb[k] = batch(t[k]);
  const Eigen::Index vec_end = n - n % width;
  constexpr Eigen::Index block = 1024;
  for (Eigen::Index b0 = 0; b0 < vec_end; b0 += block) {
    std::array<batch, K> acc;
    acc.fill(batch(T(0)));
    const Eigen::Index b1 = std::min(vec_end, b0 + block);
    batch everywhere(T(0));  // states below the lowest candidate: below every candidate
    for (Eigen::Index i = b0; i < b1; i += width) {
      const batch v = batch::load_unaligned(p + i);
      // A concentrated belief is below the lowest candidate almost everywhere: one compare.
      if (xsimd::none(v >= tb[0])) {
        everywhere += v;
        continue;
      }
      for (std::size_t k = 0; k < K; ++k) acc[k] += xsimd::select(v < tb[k], v, batch(T(0)));
    }
    const auto common = static_cast<double>(xsimd::hadd(everywhere));
    for (std::size_t k = 0; k < K; ++k) out[k] += common + static_cast<double>(xsimd::hadd(acc[k]));
  }
  for (Eigen::Index i = vec_end; i < n; ++i)
    for (std::size_t k = 0; k < K; ++k)
      if (p[i] < t[k]) out[k] += static_cast<double>(p[i]);
  return out;
}

/// The largest candidate threshold t whose mass below is <= epsilon (see `mass_below`); the
/// support {p >= t} then holds >= 1 - epsilon of the mass. Candidates are geometric between
/// epsilon / n and 1: within a factor (n / epsilon)^(1/15) (5.8 for 547,000 states and 1e-6)
/// of the exact threshold of the smallest such set.
template <class T>
T support_threshold(const T* p, Eigen::Index n, double epsilon) {
  constexpr std::size_t K = support_candidates;
  const double lo = epsilon / static_cast<double>(n);
  const double hi = std::max(1.0, lo);
  const double ratio = std::pow(hi / lo, 1.0 / static_cast<double>(K - 1));
  std::array<T, K> t{};
  for (std::size_t k = 0; k < K; ++k)
    t[k] = static_cast<T>(lo * std::pow(ratio, static_cast<double>(k)));
  const std::array<double, K> below = mass_below(p, n, t);
  T best = t[0];
  for (std::size_t k = 1; k < K; ++k)
    if (below[k] <= epsilon) best = t[k];
  return best;
}

/// What `support_ranges` found.
struct support_summary {
  Eigen::Index states = 0;  ///< states with p >= t
  double outside = 0.0;     ///< the mass of the others
  bool too_wide = false;    ///< stopped: more than the allowed states
};

/// The ranges of consecutive states with p >= t, into `out`, and the mass outside them. Stops
/// (too_wide) as soon as more than `max_states` states are in: the caller takes the whole grid.
template <class T>
support_summary support_ranges(const T* p, Eigen::Index n, T t, Eigen::Index max_states,
                               std::vector<state_range>& out) {
  using batch = xsimd::batch<T, kernel_arch<T>>;
  constexpr auto width = static_cast<Eigen::Index>(batch::size);
  out.clear();
  support_summary s;
  const batch tb(t);
  Eigen::Index open = -1;  // first state of the range being built, or -1
  batch outside(T(0));
  Eigen::Index since_flush = 0;
  const auto flush = [&] {
    s.outside += static_cast<double>(xsimd::hadd(outside));
    outside = batch(T(0));
    since_flush = 0;
  };
  const auto lane = [&](Eigen::Index i) {
    if (p[i] >= t) {
      if (open < 0) open = i;
      ++s.states;
    } else {
      s.outside += static_cast<double>(p[i]);
      if (open >= 0) {
        out.push_back({open, i});
        open = -1;
      }
    }
  };
  const Eigen::Index vec_end = n - n % width;
  for (Eigen::Index i = 0; i < vec_end; i += width) {
    const batch v = batch::load_unaligned(p + i);
    const auto in = v >= tb;
    if (xsimd::none(in)) {
      outside += v;
      if (open >= 0) {
        out.push_back({open, i});
        open = -1;
      }
      if (++since_flush == 128) flush();
    } else if (xsimd::all(in)) {
      if (open < 0) open = i;
      s.states += width;
    } else {
      for (Eigen::Index l = 0; l < width; ++l) lane(i + l);
    }
    if (s.states > max_states) {
      s.too_wide = true;
      return s;
    }
  }
  for (Eigen::Index i = vec_end; i < n; ++i) lane(i);
  flush();
  if (open >= 0) out.push_back({open, n});
  s.too_wide = s.states > max_states;
  return s;
}

}  // namespace tacmap::detail
