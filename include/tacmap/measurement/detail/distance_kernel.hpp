// tacmap: the per-touch hot loop of `descriptor_likelihood`, hand-vectorised with xsimd.
//
//   out(q) += sum over the given tactile descriptors g_n of || F(q) - g_n ||
//
// for every position q. Descriptors are stored in tiles of one SIMD width of positions, element
// by element ("array of structures of arrays"): a tile is `dimension` registers, read front to
// back, so one register holds element k of several positions, no horizontal sums are needed and
// the memory is streamed sequentially. Distances are summed from differences, never as
// ||F||^2 - 2 F.g + ||g||^2: that expansion cancels catastrophically in float exactly where it
// matters (a touch against its own window, d -> 0).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <vector>
#include <xsimd/xsimd.hpp>

namespace tacmap::detail {

/// Descriptors of `positions` positions, tiled for `accumulate_distances`.
template <class T>
class descriptor_tiles {
 public:
  using batch = xsimd::batch<T>;
  static constexpr auto width = static_cast<Eigen::Index>(batch::size);

  descriptor_tiles() = default;
  /// From descriptors as columns (dimension x positions).
  template <class Derived>
  explicit descriptor_tiles(const Eigen::DenseBase<Derived>& columns)
      : positions_(columns.cols()), dim_(columns.rows()) {
    const Eigen::Index tiles = (positions_ + width - 1) / width;
    data_.assign(static_cast<std::size_t>(tiles * dim_ * width), T(0));  // padding stays 0
    for (Eigen::Index q = 0; q < positions_; ++q) set(q, columns.col(q));
  }
  descriptor_tiles(Eigen::Index positions, Eigen::Index dimension)
      : positions_(positions), dim_(dimension) {
    const Eigen::Index tiles = (positions_ + width - 1) / width;
    data_.assign(static_cast<std::size_t>(tiles * dim_ * width), T(0));
  }
  /// Stores the descriptor of position q.
  template <class Derived>
  void set(Eigen::Index q, const Eigen::DenseBase<Derived>& descriptor) {
    T* tile = data_.data() + (q / width) * dim_ * width + q % width;
    for (Eigen::Index k = 0; k < dim_; ++k) tile[k * width] = static_cast<T>(descriptor(k));
  }
  /// Element k of position q.
  [[nodiscard]] T at(Eigen::Index q, Eigen::Index k) const {
    return data_[static_cast<std::size_t>((q / width) * dim_ * width + k * width + q % width)];
  }
  [[nodiscard]] Eigen::Index positions() const { return positions_; }
  [[nodiscard]] Eigen::Index dimension() const { return dim_; }
  [[nodiscard]] const T* tile(Eigen::Index t) const { return data_.data() + t * dim_ * width; }

 private:
  Eigen::Index positions_ = 0;
  Eigen::Index dim_ = 0;
  std::vector<T, xsimd::aligned_allocator<T>> data_;
};

/// Plain reference: out(q) += sum_{n in [first, first+count)} || F(q) - g.col(n) ||.
template <class T>
void accumulate_distances_scalar(const descriptor_tiles<T>& f,
                                 const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& g,
                                 Eigen::Index first, Eigen::Index count, T* out) {
  for (Eigen::Index q = 0; q < f.positions(); ++q)
    for (Eigen::Index n = first; n < first + count; ++n) {
      T sum = 0;
      for (Eigen::Index k = 0; k < f.dimension(); ++k) {
        const T d = f.at(q, k) - g(k, n);
        sum += d * d;
      }
      out[q] += std::sqrt(sum);
    }
}

namespace distance_kernel {

// Count tactile descriptors at once, their accumulators held in registers.
template <int Count, class T>
void tiles(const descriptor_tiles<T>& f, const T* g, Eigen::Index g_stride, T* out) {
  using batch = xsimd::batch<T>;
  constexpr Eigen::Index width = descriptor_tiles<T>::width;
  const Eigen::Index dim = f.dimension();
  const Eigen::Index full = f.positions() / width;
  alignas(64) T lanes[static_cast<std::size_t>(width)];
  for (Eigen::Index t = 0; t * width < f.positions(); ++t) {
    const T* tile = f.tile(t);
    batch acc[static_cast<std::size_t>(Count)];
    for (int j = 0; j < Count; ++j) acc[j] = batch(T(0));
    for (Eigen::Index k = 0; k < dim; ++k) {
      const batch v = batch::load_aligned(tile + k * width);
      for (int j = 0; j < Count; ++j) {
        const batch d = v - batch(g[j * g_stride + k]);
        acc[j] = xsimd::fma(d, d, acc[j]);
      }
    }
    batch total = xsimd::sqrt(acc[0]);
    for (int j = 1; j < Count; ++j) total += xsimd::sqrt(acc[j]);
    T* o = out + t * width;
    if (t < full) {
      (batch::load_unaligned(o) + total).store_unaligned(o);
    } else {  // the last, partial tile: only the real positions
      total.store_aligned(lanes);
      for (Eigen::Index i = 0; t * width + i < f.positions(); ++i) o[i] += lanes[i];
    }
  }
}

}  // namespace distance_kernel

template <class T>
void accumulate_distances(const descriptor_tiles<T>& f,
                          const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& g,
                          Eigen::Index first, Eigen::Index count, T* out) {
  const Eigen::Index stride = g.rows();
  for (Eigen::Index n = first; n < first + count;) {
    const T* gn = g.data() + n * stride;
    switch (std::min<Eigen::Index>(first + count - n, 3)) {
      case 3:
        distance_kernel::tiles<3>(f, gn, stride, out);
        n += 3;
        break;
      case 2:
        distance_kernel::tiles<2>(f, gn, stride, out);
        n += 2;
        break;
      default:
        distance_kernel::tiles<1>(f, gn, stride, out);
        n += 1;
        break;
    }
  }
}

}  // namespace tacmap::detail
