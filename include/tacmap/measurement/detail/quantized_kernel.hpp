// tacmap: descriptors stored as 7-bit integers, and their distance kernel (issue 14).
//
// The per-window features of the default model (classic_sift, 120 px map) are 8,137 windows x
// 3 patches x 128 floats = 12.5 MB, streamed once per touch: the update was bound by that
// stream. Stored as bytes they are 3.1 MB, as VLFeat and OpenCV store SIFT: an element v
// becomes round(v * quantization_scale) in [0, 127] (see `quantize` for the clamps), and a
// tactile descriptor is quantised the same way per touch.
//
// Why 7 bits and not 8: the AVX2 kernel multiplies with `vpmaddubsw` (unsigned byte x signed
// byte, adjacent pairs summed in int16 with saturation). With both operands in [0, 127] (the
// map) and [-127, 127] (the touch) a pair sums to at most 2 x 127 x 127 = 32,258 < 32,767: it
// can never saturate, so the integer dot product is exact. 8-bit map values (255) could.
//
// Why the result is exact: ||F||^2 + ||g||^2 - 2 F.g is evaluated in int32 (at most
// 128 x 127^2 x 4 < 2^24 for 128 elements), so the expansion has no cancellation error (the
// float kernel recomputes near-matches from differences; this one never needs to) and an exact
// match gives exactly 0. The int32 value converts to float exactly (< 2^24); the distance is
// sqrt(d2 * scale^-2), one rounding each, in the same order in every kernel: the AVX2 kernel,
// the portable one and the scalar reference give the same bits.
//
// Layout: a tile holds 8 positions; its row r (32 bytes) holds elements 4r .. 4r + 3 of each of
// the 8 positions (position p at bytes 4p .. 4p + 3), so one `vpmaddubsw` + `vpmaddwd` gives 8
// partial dot products of 4 elements, one per position, with no horizontal sums. The dimension
// is padded with zeros to a multiple of 4 (zeros change no dot product or norm).
//
// Two rows per widening, where it is exact: `vpmaddwd` (the widening to int32) takes as many
// multiplier cycles as `vpmaddubsw`, so the AVX2 kernel adds two rows' int16 pair sums first
// and widens once (3 multiplies per 2 rows instead of 4). A lane then holds 4 products, exact
// in int16 when 4 x A x B <= 32,767, A being the largest map byte of the tiles and B the
// largest |touch byte| (`paired_rows_bound`). Each tile keeps its A (`quantized_tiles::peak`,
// set when it is written) and each query column its B, so the kernel decides per block of
// tiles; SIFT's 0.2 clamp keeps A and B near 64-95 for almost every tile (the default 120 px
// map: 98 % of the blocks). Others take one row per widening: every path gives the same
// integers, hence the same bits.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <optional>
#include <type_traits>
#include <vector>
#include <xsimd/xsimd.hpp>

#if defined(__AVX2__)
#include <immintrin.h>
#elif defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "tacmap/config.hpp"
#include "tacmap/detail/huge_pages.hpp"
#include "tacmap/measurement/detail/distance_kernel.hpp"

namespace tacmap::detail {

/// Integer steps per unit of a descriptor element. 254: [0, 0.5] is covered by the 7 bits, as
/// VLFeat's and OpenCV's 512 x v saturated at 255 covers [0, 0.498] with 8. SIFT elements are
/// <= 1 but above 0.5 only in descriptors with at most 3 strong bins (the 0.2 clamp and the
/// renormalisation); those are clamped at 127 and counted (`quantized_tiles::clamped`).
inline constexpr float quantization_scale = 254.0F;

/// Result of quantising one value: the integer and whether it was clamped.
struct quantized_value {
  std::int32_t value = 0;
  bool clamped = false;
};

/// round(v * quantization_scale) clamped to [lowest, 127]. Clamped (reported): values beyond
/// the range, and a NaN (to 0) — never a NaN or an out-of-range byte downstream.
[[nodiscard]] inline quantized_value quantize(float v, std::int32_t lowest) {
  const float x = v * quantization_scale;
  if (!(x >= static_cast<float>(lowest))) return {lowest == 0 || std::isnan(x) ? 0 : lowest, true};
  if (x > 127.0F) return {127, x >= 127.5F};  // rounds to 127 unless it exceeds it
  // std::lround (halves away from zero) without the library call: |x| <= 127, so the
  // remainder |x| - trunc|x| is exact.
  const float a = std::fabs(x);
  const auto t = static_cast<std::int32_t>(a);
  const std::int32_t r = t + (a - static_cast<float>(t) >= 0.5F ? 1 : 0);
  return {x < 0.0F ? -r : r, false};
}

/// Where `quantize_columns` writes: `quantized_tiles`' layout (tiles of 8 positions, `rows`
/// 32-byte rows each) and the squared norms, one per position.
struct quantized_store {
  std::uint8_t* data = nullptr;
  std::int32_t* norms = nullptr;
  Eigen::Index rows = 0;

