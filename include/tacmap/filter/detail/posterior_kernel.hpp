// tacmap: the measurement update's inner loops, hand-vectorised with xsimd.
//
// bel(x) = eta * bel_bar(x) * exp(ll(x) - max ll)  (paper, Table 1, with log-likelihoods).
// Two passes: scan (maximum, first NaN) and weight (multiply by exp, accumulate the sum). Each
// kernel has a plain scalar reference next to it; tests compare the two with tolerances (xsimd's
// exp and FMA contraction differ from std::exp in the last bits). As in distance_kernel.hpp,
// `*_simd<A>` is architecture A's kernel and the entry points without the suffix choose A: the
// compile-time one, or for float with tacmap::precompiled the CPU's best (tacmap/simd.hpp).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <type_traits>
#include <xsimd/xsimd.hpp>

#include "tacmap/detail/mass_sum.hpp"
#include "tacmap/simd.hpp"

namespace tacmap::detail {

/// Result of scanning a log-likelihood: its maximum and the first NaN (or -1 if none).
template <class T>
struct log_likelihood_scan {
  T max = -std::numeric_limits<T>::infinity();
  Eigen::Index first_nan = -1;
};

/// Below log(smallest normal) a factor exp(ll - max) is treated as exactly 0: vectorised exps
/// return denormals there (Eigen's returns one even for -infinity), and an excluded state
/// (ll = -infinity) must stay excluded.
template <class T>
inline T log_factor_floor() {
  return std::log(std::numeric_limits<T>::min());
}

template <class T>
log_likelihood_scan<T> scan_log_likelihood_scalar(const T* ll, Eigen::Index n) {
  log_likelihood_scan<T> s;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (std::isnan(ll[i])) {
      s.first_nan = i;
      return s;
    }
    s.max = std::max(s.max, ll[i]);
  }
  return s;
}

template <class A, class T>
log_likelihood_scan<T> scan_log_likelihood_simd(const T* ll, Eigen::Index n) {
  using batch = xsimd::batch<T, A>;
  constexpr auto width = static_cast<Eigen::Index>(batch::size);
  const Eigen::Index vec_end = n - n % width;
  batch top(-std::numeric_limits<T>::infinity());
  auto nan_seen = batch(T(0)) != batch(T(0));  // all false
  for (Eigen::Index i = 0; i < vec_end; i += width) {
    const batch v = batch::load_unaligned(ll + i);
    // xsimd::isnan, not v != v: xsimd 8.1's AVX `!=` is an ordered compare (_CMP_NEQ_OQ), false
    // for NaN, so an AVX2 build missed a NaN in the vector body (found by the dispatch tests).
    nan_seen = nan_seen || xsimd::isnan(v);
    top = xsimd::max(top, v);
  }
  if (xsimd::any(nan_seen)) return scan_log_likelihood_scalar(ll, n);  // locate it (rare path)
  alignas(64) T lanes[batch::size];
  top.store_aligned(lanes);
  log_likelihood_scan<T> s = scan_log_likelihood_scalar(ll + vec_end, n - vec_end);
  if (s.first_nan >= 0) {
    s.first_nan += vec_end;
    return s;
  }
  for (const T lane : lanes) s.max = std::max(s.max, lane);
  return s;
}

template <class T>
log_likelihood_scan<T> scan_log_likelihood(const T* ll, Eigen::Index n) {
#if defined(TACMAP_PRECOMPILED) && TACMAP_PRECOMPILED
  if constexpr (std::is_same_v<T, float>) return active_kernels().scan_log_likelihood(ll, n);
#endif
  return scan_log_likelihood_simd<kernel_arch<T>>(ll, n);
}

/// The two sums of the weighting pass: the unnormalised posterior's, and the likelihood
/// factors' own (what a uniform prior would have given, times the number of states).
struct weight_sums {
  double posterior = 0.0;   ///< sum_i prior(i) * exp(ll(i) - top)
  double likelihood = 0.0;  ///< sum_i exp(ll(i) - top)
};

/// out(i) = prior(i) * exp(ll(i) - top) (0 below the floor); returns the sum of out and of the
/// factors exp(ll(i) - top).
template <class T>
weight_sums weight_by_likelihood_scalar(const T* prior, const T* ll, T top, T* out,
                                        Eigen::Index n) {
  const T floor = log_factor_floor<T>();
  weight_sums sums;
  for (Eigen::Index i = 0; i < n; ++i) {
    const T d = ll[i] - top;
    const T factor = d < floor ? T(0) : std::exp(d);
    out[i] = prior[i] * factor;
    sums.posterior += static_cast<double>(out[i]);
    sums.likelihood += static_cast<double>(factor);
  }
  return sums;
}

template <class A, class T>
weight_sums weight_by_likelihood_simd(const T* prior, const T* ll, T top, T* out, Eigen::Index n) {
  using batch = xsimd::batch<T, A>;
  constexpr auto width = static_cast<Eigen::Index>(batch::size);
  const Eigen::Index vec_end = n - n % width;
  const batch floor(log_factor_floor<T>());
  const batch top_b(top);
  const batch zero(T(0));
  // The sums in float lanes over chunks of `mass_sum_chunk_batches` registers, each chunk's
  // total in double (mass_sum.hpp): lanes carried over the whole grid left a 16-million-state
  // posterior summing to 1.019 (AVX2) and 1.034 (SSE2), issue 37.
  constexpr Eigen::Index chunk = mass_sum_chunk_batches * width;
  weight_sums sums;
  Eigen::Index i = 0;
  while (i < vec_end) {
    const Eigen::Index chunk_end = std::min(vec_end, i + chunk);
    batch sum(T(0));
    batch factor_sum(T(0));
    for (; i < chunk_end; i += width) {
      const batch d = batch::load_unaligned(ll + i) - top_b;
      const batch factor = xsimd::select(d < floor, zero, xsimd::exp(d));
      const batch w = batch::load_unaligned(prior + i) * factor;
      w.store_unaligned(out + i);
      sum += w;
      factor_sum += factor;
    }
    sums.posterior += static_cast<double>(xsimd::hadd(sum));
    sums.likelihood += static_cast<double>(xsimd::hadd(factor_sum));
  }
  const weight_sums tail =
      weight_by_likelihood_scalar(prior + vec_end, ll + vec_end, top, out + vec_end, n - vec_end);
  sums.posterior += tail.posterior;
  sums.likelihood += tail.likelihood;
  return sums;
}

template <class T>
weight_sums weight_by_likelihood(const T* prior, const T* ll, T top, T* out, Eigen::Index n) {
#if defined(TACMAP_PRECOMPILED) && TACMAP_PRECOMPILED
  if constexpr (std::is_same_v<T, float>)
    return active_kernels().weight_by_likelihood(prior, ll, top, out, n);
#endif
  return weight_by_likelihood_simd<kernel_arch<T>>(prior, ll, top, out, n);
}

}  // namespace tacmap::detail
