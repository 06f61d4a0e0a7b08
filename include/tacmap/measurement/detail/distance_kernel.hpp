// tacmap: the per-touch hot loop of `descriptor_likelihood`, hand-vectorised with xsimd.
//
//   out(q) += sum over the given tactile descriptors g_n of || F(q) - g_n ||
//
// for every position q. Descriptors are stored in tiles of one SIMD width of positions, element
// by element ("array of structures of arrays"): a tile is `dimension` registers, read front to
// back, so one register holds element k of several positions, no horizontal sums are needed and
// the memory is streamed sequentially. Squared distances are taken as ||F||^2 + ||g||^2 - 2 F.g
// (one FMA per element; the tiles keep ||F||^2), and recomputed from differences wherever that
// expansion would cancel (near a match, d -> 0: a touch against its own window), so that an
// exact match still gives exactly 0.
//
// Instruction sets: each kernel is a template on an xsimd architecture A (`*_simd<A>`). The
// entry points without the suffix use `kernel_arch<T>` (the compile-time default) header-only;
// with tacmap::precompiled (TACMAP_PRECOMPILED) their float versions call the kernels compiled
// for the CPU's best level instead (tacmap/simd.hpp). A tile row is 32 bytes for every A, so one
// layout serves every level: an SSE2 register reads half a row.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <type_traits>
#include <utility>
#include <vector>
#include <xsimd/xsimd.hpp>

#include "tacmap/config.hpp"
#include "tacmap/detail/huge_pages.hpp"
#include "tacmap/image.hpp"
#include "tacmap/simd.hpp"

namespace tacmap::detail {

/// xsimd's 64-byte aligned allocator, except that a value-less construct leaves the element
/// default-initialised (a float: not written). Tiles about to be written in full are then not
/// zero-filled first: the per-window features of a 120 px map are 12.5 MB, and the fill took
/// 15 % of preparing them (issue 14).
template <class T>
struct overwrite_allocator : xsimd::aligned_allocator<T, 64> {
  template <class U>
  struct rebind {
    using other = overwrite_allocator<U>;
  };
  overwrite_allocator() noexcept = default;
  template <class U>
  explicit overwrite_allocator(const overwrite_allocator<U>& /*other*/) noexcept {}
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

/// Descriptors of `positions` positions, tiled for `accumulate_distances`.
template <class T>
class descriptor_tiles {
 public:
  /// Positions per tile: one 32-byte row per element (8 floats, 4 doubles) whatever the
  /// instruction set, so tiles built in one translation unit suit the kernels of every level.
  static constexpr auto width = static_cast<Eigen::Index>(tile_row_bytes / sizeof(T));

  descriptor_tiles() = default;
  /// From descriptors as columns (dimension x positions).
  template <class Derived>
  explicit descriptor_tiles(const Eigen::DenseBase<Derived>& columns)
      : positions_(columns.cols()), dim_(columns.rows()) {
    allocate_for_overwrite();
    set_columns(0, columns.template cast<T>());
  }
  /// Zero descriptors.
  descriptor_tiles(Eigen::Index positions, Eigen::Index dimension)
      : positions_(positions), dim_(dimension) {
    const Eigen::Index tiles = (positions_ + width - 1) / width;
    data_.assign(static_cast<std::size_t>(tiles * dim_ * width), T(0));
    norms_.assign(static_cast<std::size_t>(tiles * width), T(0));
  }
  struct for_overwrite_t {};
  static constexpr for_overwrite_t for_overwrite{};
  /// Descriptors left unspecified, for a caller that sets every position before reading any
  /// (the padding past the last position is zero, as always): no pass that zeroes them first.
  descriptor_tiles(Eigen::Index positions, Eigen::Index dimension, for_overwrite_t /*tag*/)
      : positions_(positions), dim_(dimension) {
    allocate_for_overwrite();
  }
  /// Stores the descriptor of position q.
  template <class Derived>
  void set(Eigen::Index q, const Eigen::DenseBase<Derived>& descriptor) {
    T* tile = data_.data() + (q / width) * dim_ * width + q % width;
    T norm = 0;
    for (Eigen::Index k = 0; k < dim_; ++k) {
      tile[k * width] = static_cast<T>(descriptor(k));
      norm += tile[k * width] * tile[k * width];
    }
    norms_[static_cast<std::size_t>(q)] = norm;
  }
  /// Stores the descriptors `columns` (dimension x n) at positions q0 .. q0 + n - 1: `set` for
  /// each (the norms summed in another order, equal to rounding). Whole tiles are written by
  /// transposing register-sized blocks (Eigen's packet transposes), the norms vectorised:
  /// preparing a map's per-window features writes 3 million elements (classic_sift, 120 px),
  /// where `set` one by one took 3 ms (issue 14). `set_columns_scalar` is the reference.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wignored-attributes"  // Eigen's packet types as arguments
  void set_columns(Eigen::Index q0,
                   const Eigen::Ref<const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>, 0,
                                    Eigen::OuterStride<>>& columns) {
    using packet = typename Eigen::internal::packet_traits<T>::type;
    constexpr Eigen::Index size = Eigen::internal::unpacket_traits<packet>::size;
    const Eigen::Index n = columns.cols();
    const Eigen::Array<T, 1, Eigen::Dynamic> norms = columns.square().colwise().sum();
    std::copy(norms.data(), norms.data() + n, norms_.begin() + q0);
    Eigen::Index j = 0;
    if constexpr (size > 1 && width % size == 0) {
      if (dim_ % size == 0) {
        for (; j < n && (q0 + j) % width != 0; ++j) store(q0 + j, columns.col(j));
        for (; j + width <= n; j += width) {
          T* tile = data_.data() + ((q0 + j) / width) * dim_ * width;
          for (Eigen::Index k = 0; k < dim_; k += size)
            for (Eigen::Index g = 0; g < width; g += size) {
              Eigen::internal::PacketBlock<packet, static_cast<int>(size)> block;
              for (Eigen::Index i = 0; i < size; ++i)
                block.packet[i] = Eigen::internal::ploadu<packet>(
                    columns.data() + (j + g + i) * columns.outerStride() + k);
              Eigen::internal::ptranspose(block);
              for (Eigen::Index i = 0; i < size; ++i)
                Eigen::internal::pstoreu(tile + (k + i) * width + g, block.packet[i]);
            }
        }
      }
    }
    for (; j < n; ++j) store(q0 + j, columns.col(j));
  }
#pragma GCC diagnostic pop
  /// `set_columns` one position and element at a time (the tests' reference).
  void set_columns_scalar(Eigen::Index q0,
                          const Eigen::Ref<const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>, 0,
                                           Eigen::OuterStride<>>& columns) {
    for (Eigen::Index j = 0; j < columns.cols(); ++j) set(q0 + j, columns.col(j));
  }
  /// Element k of position q.
  [[nodiscard]] T at(Eigen::Index q, Eigen::Index k) const {
    return data_[static_cast<std::size_t>((q / width) * dim_ * width + k * width + q % width)];
  }
  [[nodiscard]] Eigen::Index positions() const { return positions_; }
  [[nodiscard]] Eigen::Index dimension() const { return dim_; }
  [[nodiscard]] const T* tile(Eigen::Index t) const { return data_.data() + t * dim_ * width; }
  /// Squared norms ||F(q)||^2 from position q on (padding 0; tile-aligned for q a multiple of a
  /// register's width).
  [[nodiscard]] const T* squared_norms_from(Eigen::Index q) const { return norms_.data() + q; }