  /// Position q's first group in its tile (its later groups are 32-byte rows further on).
  [[nodiscard]] std::uint8_t* lane(Eigen::Index q) const;
};

/// What `quantize_columns` did: the elements clamped at 127 (NaN counted, stored as 0), and
/// whether it stopped at a column with a negative element.
struct quantize_report {
  std::uint64_t clamped = 0;
  bool negative = false;
};

/// `quantize(v, 0)` of every element of `n` float columns of `dim` elements (column j at
/// `src + j * stride`), stored as positions q0 .. q0 + n - 1 of `out` with their squared norms
/// (groups past `dim` are zeros). Stops at the first column with a negative element (reported;
/// that column may be stored in part). Defined below; the kernel of the CPU's level with
/// tacmap::precompiled.
inline quantize_report quantize_columns(const float* src, Eigen::Index stride, Eigen::Index n,
                                        Eigen::Index dim, quantized_store out, Eigen::Index q0);

/// The largest A x B (map byte x |touch byte|) for which the int16 sum of two rows' pair sums
/// (4 products) cannot leave [-32,768, 32,767]: 4 x 8,191 = 32,764.
inline constexpr std::int32_t paired_rows_bound = 8191;

/// Descriptors of `positions` positions as 7-bit integers, tiled for `quantized_distances`.
class quantized_tiles {
 public:
  static constexpr Eigen::Index width = 8;       ///< positions per tile
  static constexpr Eigen::Index group = 4;       ///< elements per position in a 32-byte row
  static constexpr Eigen::Index row_bytes = 32;  ///< width * group

  quantized_tiles() = default;
  /// Room for `positions` descriptors of `dimension` elements, every one to be set.
  quantized_tiles(Eigen::Index positions, Eigen::Index dimension)
      : positions_(positions), dim_(dimension), rows_((dimension + group - 1) / group) {
    const Eigen::Index tiles = (positions + width - 1) / width;
    // Huge pages asked for before the first touch: 140 MB for a 640 x 480 map's three
    // SIFT-lite patches, faulted in 4 KB pages otherwise (bench/camera_bench.cpp, build rows).
    const auto bytes = static_cast<std::size_t>(tiles * rows_ * row_bytes);
    data_.reserve(bytes);
    advise_huge_pages(data_.data(), bytes);
    data_.assign(bytes, 0);
    norms_.assign(static_cast<std::size_t>(tiles * width), 0);
    peaks_.assign(static_cast<std::size_t>(tiles), 0);
  }
  /// Quantises and stores descriptors `columns` (dimension x n) at positions q0 .. q0 + n - 1.
  /// Elements above the range are clamped at 127 and counted (`clamped`); a negative element
  /// is refused (returns false, and the tiles are left part-written: discard them): the map
  /// side is unsigned.
  template <class Derived>
  [[nodiscard]] bool set_columns(Eigen::Index q0, const Eigen::DenseBase<Derived>& columns) {
    TACMAP_ASSERT(columns.rows() == dim_ && q0 >= 0 && q0 + columns.cols() <= positions_,
                  "quantized_tiles::set_columns: columns outside the tiles");
    const quantized_store out = raw_store();
    quantize_report report;
    using plain = std::decay_t<decltype(columns.derived())>;
    if constexpr (std::is_same_v<typename Derived::Scalar, float> &&
                  (static_cast<unsigned>(plain::Flags) & Eigen::DirectAccessBit) != 0 &&
                  !static_cast<bool>(plain::IsRowMajor)) {
      // Contiguous float columns (the map's blocks): straight from their storage.
      if (columns.rows() > 1 && columns.derived().innerStride() != 1)
        return copy_and_set(q0, columns);
      report = quantize_columns(columns.derived().data(), columns.derived().outerStride(),
                                columns.cols(), dim_, out, q0);
    } else {
      return copy_and_set(q0, columns);
    }
    return finish_set(q0, columns.cols(), report);
  }
  /// Where `quantize_columns` writes into these tiles (for the kernels and their tests). The
  /// tiles' peaks become 127 (unknown): the kernel then widens one row at a time, exact for any
  /// byte written there.
  [[nodiscard]] quantized_store store() {
    std::fill(peaks_.begin(), peaks_.end(), std::uint8_t{127});
    return raw_store();
  }
  /// The largest byte of tile t (an upper bound: 127 after `store()`), for the kernel's choice
  /// of two rows per widening (`paired_rows_bound`).
  [[nodiscard]] std::int32_t peak(Eigen::Index t) const {
    return peaks_[static_cast<std::size_t>(t)];
  }
  /// Element k of position q (an integer in [0, 127]).
  [[nodiscard]] std::int32_t at(Eigen::Index q, Eigen::Index k) const {
    return data_[static_cast<std::size_t>((q / width) * rows_ * row_bytes +
                                          (k / group) * row_bytes + (q % width) * group +
                                          k % group)];
  }
  [[nodiscard]] Eigen::Index positions() const { return positions_; }
  [[nodiscard]] Eigen::Index dimension() const { return dim_; }
  /// 32-byte rows per tile: the dimension / 4, rounded up.
  [[nodiscard]] Eigen::Index rows() const { return rows_; }
  [[nodiscard]] Eigen::Index tiles() const { return (positions_ + width - 1) / width; }
  [[nodiscard]] const std::uint8_t* tile(Eigen::Index t) const {
    return data_.data() + t * rows_ * row_bytes;
  }
  /// ||F(q)||^2 in integer units from position q on (0 past the last position).
  [[nodiscard]] const std::int32_t* squared_norms_from(Eigen::Index q) const {
    return norms_.data() + q;
  }
  /// Elements clamped at 127 so far (values above 127.5 / quantization_scale).
  [[nodiscard]] std::uint64_t clamped() const { return clamped_; }
  /// Bytes held per position for descriptors of `dimension` elements (the memory check; the
  /// last tile's padding, under 8 positions, aside): the elements rounded up to a multiple of
  /// 4, and the norm.
  [[nodiscard]] static constexpr std::uint64_t bytes_per_position(std::uint64_t dimension) {
    return (dimension + group - 1) / group * group + sizeof(std::int32_t);
  }

