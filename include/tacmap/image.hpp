// tacmap: images — the map, tactile images and the belief are row-major Eigen arrays.
//
// Convention used throughout tacmap: an image has `rows()` (y, downwards) and `cols()`
// (x, to the right); element (r, c) is the pixel in row r, column c. Row-major storage makes a
// row contiguous, which is what the whole-grid kernels stream over.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

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

/// The widest blur `gaussian_blurred` takes, px: its taps reach 3 sigma, 6001 per pass.
inline constexpr double max_blur_px = 1000.0;

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

namespace detail {

/// Bilinear resampling of `src` to `rows` x `cols` over the same extent: output pixel centres
/// mapped onto source pixel centres, the border pixels extended. Shared by `rescale`
/// (enlarging a map) and `preprocess` (taxels to map pixels).
inline image<float> resize_bilinear(const image<float>& src, Eigen::Index rows, Eigen::Index cols) {
  const double sy = static_cast<double>(src.rows()) / static_cast<double>(rows);
  const double sx = static_cast<double>(src.cols()) / static_cast<double>(cols);
  const auto last_row = static_cast<double>(src.rows() - 1);
  const auto last_col = static_cast<double>(src.cols() - 1);
  image<float> out(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r) {
    const double v = std::clamp((static_cast<double>(r) + 0.5) * sy - 0.5, 0.0, last_row);
    const auto r0 = static_cast<Eigen::Index>(std::floor(v));
    const Eigen::Index r1 = std::min(r0 + 1, src.rows() - 1);
    const double fy = v - static_cast<double>(r0);
    for (Eigen::Index c = 0; c < cols; ++c) {
      const double u = std::clamp((static_cast<double>(c) + 0.5) * sx - 0.5, 0.0, last_col);
      const auto c0 = static_cast<Eigen::Index>(std::floor(u));
      const Eigen::Index c1 = std::min(c0 + 1, src.cols() - 1);
      const double fx = u - static_cast<double>(c0);
      const double top = (1 - fx) * src(r0, c0) + fx * src(r0, c1);
      const double bottom = (1 - fx) * src(r1, c0) + fx * src(r1, c1);
      out(r, c) = static_cast<float>((1 - fy) * top + fy * bottom);
    }
  }
  return out;
}

}  // namespace detail

/// Area-average resize of `src` to `rows` x `cols`: each output pixel is the mean of the source
/// area it covers, partly covered source pixels weighted by their overlap. Shrinking therefore
/// does not alias, and the image's mean is kept. Enlarging with it repeats source pixels (blocky:
/// each output pixel takes the source pixel it lies in, or the mean of the two or four it
/// straddles); `rescale` interpolates instead. Throws std::invalid_argument for an empty source or
/// a size that is not positive.
[[nodiscard]] inline image<float> resize_area(const image<float>& src, Eigen::Index rows,
                                              Eigen::Index cols);

namespace detail {
/// `resize_area` with the source pixels per output pixel given (`sy` along rows, `sx` along
/// columns; each >= 1 when shrinking): output pixel (r, c) is the mean of the source area
/// [r sy, (r + 1) sy) x [c sx, (c + 1) sx). With rows x sy < src.rows() the source's last
/// rows are left out (a crop), and so for columns. The working resolution's resampling
/// (localizer.hpp): one exact scale on both axes.
[[nodiscard]] inline image<float> resize_area_by(
    const image<float>& src, Eigen::Index rows, Eigen::Index cols, double sy,
    double sx) {  // Per axis, the source indices each output index covers and their weights
                  // (overlap / extent):
  // separable, so the 2-D weight is the product and the per-pixel loop stays small.
  const auto weights = [](Eigen::Index n_out, double scale, Eigen::Index n_src) {
    std::vector<std::vector<std::pair<Eigen::Index, double>>> w(static_cast<std::size_t>(n_out));
    for (Eigen::Index o = 0; o < n_out; ++o) {
      const double a = static_cast<double>(o) * scale;
      const double b = a + scale;
      for (auto s = static_cast<Eigen::Index>(std::floor(a));
           s < n_src && static_cast<double>(s) < b; ++s) {
        const double overlap =
            std::min(b, static_cast<double>(s + 1)) - std::max(a, static_cast<double>(s));
        if (overlap > 0) w[static_cast<std::size_t>(o)].emplace_back(s, overlap / scale);
      }
    }
    return w;
  };
  const auto wy = weights(rows, sy, src.rows());
  const auto wx = weights(cols, sx, src.cols());
  image<float> out(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index c = 0; c < cols; ++c) {
      double sum = 0;
      double total = 0;
      for (const auto& [y, a] : wy[static_cast<std::size_t>(r)])
        for (const auto& [x, b] : wx[static_cast<std::size_t>(c)]) {
          sum += a * b * static_cast<double>(src(y, x));
          total += a * b;
        }
      // Dividing by the weights' own total (1 up to rounding) keeps a constant image exact.
      out(r, c) = static_cast<float>(sum / total);
    }
  return out;
}
}  // namespace detail

[[nodiscard]] inline image<float> resize_area(const image<float>& src, Eigen::Index rows,
                                              Eigen::Index cols) {
  if (src.size() == 0)
    detail::fail("resize_area: the source image is ", src.rows(), " x ", src.cols(),
                 " px (rows x cols); expected a non-empty image");
  if (rows < 1 || cols < 1)
    detail::fail("resize_area: the requested size is ", rows, " x ", cols,
                 " px (rows x cols); expected both >= 1");
  return detail::resize_area_by(src, rows, cols,
                                static_cast<double>(src.rows()) / static_cast<double>(rows),
                                static_cast<double>(src.cols()) / static_cast<double>(cols));
}

