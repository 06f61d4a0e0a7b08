// tacmap: detail::weighted_sum, the multi-source multiply-add that dense SIFT's filters, the
// separable motion stencils and the pose model's heading convolution are built from.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <type_traits>

#include "tacmap/simd.hpp"

namespace tacmap::detail {

/// out[i] = sum_t weights[t] * sources[t][i] for i in [0, n): the one inner loop of the
/// descriptor's filters and of the separable motion model. Blocks of 128 bytes (4 AVX registers)
/// stay in registers across all taps, so each output is stored once instead of once per tap
/// (about 1.6x faster than tap-by-tap row updates). `out` must not overlap any source.
///
/// Eigen vectorises it for the translation unit's flags; A names that instruction set (an xsimd
/// architecture) only so that each level's copy in tacmap::precompiled is a symbol of its own.
/// `weighted_sum` chooses it.
template <class A, class T>
void weighted_sum_simd(const T* const* sources, const T* weights, std::size_t taps, T* out,
                       Eigen::Index n) {
  constexpr Eigen::Index block = 128 / static_cast<Eigen::Index>(sizeof(T));
  using chunk = Eigen::Array<T, block, 1>;
  Eigen::Index i = 0;
  for (; i + block <= n; i += block) {
    chunk acc = chunk::Zero();
    for (std::size_t t = 0; t < taps; ++t) {
      acc += weights[t] * Eigen::Map<const chunk>(sources[t] + i);
    }
    Eigen::Map<chunk>(out + i) = acc;
  }
  // The tail: whole registers, then single elements, each accumulated in a register (short
  // rows such as a 42 x 18 tactile image's are mostly tail).
  constexpr Eigen::Index lane = 32 / static_cast<Eigen::Index>(sizeof(T));
  using small = Eigen::Array<T, lane, 1>;
  for (; i + lane <= n; i += lane) {
    small acc = small::Zero();
    for (std::size_t t = 0; t < taps; ++t) {
      acc += weights[t] * Eigen::Map<const small>(sources[t] + i);
    }
    Eigen::Map<small>(out + i) = acc;
  }
  if (i < n && n >= lane) {
    // The last n % lane outputs: one register ending at n, overlapping outputs already
    // written (recomputed to the same values; `out` never overlaps a source), instead of a
    // scalar loop that cost as much as the vector part on 100-wide rows.
    i = n - lane;
    small acc = small::Zero();
    for (std::size_t t = 0; t < taps; ++t) {
      acc += weights[t] * Eigen::Map<const small>(sources[t] + i);
    }
    Eigen::Map<small>(out + i) = acc;
    return;
  }
  for (; i < n; ++i) {  // fewer than one register in all
    T acc = 0;
    for (std::size_t t = 0; t < taps; ++t) acc += weights[t] * sources[t][i];
    out[i] = acc;
  }
}

/// `weighted_sum_simd` for the compile-time flags, or (float, with tacmap::precompiled) compiled
/// for the CPU's best level.
template <class T>
void weighted_sum(const T* const* sources, const T* weights, std::size_t taps, T* out,
                  Eigen::Index n) {
#if defined(TACMAP_PRECOMPILED) && TACMAP_PRECOMPILED
  if constexpr (std::is_same_v<T, float>) {
    active_kernels().weighted_sum(sources, weights, taps, out, n);
    return;
  }
#endif
  weighted_sum_simd<kernel_arch<T>>(sources, weights, taps, out, n);
}

}  // namespace tacmap::detail