 private:
  Eigen::Index positions_ = 0;
  Eigen::Index dim_ = 0;
  Eigen::Index rows_ = 0;
  std::uint64_t clamped_ = 0;
  // Other expressions and scalars (double descriptors): as a float matrix first.
  template <class Derived>
  [[nodiscard]] bool copy_and_set(Eigen::Index q0, const Eigen::DenseBase<Derived>& columns) {
    values_ = columns.template cast<float>();
    const quantize_report report =
        quantize_columns(values_.data(), values_.rows(), values_.cols(), dim_, raw_store(), q0);
    return finish_set(q0, values_.cols(), report);
  }
  [[nodiscard]] quantized_store raw_store() { return {data_.data(), norms_.data(), rows_}; }
  // The peaks of the tiles positions q0 .. q0 + n - 1 lie in, from their bytes (the whole
  // tiles: a tile may be written in parts). A plain loop the compiler vectorises: 0.1 ms of
  // the 120 px map's 3.2 MB.
  [[nodiscard]] bool finish_set(Eigen::Index q0, Eigen::Index n, const quantize_report& report) {
    clamped_ += report.clamped;
    if (n > 0) {
      const Eigen::Index tile_bytes = rows_ * row_bytes;
      for (Eigen::Index t = q0 / width; t <= (q0 + n - 1) / width; ++t) {
        const std::uint8_t* b = data_.data() + t * tile_bytes;
        std::uint8_t top = 0;
        for (Eigen::Index k = 0; k < tile_bytes; ++k) top = std::max(top, b[k]);
        peaks_[static_cast<std::size_t>(t)] = top;
      }
    }
    return !report.negative;
  }

  Eigen::ArrayXXf values_;  // copy_and_set's scratch
  // 64-byte aligned: the AVX2 kernel loads whole rows aligned.
  std::vector<std::uint8_t, xsimd::aligned_allocator<std::uint8_t, 64>> data_;
  std::vector<std::int32_t, xsimd::aligned_allocator<std::int32_t, 64>> norms_;
  std::vector<std::uint8_t> peaks_;  // one per tile: its largest byte (see `peak`)
};

inline std::uint8_t* quantized_store::lane(Eigen::Index q) const {
  return data + (q / quantized_tiles::width) * rows * quantized_tiles::row_bytes +
         (q % quantized_tiles::width) * quantized_tiles::group;
}

/// Tactile descriptors quantised for `quantized_distances`: column j's elements as signed bytes
/// in [-127, 127] (padded with zeros to whole 4-element groups), and its squared norm.
struct quantized_query {
  Eigen::Index dimension = 0;
  Eigen::Index rows = 0;            // 4-element groups
  std::vector<std::int8_t> values;  // column j at j * rows * 4
  std::vector<std::int32_t> norms;  // one per column
  std::vector<std::int32_t> peaks;  // one per column: its largest |element|
  std::uint64_t clamped = 0;        // elements clamped into [-127, 127]

