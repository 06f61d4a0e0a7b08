// tacmap: the `descriptor` concept — dense local features shared by tactile and visual images
// (paper, Sec. III-C: the same descriptor is extracted from both modalities).
#pragma once

#include <concepts>

#include "tacmap/grid/concept.hpp"
#include "tacmap/image.hpp"

namespace tacmap {

/// Descriptors of every square patch of an image, at stride 1.
///
/// `values` holds one descriptor per column (so each descriptor is contiguous); the patch whose
/// top-left pixel is (r, c) is column `r * cols + c`. `rows` and `cols` count patch positions:
/// for an H x W image and patch side p they are H - p + 1 and W - p + 1.
template <class T>
struct descriptor_field {
  Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic> values;  ///< dimension x (rows * cols)
  Eigen::Index rows = 0;
  Eigen::Index cols = 0;

  /// The descriptor of the patch with top-left pixel (r, c).
  [[nodiscard]] auto at(Eigen::Index r, Eigen::Index c) const { return values.col(r * cols + c); }
};

/// A dense local image descriptor.
///
/// A type `D` models `descriptor` when, for a `const D d`, an `image<D::scalar_type> img` and two
/// descriptor columns `a`, `b` (`Eigen::Ref<const Eigen::Array<D::scalar_type, Eigen::Dynamic,
/// 1>>`):
///  1. `D::scalar_type` is `float` or `double`.
///  2. `d.dimension()` returns `Eigen::Index` > 0: the length of one descriptor.
///  3. `d.patch_size()` returns `Eigen::Index` > 0: the side, in pixels, of the square patch one
///     descriptor describes.
///  4. `d.compute(img)` returns `descriptor_field<D::scalar_type>` with `dimension()` rows and one
///     column per patch position of `img` at stride 1; it throws `std::invalid_argument` when
///     `img` is smaller than a patch or holds NaN.
///  5. `d.distance(a, b)` returns `D::scalar_type`: finite, >= 0, zero for `a == b`, symmetric.
///
/// Minimal conforming type (a patch's mean intensity, 1-D):
/// ```
/// struct mean_intensity {
///   using scalar_type = float;
///   using column = Eigen::Ref<const Eigen::Array<float, Eigen::Dynamic, 1>>;
///   Eigen::Index dimension() const { return 1; }
///   Eigen::Index patch_size() const { return 3; }
///   descriptor_field<float> compute(const image<float>& img) const;  // 3 x 3 box means
///   float distance(column a, column b) const { return std::abs(a(0) - b(0)); }
/// };
/// ```
template <class D>
concept descriptor = belief_scalar<typename D::scalar_type> &&
    requires(const D& d, const image<typename D::scalar_type>& img,
             const Eigen::Ref<const Eigen::Array<typename D::scalar_type, Eigen::Dynamic, 1>>& a) {
  { d.dimension() } -> std::same_as<Eigen::Index>;
  { d.patch_size() } -> std::same_as<Eigen::Index>;
  { d.compute(img) } -> std::same_as<descriptor_field<typename D::scalar_type>>;
  { d.distance(a, a) } -> std::same_as<typename D::scalar_type>;
};

}  // namespace tacmap
