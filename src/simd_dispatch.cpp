// tacmap::precompiled: the baseline (SSE2) kernels and the choice between levels, compiled with
// the consumer's default flags.
//
// Why the baseline lives in this file, listed first in the library: inline functions that every
// kernel file instantiates (Eigen's and the standard library's) are emitted once per object and
// the linker keeps the first copy it meets. This object is the one the consumer's code pulls in
// first (it defines the entry points), so the copies kept are baseline code, never the AVX2
// object's, and nothing compiled with -mavx2 runs before the CPU check.
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "kernel_table.hpp"

namespace tacmap::detail {
namespace {

constinit const precompiled_kernels sse2_kernels = make_kernels<xsimd::sse2>(simd_level::sse2);

// __builtin_cpu_supports rather than xsimd::available_architectures(): GCC's check also asks the
// OS (XGETBV) whether it saves the AVX registers, which xsimd 8.1's CPUID reading does not.
bool cpu_has_avx2_fma() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}

const precompiled_kernels& choose() {
  const bool avx2 = cpu_has_avx2_fma();
  const char* forced = std::getenv("TACMAP_SIMD");
  if (forced == nullptr || *forced == '\0') return avx2 ? avx2_fma_kernels : sse2_kernels;
  const std::string level(forced);
  if (level == "sse2") return sse2_kernels;
  if (level == "avx2" || level == "avx2+fma") {
    if (!avx2)
      throw std::invalid_argument(
          "tacmap: TACMAP_SIMD=" + level +
          " but this CPU (or its operating system) lacks AVX2 + FMA; set TACMAP_SIMD=sse2 or "
          "unset it to use the best level the CPU has");
    return avx2_fma_kernels;
  }
  throw std::invalid_argument("tacmap: TACMAP_SIMD=\"" + level +
                              "\" is not a level; expected sse2 or avx2 (or unset it to use the "
                              "best level the CPU has)");
}

}  // namespace

const precompiled_kernels* kernels_for(simd_level level) {
  switch (level) {
    case simd_level::sse2:
      return &sse2_kernels;
    case simd_level::avx2_fma:
      return cpu_has_avx2_fma() ? &avx2_fma_kernels : nullptr;
  }
  return nullptr;
}

const precompiled_kernels& active_kernels() {
  static const precompiled_kernels& chosen = choose();  // once per process
  return chosen;
}

}  // namespace tacmap::detail