  [[nodiscard]] Eigen::Index count() const { return static_cast<Eigen::Index>(norms.size()); }
  /// Column j's largest |element| (127 where `peaks` was not filled: the exact bound for any).
  [[nodiscard]] std::int32_t peak(Eigen::Index j) const {
    return j < static_cast<Eigen::Index>(peaks.size()) ? peaks[static_cast<std::size_t>(j)] : 127;
  }
  [[nodiscard]] const std::int8_t* column(Eigen::Index j) const {
    return values.data() + j * rows * quantized_tiles::group;
  }
  /// Quantises `g`'s columns (reusing this object's storage between touches).
  template <class Derived>
  void assign(const Eigen::DenseBase<Derived>& g) {
    dimension = g.rows();
    rows = (dimension + quantized_tiles::group - 1) / quantized_tiles::group;
    values.assign(static_cast<std::size_t>(g.cols() * rows * quantized_tiles::group), 0);
    norms.assign(static_cast<std::size_t>(g.cols()), 0);
    peaks.assign(static_cast<std::size_t>(g.cols()), 0);
    clamped = 0;
    for (Eigen::Index j = 0; j < g.cols(); ++j)
      for (Eigen::Index k = 0; k < dimension; ++k) {
        const quantized_value c = quantize(static_cast<float>(g(k, j)), -127);
        clamped += c.clamped ? 1U : 0U;
        values[static_cast<std::size_t>(j * rows * quantized_tiles::group + k)] =
            static_cast<std::int8_t>(c.value);
        norms[static_cast<std::size_t>(j)] += c.value * c.value;
        auto& top = peaks[static_cast<std::size_t>(j)];
        top = std::max(top, c.value < 0 ? -c.value : c.value);
      }
  }
};

/// The distance of one integer squared distance, in descriptor units: sqrt(d2 / scale^2).
/// Every kernel ends with this expression, so they agree bit for bit.
[[nodiscard]] inline float quantized_distance(std::int32_t d2) {
  constexpr float inverse_square = 1.0F / (quantization_scale * quantization_scale);
  return std::sqrt(static_cast<float>(d2) * inverse_square);
}

/// Plain reference: with `sum`, out[0][q] (+)= sum_j || F(q) - g_j ||; otherwise
/// out[j][q] (+)= || F(q) - g_j ||, for every position q (added when `add`, else stored). The
/// sum is taken in groups of three descriptors, each group added to the output, as the
/// kernels do.
inline void quantized_distances_scalar(const quantized_tiles& f, const quantized_query& g,
                                       float* const* out, bool sum, bool add) {
  for (Eigen::Index q = 0; q < f.positions(); ++q) {
    float total = 0.0F;
    bool added = add;
    for (Eigen::Index j = 0; j < g.count(); ++j) {
      std::int32_t d2 = 0;
      for (Eigen::Index k = 0; k < f.dimension(); ++k) {
        const std::int32_t d = f.at(q, k) - g.column(j)[k];
        d2 += d * d;
      }
      const float d = quantized_distance(d2);
      if (sum) {
        total = j % 3 == 0 ? d : total + d;
        if (j % 3 == 2 || j + 1 == g.count()) {
          out[0][q] = added ? out[0][q] + total : total;
          added = true;
        }
      } else {
        float& o = out[j][q];
        o = add ? o + d : d;
      }
    }
  }
}

namespace quantized_kernel {

// Finishes one tile: the integer dot products `dot[j][p]` of its (up to) 8 positions become
// distances, summed or stored per descriptor, written from position `first` (relative to
// `origin`). Shared by both kernels, so that every one rounds alike.
template <std::size_t Count, class A>
void finish_tile(const quantized_tiles& f, const quantized_query& g, Eigen::Index j0,
                 const std::int32_t (&dot)[Count][quantized_tiles::width], Eigen::Index first,
                 float* const* out, bool sum, bool add, Eigen::Index origin) {
  const std::int32_t* nf = f.squared_norms_from(first);
  const Eigen::Index real = std::min(quantized_tiles::width, f.positions() - first);
  for (Eigen::Index p = 0; p < real; ++p) {
    float total = 0.0F;
    for (std::size_t j = 0; j < Count; ++j) {
      const auto jj = j0 + static_cast<Eigen::Index>(j);
      const float d = quantized_distance(nf[p] + g.norms[static_cast<std::size_t>(jj)] -
                                         2 * dot[j][static_cast<std::size_t>(p)]);
      if (sum) {
        total = j == 0 ? d : total + d;
      } else {
        float& o = out[jj][first + p - origin];
        o = add ? o + d : d;
      }
    }
    if (sum) {
      float& o = out[0][first + p - origin];
      o = add ? o + total : total;
    }
  }
}

// Portable: integer multiply-adds on whatever the compiler vectorises them to. (Templates on A
// like every kernel here: each translation unit's copy is a different function, so the linker
// never picks an AVX2-compiled copy for the baseline.)
template <std::size_t Count, class A>
void tile_dots_portable(const quantized_tiles& f, Eigen::Index t, const quantized_query& g,
                        Eigen::Index j0, std::int32_t (&dot)[Count][quantized_tiles::width]) {
  const std::uint8_t* tile = f.tile(t);
  for (std::size_t j = 0; j < Count; ++j) {
    const std::int8_t* gj = g.column(j0 + static_cast<Eigen::Index>(j));
    std::int32_t acc[quantized_tiles::width] = {};
    for (Eigen::Index r = 0; r < f.rows(); ++r) {
      const std::uint8_t* row = tile + r * quantized_tiles::row_bytes;
      const std::int8_t* gr = gj + r * quantized_tiles::group;
      for (std::size_t p = 0; p < quantized_tiles::width; ++p)
        for (std::size_t e = 0; e < quantized_tiles::group; ++e)
          acc[p] += static_cast<std::int32_t>(row[p * quantized_tiles::group + e]) * gr[e];
    }
    for (std::size_t p = 0; p < quantized_tiles::width; ++p) dot[j][p] = acc[p];
  }
}

#if defined(__AVX2__)
// AVX2: xsimd 8.1 has no byte multiply-add, so this one kernel uses the intrinsics directly.
// Per 32-byte row and descriptor: vpmaddubsw (u8 map x s8 touch -> 16 int16 pair sums, exact:
// see the top of this file) and vpmaddwd with ones (-> 8 int32 sums of 4 products, one per
// position). `gb`: each descriptor's column; its 4-element groups are broadcast to 8 int32 lanes.
//
// Whole tiles are finished in registers too, with the operations of `finish_tile` in its order
// (exact integers, one float multiply, a correctly rounded sqrt, the same sums): the same bits.
// Scalar, the finish (8 square roots per tile) cost as much as the dot products. The last,
// partial tile goes the portable way.
// Tiles whole tiles from t0 on against descriptors [j0, j0 + Count): several tiles at once, so
// that each broadcast row of the touch is loaded once for all of them and more loads of the
// map are in flight (measured: one tile at a time was bound by its loads' latency). Paired:
// two rows' int16 pair sums added before one widening (the caller checked
// `paired_rows_bound`; see the top of this file).
template <std::size_t Tiles, std::size_t Count, bool Paired, class A>
void block_avx2(const quantized_tiles& f, const quantized_query& g, Eigen::Index j0,
                Eigen::Index t0, const std::int8_t* const* gb, float* const* out, bool sum,
                bool add, Eigen::Index origin) {
  const Eigen::Index rows = f.rows();
  const __m256i ones = _mm256_set1_epi16(1);
  const std::uint8_t* tile[Tiles];
  __m256i acc[Tiles][Count];
  for (std::size_t i = 0; i < Tiles; ++i) tile[i] = f.tile(t0 + static_cast<Eigen::Index>(i));
  // The map's bytes of the block after next, a row's share at a time (see the caller's note).
  const char* ahead = reinterpret_cast<const char*>(tile[0]) +
                      2 * static_cast<Eigen::Index>(Tiles) * rows * quantized_tiles::row_bytes;
  constexpr auto row_share = static_cast<Eigen::Index>(Tiles) * quantized_tiles::row_bytes;
  // Rows r .. r + Rows - 1 (1 or 2). The first call sets the sums, later ones add to them:
  // zeroing the array first made GCC 12 clear a stack copy with `rep stos` at every block (7 %
  // of the kernel's time in the profile).
  const auto rows_at = [&]<bool First, std::size_t Rows>(Eigen::Index r) {
    constexpr auto row_count = static_cast<Eigen::Index>(Rows);
    for (Eigen::Index b = 0; b < row_count * row_share; b += 64)
      _mm_prefetch(ahead + r * row_share + b, _MM_HINT_T0);
    __m256i gr[Rows][Count];
    for (std::size_t k = 0; k < Rows; ++k)
      for (std::size_t j = 0; j < Count; ++j) {
        std::int32_t four = 0;  // one vpbroadcastd from memory (a load, no shuffle)
        std::memcpy(&four, gb[j] + (r + static_cast<Eigen::Index>(k)) * quantized_tiles::group,
                    sizeof four);
        gr[k][j] = _mm256_set1_epi32(four);
      }
    for (std::size_t i = 0; i < Tiles; ++i) {
      __m256i v[Rows];
      for (std::size_t k = 0; k < Rows; ++k)
        v[k] = _mm256_load_si256(reinterpret_cast<const __m256i*>(
            tile[i] + (r + static_cast<Eigen::Index>(k)) * quantized_tiles::row_bytes));
      for (std::size_t j = 0; j < Count; ++j) {
        __m256i pairs = _mm256_maddubs_epi16(v[0], gr[0][j]);
        if constexpr (Rows == 2)
          pairs = _mm256_add_epi16(pairs, _mm256_maddubs_epi16(v[1], gr[1][j]));
        const __m256i p = _mm256_madd_epi16(pairs, ones);
        acc[i][j] = First ? p : _mm256_add_epi32(acc[i][j], p);
      }
    }
  };
  // rows >= 1: a descriptor has at least one element.
  if (Paired && rows >= 2) {
    rows_at.template operator()<true, 2>(0);
    Eigen::Index r = 2;
    for (; r + 1 < rows; r += 2) rows_at.template operator()<false, 2>(r);
    if (r < rows) rows_at.template operator()<false, 1>(r);
  } else {
    rows_at.template operator()<true, 1>(0);
    for (Eigen::Index r = 1; r < rows; ++r) rows_at.template operator()<false, 1>(r);
  }
  const __m256 inverse_square = _mm256_set1_ps(1.0F / (quantization_scale * quantization_scale));
  for (std::size_t i = 0; i < Tiles; ++i) {
    const Eigen::Index first = (t0 + static_cast<Eigen::Index>(i)) * quantized_tiles::width;
    const __m256i nf =
        _mm256_load_si256(reinterpret_cast<const __m256i*>(f.squared_norms_from(first)));
    __m256 total = _mm256_setzero_ps();
    for (std::size_t j = 0; j < Count; ++j) {
      const auto jj = j0 + static_cast<Eigen::Index>(j);
      const __m256i both =
          _mm256_add_epi32(nf, _mm256_set1_epi32(g.norms[static_cast<std::size_t>(jj)]));
      const __m256i d2 = _mm256_sub_epi32(both, _mm256_slli_epi32(acc[i][j], 1));
      const __m256 d = _mm256_sqrt_ps(_mm256_mul_ps(_mm256_cvtepi32_ps(d2), inverse_square));
      if (sum) {
        total = j == 0 ? d : _mm256_add_ps(total, d);
      } else {
        float* o = out[jj] + first - origin;
        _mm256_storeu_ps(o, add ? _mm256_add_ps(_mm256_loadu_ps(o), d) : d);
      }
    }
    if (sum) {
      float* o = out[0] + first - origin;
      _mm256_storeu_ps(o, add ? _mm256_add_ps(_mm256_loadu_ps(o), total) : total);
    }
  }
}

// The integer dot products of tile t (its positions past the last are zero bytes) with the
// descriptors `gb`, as `tile_dots_portable` gives them: for the partial last tile, whose
// outputs `block_avx2` would write past the end (the portable loop cost 2 % of a touch).
template <std::size_t Count, class A>
void tile_dots_avx2(const quantized_tiles& f, Eigen::Index t, const std::int8_t* const* gb,
                    std::int32_t (&dot)[Count][quantized_tiles::width]) {
  const __m256i ones = _mm256_set1_epi16(1);
  const std::uint8_t* tile = f.tile(t);
  __m256i acc[Count];
  for (std::size_t j = 0; j < Count; ++j) acc[j] = _mm256_setzero_si256();
  for (Eigen::Index r = 0; r < f.rows(); ++r) {
    const __m256i v =
        _mm256_load_si256(reinterpret_cast<const __m256i*>(tile + r * quantized_tiles::row_bytes));
    for (std::size_t j = 0; j < Count; ++j) {
      std::int32_t four = 0;
      std::memcpy(&four, gb[j] + r * quantized_tiles::group, sizeof four);
      acc[j] = _mm256_add_epi32(
          acc[j], _mm256_madd_epi16(_mm256_maddubs_epi16(v, _mm256_set1_epi32(four)), ones));
    }
  }
  for (std::size_t j = 0; j < Count; ++j)
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(dot[j]), acc[j]);
}
#endif

// True when architecture A's kernel is the AVX2 one (compiled with AVX2 and A at least AVX2).
template <class A>
constexpr bool uses_avx2() {
#if defined(__AVX2__)
  return std::is_base_of_v<xsimd::avx2, A>;
#else
  return false;
#endif
}

// Tiles of `range` against descriptors [j0, j0 + Count).
template <std::size_t Count, class A>
void tiles(const quantized_tiles& f, const quantized_query& g, Eigen::Index j0, float* const* out,
           bool sum, bool add, tile_range range) {
  const Eigen::Index end = range.end < 0 ? f.tiles() : std::min(range.end, f.tiles());
  const Eigen::Index origin = range.begin * quantized_tiles::width;
  std::int32_t dot[Count][quantized_tiles::width];
  if constexpr (uses_avx2<A>()) {
#if defined(__AVX2__)
    const std::int8_t* gb[Count];
    for (std::size_t j = 0; j < Count; ++j) gb[j] = g.column(j0 + static_cast<Eigen::Index>(j));
    constexpr std::size_t per_block = Count == 1 ? 4 : 2;
    constexpr auto step = static_cast<Eigen::Index>(per_block);
    const Eigen::Index whole = std::min(end, f.positions() / quantized_tiles::width);
    // Two rows per widening where the bytes allow it (see the top of this file).
    std::int32_t touch_peak = 0;
    for (std::size_t j = 0; j < Count; ++j)
      touch_peak = std::max(touch_peak, g.peak(j0 + static_cast<Eigen::Index>(j)));
    const auto paired = [&](Eigen::Index first, Eigen::Index n) {
      std::int32_t map_peak = 0;
      for (Eigen::Index i = first; i < first + n; ++i) map_peak = std::max(map_peak, f.peak(i));
      return map_peak * touch_peak <= paired_rows_bound;
    };
    Eigen::Index t = range.begin;
    for (; t + step <= whole; t += step) {
      if (paired(t, step))
        block_avx2<per_block, Count, true, A>(f, g, j0, t, gb, out, sum, add, origin);
      else
        block_avx2<per_block, Count, false, A>(f, g, j0, t, gb, out, sum, add, origin);
    }
    for (; t < whole; ++t) {
      if (paired(t, 1))
        block_avx2<1, Count, true, A>(f, g, j0, t, gb, out, sum, add, origin);
      else
        block_avx2<1, Count, false, A>(f, g, j0, t, gb, out, sum, add, origin);
    }
    for (; t < end; ++t) {  // the partial last tile: its padding is zeros, finished in scalar
      tile_dots_avx2<Count, A>(f, t, gb, dot);
      finish_tile<Count, A>(f, g, j0, dot, t * quantized_tiles::width, out, sum, add, origin);
    }
#endif
  } else {
    for (Eigen::Index t = range.begin; t < end; ++t) {
      tile_dots_portable<Count, A>(f, t, g, j0, dot);
      finish_tile<Count, A>(f, g, j0, dot, t * quantized_tiles::width, out, sum, add, origin);
    }
  }
}

}  // namespace quantized_kernel