 private:
  // Storage for every tile, unspecified but for the last tile's lanes past the last position
  // (zero: the kernels read whole tiles) and the norms (zero).
  void allocate_for_overwrite() {
    const Eigen::Index tiles = (positions_ + width - 1) / width;
    data_.resize(static_cast<std::size_t>(tiles * dim_ * width));
    // Not yet touched (overwrite_allocator): huge pages before the first write. A map's dense
    // field at 640 x 480 px is 157 MB of tiles; in 4 KB pages their faults cost more than
    // writing them (perf of the 36-heading build: a third of it in the kernel's page faults).
    advise_huge_pages(data_.data(), data_.size() * sizeof(T));
    norms_.assign(static_cast<std::size_t>(tiles * width), T(0));
    const Eigen::Index used = positions_ - (tiles - 1) * width;  // lanes of the last tile
    if (tiles > 0 && used < width)
      for (Eigen::Index k = 0; k < dim_; ++k)
        std::fill_n(data_.data() + ((tiles - 1) * dim_ + k) * width + used, width - used, T(0));
  }

  // Position q's elements, without its norm (set_columns computes the norms together).
  template <class Column>
  void store(Eigen::Index q, const Column& column) {
    T* lane = data_.data() + (q / width) * dim_ * width + q % width;
    for (Eigen::Index k = 0; k < dim_; ++k) lane[k * width] = column(k);
  }