namespace detail {
/// 1-D Gaussian taps for `sigma` (in samples), truncated at 3 sigma; one tap for 0. Not
/// normalised: `gaussian_blur` divides by the taps that fall inside the image, pixel by pixel.
inline std::vector<double> gaussian_taps(double sigma) {
  if (!(sigma > 0.0)) return {1.0};
  const auto radius = static_cast<int>(std::ceil(3.0 * sigma));
  std::vector<double> taps(static_cast<std::size_t>(2 * radius + 1));
  for (int o = -radius; o <= radius; ++o)
    taps[static_cast<std::size_t>(o + radius)] =
        std::exp(-0.5 * static_cast<double>(o * o) / (sigma * sigma));
  return taps;
}

/// Separable Gaussian blur of `values` in place (`sigma` in pixels, unchecked). Taps falling
/// outside the image are dropped and the rest renormalised, so a constant image stays constant
/// (no darkening at the border) and a value farther than 3 sigma from any load stays exactly 0.
inline void gaussian_blur(image<float>& values, double sigma) {
  const std::vector<double> taps = gaussian_taps(sigma);
  if (taps.size() == 1) return;
  const auto radius = static_cast<Eigen::Index>(taps.size() / 2);
  const auto pass = [&](const image<float>& in, bool along_rows) {
    image<float> out(in.rows(), in.cols());
    const Eigen::Index n = along_rows ? in.cols() : in.rows();
    for (Eigen::Index r = 0; r < in.rows(); ++r)
      for (Eigen::Index c = 0; c < in.cols(); ++c) {
        const Eigen::Index at = along_rows ? c : r;
        double sum = 0.0;
        double weight = 0.0;
        for (Eigen::Index o = -radius; o <= radius; ++o) {
          const Eigen::Index k = at + o;
          if (k < 0 || k >= n) continue;
          const double w = taps[static_cast<std::size_t>(o + radius)];
          sum += w * static_cast<double>(along_rows ? in(r, k) : in(k, c));
          weight += w;
        }
        out(r, c) = static_cast<float>(sum / weight);
      }
    return out;
  };
  values = pass(values, true);
  values = pass(values, false);
}
}  // namespace detail

/// `src` blurred by a Gaussian of standard deviation `sigma_px` pixels (separable; taps to
/// 3 sigma). Taps falling outside the image are dropped and the rest renormalised, so a constant
/// image stays constant up to its border. `sigma_px` 0 returns a copy. Throws
/// std::invalid_argument for a `sigma_px` that is not in [0, `detail::max_blur_px`].
[[nodiscard]] inline image<float> gaussian_blurred(const image<float>& src, double sigma_px) {
  if (!(sigma_px >= 0.0 && sigma_px <= detail::max_blur_px))
    detail::fail("gaussian_blurred: sigma_px = ", sigma_px,
                 "; expected a standard deviation in [0, ", detail::max_blur_px,
                 "] pixels (0: no blur)");
  image<float> out = src;
  detail::gaussian_blur(out, sigma_px);
  return out;
}

/// `src`, sampled at `from_mm_per_px`, resampled to `to_mm_per_px` so that it covers the same
/// physical extent: each side becomes round(side x from / to) px (at least 1), so the scale is
/// met to within half a pixel over the whole side. Shrinking (to > from) averages areas
/// (`resize_area`: no aliasing, the mean is kept); enlarging (to < from) interpolates bilinearly
/// between pixel centres, the border pixels extended (smooth, unlike `resize_area`'s blocks); the
/// same scale returns a copy. Throws std::invalid_argument for an empty image, a scale that is
/// not finite and > 0, or a result under 1 px or over 2^28 px.
[[nodiscard]] inline image<float> rescale(const image<float>& src, double from_mm_per_px,
                                          double to_mm_per_px) {
  if (src.size() == 0)
    detail::fail("rescale: the source image is ", src.rows(), " x ", src.cols(),
                 " px (rows x cols); expected a non-empty image");
  if (!(std::isfinite(from_mm_per_px) && from_mm_per_px > 0.0) ||
      !(std::isfinite(to_mm_per_px) && to_mm_per_px > 0.0))
    detail::fail(
        "rescale: from ", from_mm_per_px, " to ", to_mm_per_px,
        " mm per px; expected two finite scales > 0 (the image's own, then the wanted one)");
  const double factor = from_mm_per_px / to_mm_per_px;
  const double rows_out = std::round(static_cast<double>(src.rows()) * factor);
  const double cols_out = std::round(static_cast<double>(src.cols()) * factor);
  // A bound that a typo in a scale (mm for m) hits long before the memory does.
  constexpr double max_pixels = 268435456.0;  // 2^28 floats = 1 GiB
  if (rows_out < 1.0 || cols_out < 1.0 || rows_out * cols_out > max_pixels)
    detail::fail("rescale: a ", src.rows(), " x ", src.cols(), " px image from ", from_mm_per_px,
                 " to ", to_mm_per_px, " mm per px would be ", rows_out, " x ", cols_out,
                 " px; expected 1 px to 2^28 px — check that both scales are in mm per px");
  const auto rows = static_cast<Eigen::Index>(rows_out);
  const auto cols = static_cast<Eigen::Index>(cols_out);
  if (rows == src.rows() && cols == src.cols()) return src;
  if (factor < 1.0) return resize_area(src, rows, cols);
  return detail::resize_bilinear(src, rows, cols);
}

}  // namespace tacmap
