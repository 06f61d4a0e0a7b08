// tacmap: `unsigned_orientation` — dense SIFT with opposite gradient orientations folded together,
// so that a patch and its contrast-reversed copy have the same descriptor.
//
// Why: a tactile image always shows raised parts as high pressure, but a photograph shows them
// brighter or darker than their surroundings depending on the object (reference/
// cross-modal-matching.md). Where they are darker, every gradient of the photo points the other
// way (theta -> theta + pi) and the true window's SIFT descriptors point away from the touch's.
// Folding orientation modulo pi, as HOG's unsigned gradients do (Dalal & Triggs, CVPR 2005) and
// PIIFD does for multimodal retinal registration (Chen et al., IEEE TBME 2010), makes the
// descriptor blind to the sign of contrast, at the price of half the orientation resolution.
#pragma once

#include <Eigen/Core>
#include <span>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "tacmap/config.hpp"
#include "tacmap/descriptor/concept.hpp"
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/descriptor/detail/dense_sift_kernels.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/image.hpp"

namespace tacmap {

namespace detail {

/// True for the `dense_sift` specialisations `unsigned_orientation` knows the layout of.
template <class D>
struct is_dense_sift : std::false_type {};
template <int NumBins, int NumAngles, class T>
struct is_dense_sift<dense_sift<NumBins, NumAngles, T>> : std::true_type {};

}  // namespace detail

/// A `dense_sift` whose opposite orientation channels are summed: gradient orientation modulo
/// pi ("unsigned", as in HOG), so an image and its negative give the same descriptors.
///
/// **What it computes.** The wrapped descriptor `Sift` (e.g. `sift_lite`, `classic_sift`) runs as
/// usual — whole-image division by the peak, gradients, soft orientation channels, pooling,
/// normalisation. Then, in every spatial bin, channel k and channel k + NumAngles/2 are summed
/// into folded channel k (k < NumAngles/2), and the folded descriptor is normalised again by the
/// wrapped descriptor's own rule (`norm_threshold`, `clamp`: detail::dsift::normalise).
///  * Element order: as `dense_sift` with half the angles, angles inner:
///    element_index(by, bx, k) = k + NumAngles/2 * (by + NumBins * bx).
///  * Dimension: NumBins^2 * NumAngles / 2 (16 for sift_lite, 64 for classic_sift).
///  * Why folding the normalised descriptor is enough: negating an image negates every gradient
///    (theta -> theta + pi), which moves channel k's energy to channel k + NumAngles/2 of the same
///    bin; the L2 norm and the elementwise clamp do not care about that permutation, so the
///    wrapped descriptors of the two images are channel-shifted copies and their folds are equal.
///    "Negative" means max + min - image: `dense_sift` divides an image by its largest magnitude,
///    and for an image >= 0 this keeps that peak (the scale of the gradients) unchanged; an
///    inversion that changes the peak changes the strength of weak, unnormalised descriptors.
///
/// **What it trades.** Half the orientation resolution (a bin no longer tells a rising edge from
/// a falling one, so e.g. a bright bar and a dark bar of the same shape match) for invariance to
/// the sign of contrast. For a map whose raised parts are darker than around them this is what
/// makes the true window match at all; for a map of known polarity it only loses information.
///
/// **Speed.** Offers what `descriptor_likelihood` and `rotated_descriptor_likelihood` use when the
/// wrapped descriptor does: `euclidean_distance`, `grid_spacing()` and `sample()` (only the grid's
/// patches), `describe_at()` with a reusable `workspace`. The fold is one pass over the wrapped
/// output: a few percent of its cost.
///
/// Const and stateless between calls, like the wrapped descriptor.
template <class Sift>
class unsigned_orientation {
  static_assert(detail::is_dense_sift<Sift>::value,
                "unsigned_orientation wraps a dense_sift<NumBins, NumAngles, T> (it folds that "
                "layout's orientation channels)");
  static_assert(Sift::num_angles % 2 == 0,
                "unsigned_orientation needs an even number of orientation channels, so that "
                "channel k + NumAngles/2 is the opposite of channel k");

 public:
  using scalar_type = typename Sift::scalar_type;
  using wrapped_type = Sift;
  using column = Eigen::Ref<const Eigen::Array<scalar_type, Eigen::Dynamic, 1>>;
  using workspace = typename Sift::workspace;
  static constexpr int num_bins = Sift::num_bins;
  /// Folded orientation channels: half the wrapped descriptor's.
  static constexpr int num_angles = Sift::num_angles / 2;
  static constexpr int descriptor_size = num_bins * num_bins * num_angles;
  /// `distance` is Euclidean, as the wrapped descriptor's (whole-field fast paths apply).
  static constexpr bool euclidean_distance = true;
  /// Folded histograms renormalised by the wrapped rule: the wrapped descriptor's range
  /// (concept.hpp, H5).
  static constexpr bool byte_quantizable = true;

