// tacmap: which instruction set the hot kernels run on, and the run-time dispatch behind the
// optional compiled target tacmap::precompiled.
//
// Header-only (linking tacmap::tacmap only): the kernels use xsimd's compile-time default
// architecture, i.e. whatever the consumer's flags enable (SSE2 with a compiler's default x86-64
// flags, AVX2 + FMA with -march=x86-64-v3). Linking tacmap::precompiled defines
// TACMAP_PRECOMPILED=1 for the consumer: the float kernels of the measurement and the update
// (descriptor distances, the posterior's scan and weighting) and the separable filters of dense
// SIFT and the motion models (detail::weighted_sum) then go through entry points
// compiled once per instruction set in that library and chosen once, at the first call, from
// what the CPU offers — so a consumer built with default flags still gets AVX2 + FMA where the
// CPU has it. `simd_info()` tells which is in use.
//
// The environment variable TACMAP_SIMD (read once, at the first dispatched call) forces a
// level: `sse2` or `avx2` (e.g. to compare, or to reproduce a result from an older machine).
// AVX-512 is not dispatched: no machine of the project has it to test and measure it on.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <string_view>
#include <type_traits>
#include <xsimd/xsimd.hpp>

namespace tacmap {

/// The instruction sets tacmap::precompiled carries kernels for.
enum class simd_level {
  sse2,      ///< the x86-64 baseline (every x86-64 CPU)
  avx2_fma,  ///< AVX2 + FMA (x86-64-v3: Intel Haswell 2013, AMD Zen and later)
};

/// What the kernels of this translation unit run on.
struct simd_report {
  /// xsimd's compile-time architecture of this translation unit (what header-only kernels use),
  /// e.g. "sse2" with default flags, "fma3+avx2" with -march=x86-64-v3.
  std::string_view compiled;
  /// True when tacmap::precompiled is linked (TACMAP_PRECOMPILED): the float kernels are
  /// dispatched at run time.
  bool precompiled = false;
  /// The dispatched level's name ("sse2" or "avx2+fma") when `precompiled`, else "none".
  std::string_view dispatched;
};

namespace detail {

/// The name of a level, as TACMAP_SIMD accepts it ("sse2", "avx2").
[[nodiscard]] constexpr std::string_view simd_level_name(simd_level level) {
  return level == simd_level::avx2_fma ? "avx2+fma" : "sse2";
}

/// Bytes of one row of a descriptor tile (see descriptor_tiles): 32, the widest register the
/// dispatched kernels use (AVX2), so that tiles built in any translation unit fit the kernels of
/// every level (SSE2 reads a row as two registers).
inline constexpr std::size_t tile_row_bytes = 32;

/// The architecture of the header-only kernels: xsimd's default for this translation unit,
/// unless its registers are wider than a tile row (an AVX-512 build), where AVX2 + FMA (which
/// such a build also has) is used instead.
template <class T>
using kernel_arch =
    std::conditional_t<(sizeof(xsimd::batch<T, xsimd::default_arch>) <= tile_row_bytes),
                       xsimd::default_arch, xsimd::fma3<xsimd::avx2>>;

template <class T>
class descriptor_tiles;
template <class T>
struct log_likelihood_scan;
struct weight_sums;
struct position_range;
struct tile_range;
class quantized_tiles;
struct quantized_query;
struct quantized_store;
struct quantize_report;

/// The float kernels of one instruction set in tacmap::precompiled (src/simd_*.cpp): the same
/// templates as the header-only kernels, instantiated for that architecture.
struct precompiled_kernels {
  simd_level level;
  void (*accumulate_distances)(const descriptor_tiles<float>& f, const Eigen::ArrayXXf& g,
                               Eigen::Index first, Eigen::Index count, float* out, bool add);
  void (*accumulate_sign_pair)(const descriptor_tiles<float>& f, const float* g, Eigen::Index half,
                               float* plus, float* minus, bool add);
  void (*distances_each)(const descriptor_tiles<float>& f, const Eigen::ArrayXXf& g,
                         const float* g_norms, float* out, Eigen::Index out_stride,
                         const position_range* ranges, tile_range tiles, Eigen::Index group);
  log_likelihood_scan<float> (*scan_log_likelihood)(const float* ll, Eigen::Index n);
  weight_sums (*weight_by_likelihood)(const float* prior, const float* ll, float top, float* out,
                                      Eigen::Index n);
  /// Dense SIFT's filters and the motion models' stencils (Eigen, vectorised for the level).
  void (*weighted_sum)(const float* const* sources, const float* weights, std::size_t taps,
                       float* out, Eigen::Index n);
  /// `accumulate_sign_pair` on a range of tiles (the filter's tracking mode).
  void (*accumulate_sign_pair_tiles)(const descriptor_tiles<float>& f, const float* g,
                                     Eigen::Index half, float* plus, float* minus, bool add,
                                     tile_range tiles);
  /// `accumulate_distances` on a range of tiles (the filter's tracking mode).
  void (*accumulate_distances_tiles)(const descriptor_tiles<float>& f, const Eigen::ArrayXXf& g,
                                     Eigen::Index first, Eigen::Index count, float* out, bool add,
                                     tile_range range);
  /// Distances to descriptors stored as 7-bit integers (quantized_kernel.hpp; issue 14).
  void (*quantized_distances)(const quantized_tiles& f, const quantized_query& g, float* const* out,
                              bool sum, bool add, tile_range range);
  /// A map's descriptors quantised to 7 bits (map preparation; quantized_kernel.hpp).
  quantize_report (*quantize_columns)(const float* src, Eigen::Index stride, Eigen::Index n,
                                      Eigen::Index dim, quantized_store out, Eigen::Index q0);
};

// Defined in tacmap::precompiled (src/simd_dispatch.cpp); declared for every translation unit,
// usable where that library is linked.

/// The kernels of `level`, or null when this CPU (or the OS) lacks it. For tests and
/// comparisons; the library itself uses `active_kernels()`.
[[nodiscard]] const precompiled_kernels* kernels_for(simd_level level);
/// The kernels chosen for this process: the best level the CPU has, or TACMAP_SIMD's. Chosen
/// once (the CPU query and the environment are read at the first call); throws
/// std::invalid_argument for a TACMAP_SIMD value that is unknown or that the CPU lacks.
[[nodiscard]] const precompiled_kernels& active_kernels();

}  // namespace detail

/// What the kernels run on in this translation unit: the compile-time architecture, and with
/// tacmap::precompiled the level dispatched to at run time (which the first call chooses).
[[nodiscard]] inline simd_report simd_info() {
  simd_report r;
  r.compiled = xsimd::default_arch::name();
#if defined(TACMAP_PRECOMPILED) && TACMAP_PRECOMPILED
  r.precompiled = true;
  r.dispatched = detail::simd_level_name(detail::active_kernels().level);
#else
  r.dispatched = "none";
#endif
  return r;
}

}  // namespace tacmap
