// tacmap: the `descriptor` concept — dense local features shared by tactile and visual images
// (paper, Sec. III-C: the same descriptor is extracted from both modalities).
#pragma once

#include <concepts>
#include <span>
#include <vector>

#include "tacmap/grid/concept.hpp"
#include "tacmap/grid/planar_grid.hpp"
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
///   descriptor_field<float> compute(const image<float>& img) const;  // 3 x 3 box means;
///                                        // throws on a small or non-finite image
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

/// Optional hooks. A `descriptor` may offer more; the library detects each with a concept below
/// and takes a faster path when it is there, and `tacmap/testing/conformance.hpp` checks each
/// one a type declares:
///  H1. `static constexpr bool euclidean_distance = true;`: `distance(a, b)` IS the Euclidean
///      norm of a - b. The measurement models then compute distances as whole-array dot
///      products and never call `distance()`, so a type that declares it but measures something
///      else would be silently wrong (the conformance suite compares the two).
///  H2. `grid_spacing()` (`Eigen::Index` > 0) and `sample(img)` (a `.values` array with one
///      column per patch whose top-left pixel is (i * spacing, j * spacing), row-major over that
///      grid): the patches on the spacing grid only, each equal to `compute(img)`'s column there.
///      The tactile side then describes only the patches it uses.
///  H3. `contrast_permutation()` (with H1): a `std::vector<Eigen::Index>` p, an involution
///      without fixed points, such that element i of the descriptor of the inverted image
///      (max + min - img) is element p[i] of the image's (`dense_sift`: orientation channels
///      turned by half a turn). `descriptor_likelihood_params::both_signs` then scores both
///      contrast signs in one pass.
///  H4. `describe_windows(map, window, offsets, sink)`: the descriptors of the patches whose
///      top-left pixels are `offsets` (inside a window) of EVERY window of `map`, each equal to
///      compute(window cut from the map)'s column at that offset, delivered one row of windows
///      at a time: for r = 0 .. map rows - window.height, in order, sink(r, block) with `block`
///      an `Eigen::Array<scalar_type, Dynamic, Dynamic>` of dimension() x (cols * M), column
///      c * M + m = patch m of the window with top-left (r, c) (cols = map cols - window.width
///      + 1, M = offsets.size()). `descriptor_likelihood` (per_window features) then prepares a
///      map from it instead of one `compute` per window; a descriptor can share work between
///      overlapping windows there (`dense_sift`: gradients, channels and pooled sums, issue 14).
///  H5. `static constexpr bool byte_quantizable = true;` (with H1): every element is >= 0 and
///      all but rare ones are <= 0.5, as in normalised, clamped histograms (`dense_sift`:
///      normalised to unit length, clamped at 0.2, renormalised). `descriptor_storage::int8`
///      then stores the per-window descriptors as 7-bit integers (round(254 v); larger
///      elements clamped at 127 and counted; a negative one refused); without H5 the model
///      keeps floats.
template <class D>
concept euclidean_descriptor = descriptor<D> && requires {
  requires D::euclidean_distance;
};

/// H5 above.
template <class D>
concept byte_quantizable_descriptor = euclidean_descriptor<D> && requires {
  requires D::byte_quantizable;
};

/// H2 above.
template <class D>
concept samples_on_grid = descriptor<D> &&
    requires(const D& d, const image<typename D::scalar_type>& img) {
  { d.grid_spacing() } -> std::same_as<Eigen::Index>;
  {
    d.sample(img).values
    } -> std::convertible_to<Eigen::Array<typename D::scalar_type, Eigen::Dynamic, Eigen::Dynamic>>;
};

/// H3 above.
template <class D>
concept contrast_symmetric_descriptor = euclidean_descriptor<D> && requires(const D& d) {
  { d.contrast_permutation() } -> std::convertible_to<std::vector<Eigen::Index>>;
};

namespace detail {
/// The sink `describes_windows` is checked with: what a caller of H4 passes must be callable so.
template <class T>
struct window_rows_sink {
  void operator()(Eigen::Index /*row*/,
                  const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& /*block*/) const {}
};
}  // namespace detail

/// H4 above.
template <class D>
concept describes_windows = descriptor<D> &&
    requires(const D& d, const image<typename D::scalar_type>& map, pixel_size window,
             std::span<const grid_cell> offsets,
             detail::window_rows_sink<typename D::scalar_type> sink) {
  d.describe_windows(map, window, offsets, sink);
};

}  // namespace tacmap