  Eigen::Index positions_ = 0;
  Eigen::Index dim_ = 0;
  // 64-byte aligned whatever the flags of the translation unit that builds them: the kernels of
  // any level load their registers aligned.
  std::vector<T, overwrite_allocator<T>> data_;
  std::vector<T, xsimd::aligned_allocator<T, 64>> norms_;
};

/// Plain reference: out(q) (+)= sum_{n in [first, first+count)} || F(q) - g.col(n) ||.
template <class T>
void accumulate_distances_scalar(const descriptor_tiles<T>& f,
                                 const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& g,
                                 Eigen::Index first, Eigen::Index count, T* out, bool add = true) {
  for (Eigen::Index q = 0; q < f.positions(); ++q) {
    if (!add) out[q] = T(0);
    for (Eigen::Index n = first; n < first + count; ++n) {
      T sum = 0;
      for (Eigen::Index k = 0; k < f.dimension(); ++k) {
        const T d = f.at(q, k) - g(k, n);
        sum += d * d;
      }
      out[q] += std::sqrt(sum);
    }
  }
}

/// Tiles [begin, end) of a `descriptor_tiles` (end < 0: to the last tile).
struct tile_range {
  Eigen::Index begin = 0;
  Eigen::Index end = -1;
};

namespace distance_kernel {

// Registers of architecture A: "register tile" r holds positions [r * width, (r + 1) * width),
// a whole tile or part of one (an SSE2 register is half a 32-byte tile row).
template <class A, class T>
constexpr Eigen::Index register_width() {
  constexpr auto w = static_cast<Eigen::Index>(xsimd::batch<T, A>::size);
  static_assert(descriptor_tiles<T>::width % w == 0, "a tile row must hold whole registers");
  return w;
}

// Element 0 of register tile r; element k is descriptor_tiles<T>::width values further on.
template <class A, class T>
const T* register_tile(const descriptor_tiles<T>& f, Eigen::Index r) {
  constexpr Eigen::Index row = descriptor_tiles<T>::width;
  const Eigen::Index first = r * register_width<A, T>();
  return f.tile(first / row) + first % row;
}

// Register tiles covering f's positions.
template <class A, class T>
Eigen::Index register_tiles(const descriptor_tiles<T>& f) {
  constexpr Eigen::Index width = register_width<A, T>();
  return (f.positions() + width - 1) / width;
}

// Writes (or, when `add`, adds) one register tile's values at out[first, first + width); the
// last, partial tile writes only the real positions.
template <class A, class T>
void store_tile(const xsimd::batch<T, A>& v, T* out, Eigen::Index first, Eigen::Index positions,
                bool add) {
  using batch = xsimd::batch<T, A>;
  constexpr Eigen::Index width = register_width<A, T>();
  T* o = out + first;
  if (first + width <= positions) {
    (add ? batch::load_unaligned(o) + v : v).store_unaligned(o);
  } else {
    alignas(64) T lanes[static_cast<std::size_t>(width)];
    v.store_aligned(lanes);
    const Eigen::Index real = std::min(width, positions - first);
    for (Eigen::Index l = 0; l < real; ++l) o[l] = (add ? o[l] : T(0)) + lanes[l];
  }
}

// ||F - g||^2 for one tile from the accumulated F.g (`dot`), ||F||^2 (`nf`) and ||g||^2 (`ng`):
// the expansion ||F||^2 + ||g||^2 - 2 F.g, or, where a lane lands below 1/64 of
// ||F||^2 + ||g||^2 (a near match, where the expansion cancels), recomputed from differences
// over the tile's elements `ti` against g_k(k) (element k of g, broadcast). Clamped at 0.
template <class A, class T, class G>
xsimd::batch<T, A> squared_distance(const xsimd::batch<T, A>& dot, const xsimd::batch<T, A>& nf,
                                    T ng, const T* ti, Eigen::Index dim, const G& g_k) {
  using batch = xsimd::batch<T, A>;
  constexpr Eigen::Index row = descriptor_tiles<T>::width;
  const batch both = nf + batch(ng);
  batch d2 = xsimd::fnma(batch(T(2)), dot, both);
  if (xsimd::any(d2 < both * batch(T(1) / T(64)))) {
    d2 = batch(T(0));
    for (Eigen::Index k = 0; k < dim; ++k) {
      const batch d = batch::load_aligned(ti + k * row) - g_k(k);
      d2 = xsimd::fma(d, d, d2);
    }
  }
  return xsimd::max(d2, batch(T(0)));
}

// Tiles consecutive tiles times Count tactile descriptors at once. Why blocks of tiles: each
// accumulator is a chain of `dimension` dependent FMAs (latency ~4-5 cycles), so one tile with
// three descriptors is latency-bound at a third of the FMA units' throughput; interleaving tiles
// gives the core 8-9 independent chains. `gb` holds the tactile descriptors pre-broadcast (one
// full register per element, descriptor-major), so the products read them straight from L1
// instead of re-broadcasting a scalar per tile and element; `gn` their squared norms.
//
// ||F - g||^2 = ||F||^2 + ||g||^2 - 2 F.g: one FMA per element instead of a subtraction and
// an FMA (measured: the whole shared-dense measurement 9 % faster, per window 10 %); near a
// match `squared_distance` recomputes from differences (rare; elsewhere the relative error of
// the distance stays below ~1e-5), so an exact match is 0.
template <std::size_t Tiles, std::size_t Count, class A, class T>
void block(const descriptor_tiles<T>& f, Eigen::Index t0, const xsimd::batch<T, A>* gb, const T* gn,
           T* out, bool add, Eigen::Index origin) {
  using batch = xsimd::batch<T, A>;
  constexpr Eigen::Index width = register_width<A, T>();
  constexpr Eigen::Index row = descriptor_tiles<T>::width;
  const Eigen::Index dim = f.dimension();
  batch acc[Tiles][Count];
  const T* tile[Tiles];
  for (std::size_t i = 0; i < Tiles; ++i) {
    tile[i] = register_tile<A>(f, t0 + static_cast<Eigen::Index>(i));
    for (std::size_t j = 0; j < Count; ++j) acc[i][j] = batch(T(0));
  }
  for (Eigen::Index k = 0; k < dim; ++k) {
    for (std::size_t i = 0; i < Tiles; ++i) {
      const batch v = batch::load_aligned(tile[i] + k * row);
      for (std::size_t j = 0; j < Count; ++j)
        acc[i][j] = xsimd::fma(v, gb[static_cast<Eigen::Index>(j) * dim + k], acc[i][j]);
    }
  }
  for (std::size_t i = 0; i < Tiles; ++i) {
    const Eigen::Index first = (t0 + static_cast<Eigen::Index>(i)) * width;
    const batch nf = batch::load_aligned(f.squared_norms_from(first));
    batch total(T(0));
    for (std::size_t j = 0; j < Count; ++j) {
      const batch* gj = gb + static_cast<Eigen::Index>(j) * dim;
      total += xsimd::sqrt(squared_distance(acc[i][j], nf, gn[j], tile[i], dim,
                                            [gj](Eigen::Index k) { return gj[k]; }));
    }
    store_tile(total, out, first - origin, f.positions() - origin, add);
  }
}

// All tiles against Count descriptors: blocks of about 8-9 independent accumulator chains, then
// the remaining tiles one by one.
template <class A, class T>
using batch_vector =
    std::vector<xsimd::batch<T, A>, xsimd::aligned_allocator<xsimd::batch<T, A>, 64>>;

template <std::size_t Count, class A, class T>
void tiles(const descriptor_tiles<T>& f, const T* g, Eigen::Index g_stride, batch_vector<A, T>& gb,
           T* out, bool add, tile_range range) {
  using batch = xsimd::batch<T, A>;
  constexpr std::size_t per_block = Count >= 3 ? 3 : (Count == 2 ? 4 : 8);
  const Eigen::Index dim = f.dimension();
  constexpr auto n = static_cast<Eigen::Index>(Count);
  gb.resize(static_cast<std::size_t>(n * dim));
  T gn[Count];
  for (Eigen::Index j = 0; j < n; ++j) {
    T& norm = gn[static_cast<std::size_t>(j)];
    norm = T(0);
    for (Eigen::Index k = 0; k < dim; ++k) {
      const T v = g[j * g_stride + k];
      gb[static_cast<std::size_t>(j * dim + k)] = batch(v);
      norm += v * v;
    }
  }
  // `range` counts whole tiles, the kernels registers (`per` to a tile); outputs relative to
  // the range's first position. Each register's lanes are computed alike wherever the range
  // starts, so a range's values equal the whole pass's bit for bit (the tracking mode).
  constexpr Eigen::Index per = descriptor_tiles<T>::width / register_width<A, T>();
  const Eigen::Index all = register_tiles<A>(f);
  const Eigen::Index count = range.end < 0 ? all : std::min(range.end * per, all);
  const Eigen::Index origin = range.begin * descriptor_tiles<T>::width;
  Eigen::Index t = range.begin * per;
  constexpr auto step = static_cast<Eigen::Index>(per_block);
  for (; t + step <= count; t += step)
    block<per_block, Count>(f, t, gb.data(), gn, out, add, origin);
  for (; t < count; ++t) block<1, Count>(f, t, gb.data(), gn, out, add, origin);
}

}  // namespace distance_kernel

/// out(q) (+)= sum_{n in [first, first+count)} || F(q) - g.col(n) || for every position q: added
/// to out when `add`, else stored (saves clearing a buffer that is about to be overwritten).
/// Architecture A's kernel; `accumulate_distances` chooses A.
template <class A, class T>
void accumulate_distances_tiles_simd(const descriptor_tiles<T>& f,
                                     const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& g,
                                     Eigen::Index first, Eigen::Index count, T* out, bool add,
                                     tile_range range) {
  const Eigen::Index stride = g.rows();
  // Pre-broadcast tactile descriptors; a few KB, allocated per call (negligible next to the
  // pass over the map's descriptors).
  distance_kernel::batch_vector<A, T> gb;
  for (Eigen::Index n = first; n < first + count;) {
    const T* gn = g.data() + n * stride;
    switch (std::min<Eigen::Index>(first + count - n, 3)) {
      case 3:
        distance_kernel::tiles<3>(f, gn, stride, gb, out, add, range);
        n += 3;
        break;
      case 2:
        distance_kernel::tiles<2>(f, gn, stride, gb, out, add, range);
        n += 2;
        break;
      default:
        distance_kernel::tiles<1>(f, gn, stride, gb, out, add, range);
        n += 1;
        break;
    }
    add = true;  // later descriptors add to the first ones' sums
  }
}

/// Every position: `accumulate_distances_tiles_simd` on all tiles.
template <class A, class T>
void accumulate_distances_simd(const descriptor_tiles<T>& f,
                               const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& g,
                               Eigen::Index first, Eigen::Index count, T* out, bool add = true) {
  accumulate_distances_tiles_simd<A>(f, g, first, count, out, add, tile_range{});
}

/// `accumulate_distances_simd` on the compile-time architecture, or (float, with
/// tacmap::precompiled) on the CPU's best level.
template <class T>
void accumulate_distances(const descriptor_tiles<T>& f,
                          const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& g,
                          Eigen::Index first, Eigen::Index count, T* out, bool add = true) {
#if defined(TACMAP_PRECOMPILED) && TACMAP_PRECOMPILED
  if constexpr (std::is_same_v<T, float>) {
    active_kernels().accumulate_distances(f, g, first, count, out, add);
    return;
  }
#endif
  accumulate_distances_simd<kernel_arch<T>>(f, g, first, count, out, add);
}

/// `accumulate_distances` on the positions of the tiles `range` only, written relative to its
/// first position (out[q - range.begin * width]): the whole pass's values there, bit for bit.
template <class T>
void accumulate_distances_tiles(const descriptor_tiles<T>& f,
                                const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& g,
                                Eigen::Index first, Eigen::Index count, T* out, bool add,
                                tile_range range) {
#if defined(TACMAP_PRECOMPILED) && TACMAP_PRECOMPILED
  if constexpr (std::is_same_v<T, float>) {
    active_kernels().accumulate_distances_tiles(f, g, first, count, out, add, range);
    return;
  }
#endif
  accumulate_distances_tiles_simd<kernel_arch<T>>(f, g, first, count, out, add, range);
}

namespace distance_kernel {

// Tiles consecutive tiles against one descriptor g in a sum/difference basis (elements [0, half):
// sums S, [half, dim): differences D, see `accumulate_sign_pair`): two accumulators per tile,
// F_S.g_S and F_D.g_D, give both F.g = S + D and F.g^- = S - D for g^- = (g_S, -g_D). Four tiles
// keep eight independent FMA chains in flight, like `block`.
// Outputs are written relative to position `origin` (a tile range's first position).
template <std::size_t Tiles, class A, class T>
void pair_block(const descriptor_tiles<T>& f, Eigen::Index t0, const xsimd::batch<T, A>* gb, T gn,
                Eigen::Index half, T* plus, T* minus, bool add, Eigen::Index origin) {
  using batch = xsimd::batch<T, A>;
  constexpr Eigen::Index width = register_width<A, T>();
  constexpr Eigen::Index row = descriptor_tiles<T>::width;
  const Eigen::Index dim = f.dimension();
  batch sum[Tiles], diff[Tiles];
  const T* tile[Tiles];
  for (std::size_t i = 0; i < Tiles; ++i) {
    sum[i] = diff[i] = batch(T(0));
    tile[i] = register_tile<A>(f, t0 + static_cast<Eigen::Index>(i));
  }
  for (Eigen::Index k = 0; k < half; ++k)
    for (std::size_t i = 0; i < Tiles; ++i)
      sum[i] = xsimd::fma(batch::load_aligned(tile[i] + k * row), gb[k], sum[i]);
  for (Eigen::Index k = half; k < dim; ++k)
    for (std::size_t i = 0; i < Tiles; ++i)
      diff[i] = xsimd::fma(batch::load_aligned(tile[i] + k * row), gb[k], diff[i]);
  for (std::size_t i = 0; i < Tiles; ++i) {
    const Eigen::Index t = t0 + static_cast<Eigen::Index>(i);
    const batch nf = batch::load_aligned(f.squared_norms_from(t * width));
    const T* ti = tile[i];
    const batch p = xsimd::sqrt(squared_distance(sum[i] + diff[i], nf, gn, ti, dim,
                                                 [gb](Eigen::Index k) { return gb[k]; }));
    const batch m =
        xsimd::sqrt(squared_distance(sum[i] - diff[i], nf, gn, ti, dim, [gb, half](Eigen::Index k) {
          return k < half ? gb[k] : -gb[k];
        }));
    store_tile(p, plus, t * width - origin, f.positions() - origin, add);
    store_tile(m, minus, t * width - origin, f.positions() - origin, add);
  }
}

}  // namespace distance_kernel

/// Both contrast signs in one pass. For descriptors stored in the sum/difference basis of a
/// contrast permutation P (an involution: first `half` elements (f_k + f_P(k)) / sqrt 2 over the
/// pairs k < P(k), then the differences (f_k - f_P(k)) / sqrt 2; `contrast_basis` builds it),
/// the permuted descriptor Pg is g with its differences negated. So
///   plus(q)  (+)= || F(q) - g ||       and       minus(q) (+)= || F(q) - P g ||
/// share every product: F.g = F_S.g_S + F_D.g_D, F.Pg = F_S.g_S - F_D.g_D — two distances for
/// the multiply-adds of one. `g`: one descriptor in that basis (f.dimension() values). Added to
/// the outputs when `add`, else stored. Architecture A's kernel; `accumulate_sign_pair`
/// chooses A.
template <class A, class T>
void accumulate_sign_pair_tiles_simd(const descriptor_tiles<T>& f, const T* g, Eigen::Index half,
                                     T* plus, T* minus, bool add, tile_range tiles) {
  using batch = xsimd::batch<T, A>;
  const Eigen::Index dim = f.dimension();
  TACMAP_ASSERT(half >= 0 && half <= dim, "accumulate_sign_pair: half out of range");
  distance_kernel::batch_vector<A, T> gb(static_cast<std::size_t>(dim));
  T gn = 0;
  for (Eigen::Index k = 0; k < dim; ++k) {
    gb[static_cast<std::size_t>(k)] = batch(g[k]);
    gn += g[k] * g[k];
  }
  // `tiles` counts whole tiles (rows of descriptor_tiles<T>::width); the kernels count
  // registers, `per` to a tile. Every register is computed the same way whatever the range
  // (its lanes' sums do not depend on their neighbours), so a range's values are bit for bit
  // those of the whole pass: what the filter's tracking mode relies on.
  constexpr Eigen::Index per = descriptor_tiles<T>::width / distance_kernel::register_width<A, T>();
  const Eigen::Index all = distance_kernel::register_tiles<A>(f);
  const Eigen::Index count = tiles.end < 0 ? all : std::min(tiles.end * per, all);
  const Eigen::Index origin = tiles.begin * descriptor_tiles<T>::width;
  Eigen::Index t = tiles.begin * per;
  for (; t + 4 <= count; t += 4)
    distance_kernel::pair_block<4>(f, t, gb.data(), gn, half, plus, minus, add, origin);
  for (; t < count; ++t)
    distance_kernel::pair_block<1>(f, t, gb.data(), gn, half, plus, minus, add, origin);
}

/// Both signs over every position: `accumulate_sign_pair_tiles_simd` on all tiles.
template <class A, class T>
void accumulate_sign_pair_simd(const descriptor_tiles<T>& f, const T* g, Eigen::Index half, T* plus,
                               T* minus, bool add) {
  accumulate_sign_pair_tiles_simd<A>(f, g, half, plus, minus, add, tile_range{});
}

/// `accumulate_sign_pair_simd` on the compile-time architecture, or (float, with
/// tacmap::precompiled) on the CPU's best level.
template <class T>
void accumulate_sign_pair(const descriptor_tiles<T>& f, const T* g, Eigen::Index half, T* plus,
                          T* minus, bool add) {
#if defined(TACMAP_PRECOMPILED) && TACMAP_PRECOMPILED
  if constexpr (std::is_same_v<T, float>) {
    active_kernels().accumulate_sign_pair(f, g, half, plus, minus, add);
    return;
  }
#endif
  accumulate_sign_pair_simd<kernel_arch<T>>(f, g, half, plus, minus, add);
}

/// `accumulate_sign_pair` on the positions of `tiles` only, written relative to the first of
/// them (plus[q - tiles.begin * width]): the same values as the whole pass there, bit for bit.
template <class T>
void accumulate_sign_pair_tiles(const descriptor_tiles<T>& f, const T* g, Eigen::Index half,
                                T* plus, T* minus, bool add, tile_range tiles) {
#if defined(TACMAP_PRECOMPILED) && TACMAP_PRECOMPILED
  if constexpr (std::is_same_v<T, float>) {
    active_kernels().accumulate_sign_pair_tiles(f, g, half, plus, minus, add, tiles);
    return;
  }
#endif
  accumulate_sign_pair_tiles_simd<kernel_arch<T>>(f, g, half, plus, minus, add, tiles);
}

/// Plain reference of `accumulate_sign_pair`.
template <class T>
void accumulate_sign_pair_scalar(const descriptor_tiles<T>& f, const T* g, Eigen::Index half,
                                 T* plus, T* minus, bool add) {
  for (Eigen::Index q = 0; q < f.positions(); ++q) {
    double p2 = 0.0, m2 = 0.0;
    for (Eigen::Index k = 0; k < f.dimension(); ++k) {
      const double fk = static_cast<double>(f.at(q, k));
      const double gk = static_cast<double>(g[k]);
      p2 += (fk - gk) * (fk - gk);
      const double gm = k < half ? gk : -gk;
      m2 += (fk - gm) * (fk - gm);
    }
    plus[q] = (add ? plus[q] : T(0)) + static_cast<T>(std::sqrt(p2));
    minus[q] = (add ? minus[q] : T(0)) + static_cast<T>(std::sqrt(m2));
  }
}

/// The orthonormal sum/difference basis of a contrast permutation `perm` (an involution without
/// fixed points over [0, dim)): `apply(in, out)` writes (in_k + in_P(k)) / sqrt 2 for the pairs
/// k < P(k) in order, then (in_k - in_P(k)) / sqrt 2. Euclidean distances are unchanged by it;
/// the permutation becomes a sign flip of the second half.
class contrast_basis {
 public:
  contrast_basis() = default;
  explicit contrast_basis(const std::vector<Eigen::Index>& perm) {
    const auto dim = static_cast<Eigen::Index>(perm.size());
    for (Eigen::Index k = 0; k < dim; ++k) {
      const Eigen::Index p = perm[static_cast<std::size_t>(k)];
      if (p < 0 || p >= dim || p == k || perm[static_cast<std::size_t>(p)] != k)
        fail("contrast_basis: element ", k, " maps to ", p,
             "; expected an involution without fixed points over [0, ", dim,
             ") (the descriptor's contrast_permutation())");
      if (k < p) pairs_.push_back({k, p});
    }
  }
  [[nodiscard]] Eigen::Index dimension() const { return 2 * half(); }
  /// Number of sums (= number of differences).
  [[nodiscard]] Eigen::Index half() const { return static_cast<Eigen::Index>(pairs_.size()); }
  template <class In, class Out>
  void apply(const In& in, Out&& out) const {
    const double r = 1.0 / std::sqrt(2.0);
    const Eigen::Index h = half();
    for (Eigen::Index i = 0; i < h; ++i) {
      const auto [a, b] = pairs_[static_cast<std::size_t>(i)];
      const double x = static_cast<double>(in(a)), y = static_cast<double>(in(b));
      out(i) = static_cast<std::remove_cvref_t<decltype(out(i))>>((x + y) * r);
      out(h + i) = static_cast<std::remove_cvref_t<decltype(out(i))>>((x - y) * r);
    }
  }