  /// The wrapped descriptor's default configuration (`Sift::default_params()`).
  unsigned_orientation() = default;
  /// Wraps `sift` (its parameters, validated by its own constructor).
  explicit unsigned_orientation(Sift sift) : sift_(std::move(sift)) {}
  /// Wraps a `Sift` built from `params`; throws `std::invalid_argument` as `Sift` does.
  explicit unsigned_orientation(const dense_sift_params& params) : sift_(params) {}

  [[nodiscard]] const Sift& wrapped() const noexcept { return sift_; }
  [[nodiscard]] const dense_sift_params& params() const noexcept { return sift_.params(); }
  [[nodiscard]] Eigen::Index dimension() const noexcept { return descriptor_size; }
  [[nodiscard]] Eigen::Index patch_size() const noexcept { return sift_.patch_size(); }
  [[nodiscard]] Eigen::Index grid_spacing() const noexcept { return sift_.grid_spacing(); }

  /// Position of (bin row `by`, bin column `bx`, folded orientation `angle` < num_angles).
  [[nodiscard]] static constexpr Eigen::Index element_index(Eigen::Index by, Eigen::Index bx,
                                                            Eigen::Index angle) noexcept {
    return angle + num_angles * (by + num_bins * bx);
  }

  /// Folded descriptors of every patch position at stride 1 (layout of `dense_sift::compute`).
  /// Throws `std::invalid_argument` as the wrapped `compute` does.
  [[nodiscard]] descriptor_field<scalar_type> compute(const image_view<scalar_type>& img) const {
    const descriptor_field<scalar_type> signed_field = sift_.compute(img);
    descriptor_field<scalar_type> field;
    field.rows = signed_field.rows;
    field.cols = signed_field.cols;
    field.values = fold(signed_field.values);
    return field;
  }

  /// Folded descriptors on the grid_spacing grid (layout of `dense_sift::sample`).
  [[nodiscard]] descriptor_samples<scalar_type> sample(const image_view<scalar_type>& img) const {
    descriptor_samples<scalar_type> out = sift_.sample(img);
    out.values = fold(out.values);
    return out;
  }

  /// Folded descriptors of the patches with the given top-lefts (`dense_sift::describe_at`).
  [[nodiscard]] Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> describe_at(
      const image_view<scalar_type>& img, std::span<const grid_cell> top_left) const {
    return fold(sift_.describe_at(img, top_left));
  }

  /// `describe_at` reusing `scratch`'s memory.
  [[nodiscard]] Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> describe_at(
      const image_view<scalar_type>& img, std::span<const grid_cell> top_left,
      workspace& scratch) const {
    return fold(sift_.describe_at(img, top_left, scratch));
  }

  /// Euclidean distance between two folded descriptors. Throws `std::invalid_argument` when a
  /// column's length is not `dimension()`.
  [[nodiscard]] scalar_type distance(column a, column b) const {
    if (a.size() != descriptor_size || b.size() != descriptor_size) {
      detail::fail<std::invalid_argument>(
          "unsigned_orientation::distance: descriptors of length ", a.size(), " and ", b.size(),
          " given, expected ", descriptor_size,
          " each (the folded dimension, half the wrapped descriptor's ", Sift::descriptor_size,
          "); pass columns of this descriptor's output");
    }
    return (a - b).matrix().norm();
  }

  /// Folds wrapped descriptors (Sift::dimension() x n) into this descriptor's (dimension() x n)
  /// and renormalises them: see the class comment.
  [[nodiscard]] Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> fold(
      const Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic>& wrapped_values) const {
    TACMAP_ASSERT(wrapped_values.rows() == Sift::descriptor_size,
                  "unsigned_orientation::fold: not the wrapped descriptor's dimension");
    const Eigen::Index n = wrapped_values.cols();
    // Angles are the innermost index of both layouts, so each column-major run of NumAngles
    // wrapped values (one spatial bin) becomes one run of NumAngles/2 folded values: the whole
    // block is a NumAngles x (bins * n) array whose top and bottom halves add up.
    using wrapped_runs =
        Eigen::Map<const Eigen::Array<scalar_type, Sift::num_angles, Eigen::Dynamic>>;
    using folded_runs = Eigen::Map<Eigen::Array<scalar_type, num_angles, Eigen::Dynamic>>;
    const Eigen::Index runs = num_bins * num_bins * n;
    Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> out(descriptor_size, n);
    const wrapped_runs in(wrapped_values.data(), Sift::num_angles, runs);
    folded_runs(out.data(), num_angles, runs) =
        in.template topRows<num_angles>() + in.template bottomRows<num_angles>();
    // The sum of two clamped unit halves is neither unit nor clamped: apply the wrapped
    // descriptor's rule again, so strong folded descriptors are unit length and clamped and weak
    // ones (flat areas) stay weak.
    detail::dsift::normalise<descriptor_size>(out.data(), n,
                                              static_cast<scalar_type>(params().norm_threshold),
                                              static_cast<scalar_type>(params().clamp));
    return out;
  }

 private:
  Sift sift_;
};

static_assert(descriptor<unsigned_orientation<sift_lite>>);
static_assert(descriptor<unsigned_orientation<classic_sift>>);

}  // namespace tacmap
