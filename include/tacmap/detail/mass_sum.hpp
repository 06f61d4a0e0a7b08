// tacmap: detail::mass_sum and detail::chunked_sum — sums of a whole belief (millions of
// non-negative floats) that stay exact to ~1e-7 at every grid size.
//
// A vectorised float sum keeps one running total per lane: at 16 million states each lane adds
// a million values, its total grows a million times larger than what it adds, and every add
// rounds away up to half a unit of the total's last place — a belief then summed to 1.019 (AVX2)
// or 1.034 (SSE2), and a prediction to 0.981 (issue 37). Here the lanes add only a short chunk
// (16 registers: at most 4 values per lane, then a tree), each chunk's total is rounded once to
// float and added in double: the relative error is that of a 16-register chunk, whatever the
// size. The cost is one horizontal add per chunk; with four accumulators it is faster than
// Eigen's flat float sum (bench/filter_bench.cpp, belief_sum, AVX2, a loaded machine, medians
// of 5: 1.5 against 2.6 us at the paper's 8,137 states, 18.5 against 21.7 ms at 16 million).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cstddef>
#include <xsimd/xsimd.hpp>

#include "tacmap/simd.hpp"

namespace tacmap::detail {

/// Registers of values summed in the values' own precision before the total goes to double.
inline constexpr Eigen::Index mass_sum_chunk_batches = 16;

/// The reference: every value added in double, one after the other.
template <class T>
double mass_sum_scalar(const T* v, Eigen::Index n) {
  double total = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) total += static_cast<double>(v[i]);
  return total;
}

/// The sum of v[0, n) with every value in double (the precision of `mass_sum_scalar`), in eight
/// interleaved running totals (value i into total i mod 8, the totals added last in a fixed
/// tree): one chain of dependent double adds is bound by the add's latency (82 % of the
/// estimate of the paper's grid at known heading was the hypotheses' masses summed so), eight
/// chains are not, and the compiler vectorises them. The same order at every call, so the same
/// value bit for bit; it differs from `mass_sum_scalar` only in the rounding of the order
/// (relative ~1e-16 n).
template <class T>
double double_sum(const T* v, Eigen::Index n) {
  constexpr Eigen::Index lanes = 8;
  std::array<double, lanes> t{};
  Eigen::Index i = 0;
  for (; i + lanes <= n; i += lanes)
    for (Eigen::Index k = 0; k < lanes; ++k)
      t[static_cast<std::size_t>(k)] += static_cast<double>(v[i + k]);
  double tail = 0.0;
  for (; i < n; ++i) tail += static_cast<double>(v[i]);
  return (((t[0] + t[4]) + (t[1] + t[5])) + ((t[2] + t[6]) + (t[3] + t[7]))) + tail;
}

/// `double_sum` of a contiguous Eigen array or vector.
template <class Derived>
double double_sum(const Eigen::DenseBase<Derived>& values) {
  static_assert(Derived::IsVectorAtCompileTime || Derived::InnerStrideAtCompileTime == 1,
                "double_sum reads contiguous storage");
  return double_sum(values.derived().data(), values.size());
}

/// Architecture A's sum of v[0, n): chunks of `mass_sum_chunk_batches` registers, four
/// accumulators (four adds per lane), their tree and the lanes' horizontal add in T, the chunk's
/// total in double.
template <class A, class T>
double mass_sum_simd(const T* v, Eigen::Index n) {
  using batch = xsimd::batch<T, A>;
  constexpr auto width = static_cast<Eigen::Index>(batch::size);
  constexpr Eigen::Index chunk = mass_sum_chunk_batches * width;
  double total = 0.0;
  Eigen::Index i = 0;
  for (; i + chunk <= n; i += chunk) {
    batch a0 = batch::load_unaligned(v + i);
    batch a1 = batch::load_unaligned(v + i + width);
    batch a2 = batch::load_unaligned(v + i + 2 * width);
    batch a3 = batch::load_unaligned(v + i + 3 * width);
    for (Eigen::Index k = 4 * width; k < chunk; k += 4 * width) {
      a0 += batch::load_unaligned(v + i + k);
      a1 += batch::load_unaligned(v + i + k + width);
      a2 += batch::load_unaligned(v + i + k + 2 * width);
      a3 += batch::load_unaligned(v + i + k + 3 * width);
    }
    total += static_cast<double>(xsimd::hadd((a0 + a1) + (a2 + a3)));
  }
  for (; i + width <= n; i += width)
    total += static_cast<double>(xsimd::hadd(batch::load_unaligned(v + i)));
  return total + mass_sum_scalar(v + i, n - i);
}

/// The sum of v[0, n) in double, for the compile-time architecture (a memory-bound pass: not
/// dispatched through tacmap::precompiled).
template <class T>
double mass_sum(const T* v, Eigen::Index n) {
  return mass_sum_simd<kernel_arch<T>>(v, n);
}

/// `mass_sum` of a contiguous Eigen array or vector.
template <class Derived>
double mass_sum(const Eigen::DenseBase<Derived>& values) {
  static_assert(Derived::IsVectorAtCompileTime || Derived::InnerStrideAtCompileTime == 1,
                "mass_sum reads contiguous storage");
  return mass_sum(values.derived().data(), values.size());
}

/// The sum of a 1-D Eigen expression (e.g. p log p) in double: chunks of 128 values evaluated
/// and summed by Eigen in the expression's precision (at most 16 adds per lane), the chunks'
/// totals added in double.
template <class Derived>
double chunked_sum(const Eigen::ArrayBase<Derived>& expr) {
  static_assert(Derived::IsVectorAtCompileTime, "chunked_sum sums 1-D expressions");
  constexpr Eigen::Index chunk = 128;
  const Eigen::Index n = expr.size();
  double total = 0.0;
  Eigen::Index i = 0;
  for (; i + chunk <= n; i += chunk)
    total += static_cast<double>(expr.derived().template segment<chunk>(i).sum());
  if (i < n) total += static_cast<double>(expr.derived().segment(i, n - i).sum());
  return total;
}

}  // namespace tacmap::detail