 private:
  std::vector<std::pair<Eigen::Index, Eigen::Index>> pairs_;
};

/// A half-open range of positions [begin, end).
struct position_range {
  Eigen::Index begin = 0;
  Eigen::Index end = 0;
};

/// Plain reference of `distances_each`.
template <class T>
void distances_each_scalar(const descriptor_tiles<T>& f,
                           const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& g, T* out,
                           Eigen::Index out_stride) {
  for (Eigen::Index j = 0; j < g.cols(); ++j)
    for (Eigen::Index q = 0; q < f.positions(); ++q) {
      T sum = 0;
      for (Eigen::Index k = 0; k < f.dimension(); ++k) {
        const T d = f.at(q, k) - g(k, j);
        sum += d * d;
      }
      out[j * out_stride + q] = std::sqrt(sum);
    }
}

namespace distance_kernel {

// Tiles x Count accumulators as in `block` (the same expansion, the same fallback from
// differences near a match), but each descriptor's distances go to their own output column
// (stored, not summed), and the descriptors are broadcast on the fly (108 of them do not fit L1
// pre-broadcast); `gn` their squared norms. `Sum`: the Count distances are summed in registers
// into ONE column instead (stored, or added when `add`): a group of descriptors whose caller
// only wants their sum (all pairs of one heading) never writes the single distances. It stays
// a second loop: one shared function filling the accumulators through a reference measured
// 51 -> 75 us (planar) and 2.1 -> 3.2 ms (36 headings).
template <std::size_t Tiles, std::size_t Count, bool Sum, class A, class T>
void block_each(const descriptor_tiles<T>& f, Eigen::Index t0, const T* g, Eigen::Index g_stride,
                const T* gn, T* out, Eigen::Index out_stride, Eigen::Index origin,
                bool add = false) {
  using batch = xsimd::batch<T, A>;
  constexpr Eigen::Index width = register_width<A, T>();
  constexpr Eigen::Index row = descriptor_tiles<T>::width;
  const Eigen::Index dim = f.dimension();
  batch acc[Tiles][Count];
  const T* tile[Tiles];
  for (std::size_t i = 0; i < Tiles; ++i) {
    tile[i] = register_tile<A>(f, t0 + static_cast<Eigen::Index>(i));
    for (std::size_t j = 0; j < Count; ++j) acc[i][j] = batch(T(0));
  }
  for (Eigen::Index k = 0; k < dim; ++k) {
    batch gk[Count];
    for (std::size_t j = 0; j < Count; ++j)
      gk[j] = batch(g[static_cast<Eigen::Index>(j) * g_stride + k]);
    for (std::size_t i = 0; i < Tiles; ++i) {
      const batch v = batch::load_aligned(tile[i] + k * row);
      for (std::size_t j = 0; j < Count; ++j) acc[i][j] = xsimd::fma(v, gk[j], acc[i][j]);
    }
  }
  for (std::size_t i = 0; i < Tiles; ++i) {
    const Eigen::Index first = (t0 + static_cast<Eigen::Index>(i)) * width;
    const batch nf = batch::load_aligned(f.squared_norms_from(first));
    const T* ti = tile[i];
    batch total(T(0));
    for (std::size_t j = 0; j < Count; ++j) {
      const T* gj = g + static_cast<Eigen::Index>(j) * g_stride;
      const batch d = xsimd::sqrt(squared_distance(acc[i][j], nf, gn[j], ti, dim,
                                                   [gj](Eigen::Index k) { return batch(gj[k]); }));
      if constexpr (Sum)
        total += d;
      else
        store_tile(d, out + static_cast<Eigen::Index>(j) * out_stride, first - origin,
                   f.positions() - origin, false);
    }
    if constexpr (Sum) store_tile(total, out, first - origin, f.positions() - origin, add);
  }
}

// True when descriptors [j, j + n) need any position of tiles [t0, t0 + tiles).
inline bool needed(const position_range* ranges, Eigen::Index j, Eigen::Index n, Eigen::Index t0,
                   Eigen::Index tiles, Eigen::Index width) {
  if (ranges == nullptr) return true;
  const Eigen::Index lo = t0 * width;
  const Eigen::Index hi = (t0 + tiles) * width;
  for (Eigen::Index i = j; i < j + n; ++i)
    if (ranges[i].begin < hi && ranges[i].end > lo) return true;
  return false;
}

template <std::size_t Tiles, class A, class T>
void each_descriptor(const descriptor_tiles<T>& f, Eigen::Index t0,
                     const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& g, const T* gn, T* out,
                     Eigen::Index out_stride, const position_range* ranges, Eigen::Index origin) {
  constexpr Eigen::Index width = register_width<A, T>();
  constexpr auto tiles = static_cast<Eigen::Index>(Tiles);
  const Eigen::Index stride = g.rows();
  const Eigen::Index count = g.cols();
  const T* gj = g.data();
  const T* nj = gn;
  T* oj = out;
  Eigen::Index j = 0;
  for (; j + 3 <= count; j += 3, gj += 3 * stride, nj += 3, oj += 3 * out_stride)
    if (needed(ranges, j, 3, t0, tiles, width))
      block_each<Tiles, 3, false, A>(f, t0, gj, stride, nj, oj, out_stride, origin);
  for (; j < count; ++j, gj += stride, ++nj, oj += out_stride)
    if (needed(ranges, j, 1, t0, tiles, width))
      block_each<Tiles, 1, false, A>(f, t0, gj, stride, nj, oj, out_stride, origin);
}

// Groups of `group` consecutive descriptors, each group's distances summed into one column.
template <std::size_t Tiles, class A, class T>
void each_group(const descriptor_tiles<T>& f, Eigen::Index t0,
                const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& g, const T* gn,
                Eigen::Index group, T* out, Eigen::Index out_stride, const position_range* ranges,
                Eigen::Index origin) {
  constexpr Eigen::Index width = register_width<A, T>();
  constexpr auto tiles = static_cast<Eigen::Index>(Tiles);
  const Eigen::Index stride = g.rows();
  const Eigen::Index groups = g.cols() / group;
  for (Eigen::Index c = 0; c < groups; ++c) {
    const Eigen::Index j0 = c * group;
    if (!needed(ranges, j0, group, t0, tiles, width)) continue;
    T* oc = out + c * out_stride;
    Eigen::Index j = j0;
    for (; j + 3 <= j0 + group; j += 3)
      block_each<Tiles, 3, true, A>(f, t0, g.data() + j * stride, stride, gn + j, oc, out_stride,
                                    origin, j > j0);
    for (; j < j0 + group; ++j)
      block_each<Tiles, 1, true, A>(f, t0, g.data() + j * stride, stride, gn + j, oc, out_stride,
                                    origin, j > j0);
  }
}

}  // namespace distance_kernel

/// dst[i] += src[i] for i in [0, n), and the sum of src: whole registers into `acc` (reduce it
/// once after many rows), the last n % width values returned. The pose model's per-row step
/// (a band's distances into a layer, and their sum for the off-map mean): ~10,000 rows of ~100
/// values per touch, where Eigen's add-then-sum expression cost a second pass and its reduction's
/// set-up per row.
template <class T, class A>
T add_row(const T* src, T* dst, Eigen::Index n, xsimd::batch<T, A>& acc) {
  using batch = xsimd::batch<T, A>;
  constexpr auto width = static_cast<Eigen::Index>(batch::size);
  Eigen::Index i = 0;
  for (; i + width <= n; i += width) {
    const batch v = batch::load_unaligned(src + i);
    (batch::load_unaligned(dst + i) + v).store_unaligned(dst + i);
    acc += v;
  }
  T tail = 0;
  for (; i < n; ++i) {
    dst[i] += src[i];
    tail += src[i];
  }
  return tail;
}

/// Plain reference of `add_row`: adds, and returns the whole sum.
template <class T>
T add_row_scalar(const T* src, T* dst, Eigen::Index n) {
  T sum = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    dst[i] += src[i];
    sum += src[i];
  }
  return sum;
}

/// ||g.col(j)||^2 for every column j (what `distances_each` takes with the descriptors), into
/// `out` (resized; reusable between calls).
template <class T>
void squared_norms(const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& g, std::vector<T>& out) {
  out.resize(static_cast<std::size_t>(g.cols()));
  for (Eigen::Index j = 0; j < g.cols(); ++j)
    out[static_cast<std::size_t>(j)] = g.col(j).square().sum();
}

/// out[j * out_stride + q] = || F(q) - g.col(j) || for every descriptor j and position q: many
/// tactile descriptors (e.g. 3 patches x 36 headings) against the map's field in ONE pass over
/// the field — each block of tiles stays in L1 while every descriptor visits it, so the field
/// (1.4 MB for a 120 px map) is read from memory once, not once per descriptor. `g_norms`:
/// squared_norms(g). Requires out_stride >= f.positions(). `ranges` (optional, one per
/// descriptor): only positions in ranges[j] are needed for descriptor j; whole blocks of tiles
/// outside every range of a group of descriptors are skipped (their outputs are left as they
/// were) — a turned patch near the map's edge never reads some rows of the field.
///
/// `tiles`: only the positions of these tiles, written relative to the first of them
/// (out[j * out_stride + q - tiles.begin * width], out_stride >= their positions): a band of
/// the field whose outputs stay in cache for what the caller does with them next.
///
/// `group` > 1: column c of `out` receives the SUM over descriptors [c * group, (c + 1) * group)
/// instead (g.cols() must be a multiple of group) — what the all-pairs measurement wants per
/// heading, without writing and re-reading the single distances.
///
/// Architecture A's kernel; `distances_each` chooses A.
template <class A, class T>
void distances_each_simd(const descriptor_tiles<T>& f,
                         const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& g, const T* g_norms,
                         T* out, Eigen::Index out_stride, const position_range* ranges = nullptr,
                         tile_range tiles = {}, Eigen::Index group = 1) {
  // `tiles` counts whole tiles (rows of descriptor_tiles<T>::width); the kernels count
  // registers, `per` to a tile.
  constexpr Eigen::Index per = descriptor_tiles<T>::width / distance_kernel::register_width<A, T>();
  const Eigen::Index all = distance_kernel::register_tiles<A>(f);
  const Eigen::Index count = tiles.end < 0 ? all : std::min(tiles.end * per, all);
  const Eigen::Index origin = tiles.begin * descriptor_tiles<T>::width;
  Eigen::Index t = tiles.begin * per;
  if (group > 1) {
    TACMAP_ASSERT(g.cols() % group == 0, "distances_each: descriptors not a multiple of group");
    for (; t + 3 <= count; t += 3)
      distance_kernel::each_group<3, A>(f, t, g, g_norms, group, out, out_stride, ranges, origin);
    for (; t < count; ++t)
      distance_kernel::each_group<1, A>(f, t, g, g_norms, group, out, out_stride, ranges, origin);
    return;
  }
  for (; t + 3 <= count; t += 3)
    distance_kernel::each_descriptor<3, A>(f, t, g, g_norms, out, out_stride, ranges, origin);
  for (; t < count; ++t)
    distance_kernel::each_descriptor<1, A>(f, t, g, g_norms, out, out_stride, ranges, origin);
}

/// `distances_each_simd` on the compile-time architecture, or (float, with tacmap::precompiled)
/// on the CPU's best level.
template <class T>
void distances_each(const descriptor_tiles<T>& f,
                    const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& g, const T* g_norms,
                    T* out, Eigen::Index out_stride, const position_range* ranges = nullptr,
                    tile_range tiles = {}, Eigen::Index group = 1) {
#if defined(TACMAP_PRECOMPILED) && TACMAP_PRECOMPILED
  if constexpr (std::is_same_v<T, float>) {
    active_kernels().distances_each(f, g, g_norms, out, out_stride, ranges, tiles, group);
    return;
  }
#endif
  distances_each_simd<kernel_arch<T>>(f, g, g_norms, out, out_stride, ranges, tiles, group);
}

}  // namespace tacmap::detail