namespace quantized_kernel {

// `quantize(v, 0)` of elements [from, dim) of column x into its lane (`quantized_store::lane`),
// and zeros up to the end of its last group; adds the clamped ones to `report`. Returns their
// squared norm, or nothing (report.negative set) at a negative element.
inline std::optional<std::int32_t> quantize_rest(const float* x, Eigen::Index from,
                                                 Eigen::Index dim, Eigen::Index rows,
                                                 std::uint8_t* lane, quantize_report& report) {
  std::int32_t norm = 0;
  for (Eigen::Index k = from; k < rows * quantized_tiles::group; ++k) {
    quantized_value c;
    if (k < dim) {
      if (x[k] < 0.0F) {
        report.negative = true;
        return std::nullopt;
      }
      c = quantize(x[k], 0);
    }
    report.clamped += c.clamped ? 1U : 0U;
    norm += c.value * c.value;
    lane[(k / quantized_tiles::group) * quantized_tiles::row_bytes + k % quantized_tiles::group] =
        static_cast<std::uint8_t>(c.value);
  }
  return norm;
}

}  // namespace quantized_kernel

/// `quantize_columns`' plain reference: `quantize(v, 0)` element by element.
inline quantize_report quantize_columns_scalar(const float* src, Eigen::Index stride,
                                               Eigen::Index n, Eigen::Index dim,
                                               quantized_store out, Eigen::Index q0) {
  quantize_report report;
  for (Eigen::Index j = 0; j < n; ++j) {
    const auto norm = quantized_kernel::quantize_rest(src + j * stride, 0, dim, out.rows,
                                                      out.lane(q0 + j), report);
    if (!norm) return report;
    out.norms[q0 + j] = *norm;
  }
  return report;
}

