// tacmap: images — the map, tactile images and the belief are row-major Eigen arrays.
//
// Convention used throughout tacmap: an image has `rows()` (y, downwards) and `cols()`
// (x, to the right); element (r, c) is the pixel in row r, column c. Row-major storage makes a
// row contiguous, which is what the whole-grid kernels stream over.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "tacmap/config.hpp"

namespace tacmap {

/// Row-major dynamic image of `T` (map, tactile image, belief, likelihood).
template <class T>
using image = Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// Read-only view of any row-major image-like Eigen expression with contiguous rows.
template <class T>
using image_view = Eigen::Ref<const image<T>>;

/// A size in pixels. Named fields, because rows/cols versus width/height is where bugs live.
struct pixel_size {
  Eigen::Index width = 0;   ///< columns (x)
  Eigen::Index height = 0;  ///< rows (y)
  friend bool operator==(const pixel_size&, const pixel_size&) = default;
};

namespace detail {

/// Builds an exception message in one expression: `fail<std::invalid_argument>("x = ", x)`.
template <class Exception = std::invalid_argument, class... Parts>
[[noreturn]] inline void fail(const Parts&... parts) {
  std::ostringstream out;
  out.precision(10);
  (out << ... << parts);
  throw Exception(out.str());
}

/// True when every element of the array is finite (no NaN, no infinity).
template <class Derived>
bool all_finite(const Eigen::DenseBase<Derived>& values) {
  return values.derived().array().isFinite().all();
}

/// The image with its contrast inverted, max + min - img: [min, max] onto itself, reversed. What
/// a photograph shows of an object whose raised parts are dark, seen the touch's way round.
template <class Derived>
[[nodiscard]] auto inverted_contrast(const Eigen::DenseBase<Derived>& img) {
  using T = typename Derived::Scalar;
  using out_type = Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  if (img.size() == 0) return out_type(img.rows(), img.cols());
  return out_type((img.derived().array().maxCoeff() + img.derived().array().minCoeff()) -
                  img.derived().array());
}

}  // namespace detail
}  // namespace tacmap
