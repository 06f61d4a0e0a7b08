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

}  // namespace detail
}  // namespace tacmap