namespace quantized_kernel {

// Stores the codes of one batch (whole 4-element groups, integers in [0, 127]) as the bytes of
// consecutive 32-byte rows from `at`: packed in registers on SSE2 and AVX2.
template <class A>
void store_groups(const xsimd::batch<std::int32_t, A>& codes, std::uint8_t* at) {
  constexpr std::size_t size = xsimd::batch<std::int32_t, A>::size;
#if defined(__AVX2__)
  if constexpr (uses_avx2<A>()) {
    // Packs stay within 128-bit lanes: bytes 0-3 of each lane are that lane's 4 codes.
    const __m256i c = codes;
    const __m256i bytes = _mm256_packus_epi16(_mm256_packs_epi32(c, c), c);
    const std::int32_t low = _mm256_cvtsi256_si32(bytes);
    const std::int32_t high = _mm256_extract_epi32(bytes, 4);
    std::memcpy(at, &low, 4);
    std::memcpy(at + quantized_tiles::row_bytes, &high, 4);
    return;
  }
#endif
#if defined(__SSE2__)
  if constexpr (std::is_base_of_v<xsimd::sse2, A> && size == 4) {
    const __m128i c = codes;
    const std::int32_t word = _mm_cvtsi128_si32(_mm_packus_epi16(_mm_packs_epi32(c, c), c));
    std::memcpy(at, &word, 4);
    return;
  }
#endif
  alignas(64) std::int32_t v[size];
  codes.store_aligned(v);
  for (std::size_t e = 0; e < size; ++e)
    at[(e / 4) * quantized_tiles::row_bytes + e % 4] = static_cast<std::uint8_t>(v[e]);
}

}  // namespace quantized_kernel

