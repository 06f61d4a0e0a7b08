// tacmap::precompiled (private): the table of one architecture's float kernels. Included by one
// translation unit per instruction set, each compiled with that set's flags.
#pragma once

#include "tacmap/detail/weighted_sum.hpp"
#include "tacmap/filter/detail/posterior_kernel.hpp"
#include "tacmap/measurement/detail/distance_kernel.hpp"
#include "tacmap/measurement/detail/quantized_kernel.hpp"
#include "tacmap/simd.hpp"

namespace tacmap::detail {

/// Architecture A's instantiations of the header kernels.
template <class A>
constexpr precompiled_kernels make_kernels(simd_level level) {
  return {level,
          &accumulate_distances_simd<A, float>,
          &accumulate_sign_pair_simd<A, float>,
          &distances_each_simd<A, float>,
          &scan_log_likelihood_simd<A, float>,
          &weight_by_likelihood_simd<A, float>,
          &weighted_sum_simd<A, float>,
          &accumulate_sign_pair_tiles_simd<A, float>,
          &accumulate_distances_tiles_simd<A, float>,
          &quantized_distances_simd<A>,
          &quantize_columns_simd<A>};
}

/// The AVX2 + FMA table (src/simd_avx2.cpp, compiled with -mavx2 -mfma).
extern const precompiled_kernels avx2_fma_kernels;

}  // namespace tacmap::detail
