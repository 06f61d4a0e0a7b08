// tacmap::precompiled: the float kernels for AVX2 + FMA. This file alone is compiled with
// -mavx2 -mfma (cmake/tacmap_precompiled.cmake); simd_dispatch.cpp calls into it only when the
// CPU has both.
#if !defined(__AVX2__) || !defined(__FMA__)
#error "simd_avx2.cpp must be compiled with -mavx2 -mfma (see cmake/tacmap_precompiled.cmake)"
#endif

#include "kernel_table.hpp"

namespace tacmap::detail {

constinit const precompiled_kernels avx2_fma_kernels =
    make_kernels<xsimd::fma3<xsimd::avx2>>(simd_level::avx2_fma);

}  // namespace tacmap::detail