/// `quantize_columns` on architecture A: whole batches of a column in registers, the rest by
/// the scalar rule. The same integers as the reference (tested at every rounding tie): the
/// value is clamped to [0, 127] first (a NaN becomes 0), truncated, and rounded up where the
/// remainder (exact: both below 2^24) is at least 0.5, which is std::lround on [0, 127].
/// Counts and squared norms are summed as floats: integers below 2^24, so exact.
template <class A>
quantize_report quantize_columns_simd(const float* src, Eigen::Index stride, Eigen::Index n,
                                      Eigen::Index dim, quantized_store out, Eigen::Index q0) {
  using batch = xsimd::batch<float, A>;
  constexpr auto size = static_cast<Eigen::Index>(batch::size);
  if constexpr (size % quantized_tiles::group != 0) {
    return quantize_columns_scalar(src, stride, n, dim, out, q0);
  } else {
    quantize_report report;
    const Eigen::Index whole = dim / size * size;
    const batch scale(quantization_scale), top(127.0F), half(0.5F), one(1.0F), zero(0.0F);
    for (Eigen::Index j = 0; j < n; ++j) {
      const float* x = src + j * stride;
      const Eigen::Index q = q0 + j;
      std::uint8_t* lane = out.lane(q);
      auto negative = batch(0.0F) != batch(0.0F);
      batch clamped(0.0F), norm(0.0F);
      for (Eigen::Index k = 0; k < whole; k += size) {
        const batch v = batch::load_unaligned(x + k) * scale;
        negative = negative | (v < zero);
        // Clamped: at least 127.5, or NaN (ordered compare: false for NaN; `v != v` is not
        // portable here, AVX's _CMP_NEQ_OQ is false for NaN).
        clamped += xsimd::select(v < batch(127.5F), zero, one);
        const batch y = xsimd::select(v >= zero, xsimd::min(v, top), zero);
        const batch t = xsimd::to_float(xsimd::to_int(y));  // truncation
        const batch code = t + xsimd::select(y - t >= half, one, zero);
        norm = xsimd::fma(code, code, norm);
        quantized_kernel::store_groups<A>(
            xsimd::to_int(code), lane + (k / quantized_tiles::group) * quantized_tiles::row_bytes);
      }
      if (xsimd::any(negative)) {
        report.negative = true;
        return report;
      }
      // The rest of the column and the zero padding of its last group.
      const auto rest = quantized_kernel::quantize_rest(x, whole, dim, out.rows, lane, report);
      if (!rest) return report;
      report.clamped += static_cast<std::uint64_t>(xsimd::hadd(clamped));
      out.norms[q] = static_cast<std::int32_t>(xsimd::hadd(norm)) + *rest;
    }
    return report;
  }
}

inline quantize_report quantize_columns(const float* src, Eigen::Index stride, Eigen::Index n,
                                        Eigen::Index dim, quantized_store out, Eigen::Index q0) {
#if defined(TACMAP_PRECOMPILED) && TACMAP_PRECOMPILED
  return active_kernels().quantize_columns(src, stride, n, dim, out, q0);
#else
  return quantize_columns_simd<kernel_arch<float>>(src, stride, n, dim, out, q0);
#endif
}

/// With `sum`: out[0][q] (+)= sum_j || F(q) - g_j || over g's descriptors; otherwise
/// out[j][q] (+)= || F(q) - g_j ||; added when `add`, else stored. Only the positions of the
/// tiles `range` (8 positions each), written relative to its first position
/// (out[j][q - range.begin * 8]); every tile is computed alike wherever a range starts, so a
/// range's values are the whole pass's bit for bit (the filter's tracking mode).
/// Architecture A's kernel (the AVX2 one where A and the compiler flags have AVX2, else
/// portable integer code); `quantized_distances` chooses A.
template <class A>
void quantized_distances_simd(const quantized_tiles& f, const quantized_query& g, float* const* out,
                              bool sum, bool add, tile_range range) {
  TACMAP_ASSERT(g.dimension == f.dimension(), "quantized_distances: dimensions differ");
  // Three descriptors per pass over the tiles (the default's all-pairs M = 3; a touch and its
  // inversion are 2): each row loaded once serves all of them.
  for (Eigen::Index j = 0; j < g.count();) {
    const bool a = add || (sum && j > 0);  // later descriptors add to the first ones' sums
    switch (std::min<Eigen::Index>(g.count() - j, 3)) {
      case 3:
        quantized_kernel::tiles<3, A>(f, g, j, out, sum, a, range);
        j += 3;
        break;
      case 2:
        quantized_kernel::tiles<2, A>(f, g, j, out, sum, a, range);
        j += 2;
        break;
      default:
        quantized_kernel::tiles<1, A>(f, g, j, out, sum, a, range);
        j += 1;
        break;
    }
  }
}

/// `quantized_distances_simd` on the compile-time architecture, or (with tacmap::precompiled)
/// on the CPU's best level.
inline void quantized_distances(const quantized_tiles& f, const quantized_query& g,
                                float* const* out, bool sum, bool add, tile_range range = {}) {
#if defined(TACMAP_PRECOMPILED) && TACMAP_PRECOMPILED
  active_kernels().quantized_distances(f, g, out, sum, add, range);
#else
  quantized_distances_simd<kernel_arch<float>>(f, g, out, sum, add, range);
#endif
}

}  // namespace tacmap::detail
