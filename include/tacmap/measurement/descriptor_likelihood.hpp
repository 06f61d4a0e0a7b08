// tacmap: `descriptor_likelihood` — the paper's feature-based measurement model (Sec. III-C).
//
// The tactile image z (at map scale, h x w px) is cut into overlapping patches on a grid of the
// descriptor's patch size and a spacing (the paper: patch 18, spacing 9 -> three 18 x 18 patches
// of the 42 x 18 image), one descriptor each: g_1..g_M. A map window at state x gives the
// descriptors f_{x,1..M} of the patches at the same offsets. The distance is eq. (1), read as
// the text says (Euclidean distances; the printed formula's signed sum is a typo):
//   all_pairs:  d(x, z) = sum_{m=1..M} sum_{n=1..M} || f_{x,m} - g_n ||
//   aligned:    d(x, z) = sum_{m=1..M} || f_{x,m} - g_m ||        (patch m against patch m)
// and the likelihood shape is either eq. (2) or an exponential:
//   inverse:      p(z | x) = eta' / d            -> log p = -log(d + epsilon)   (guarded at d = 0)
//   exponential:  p(z | x) = exp(-d / tau)       -> log p = -d / tau
// times a tempering exponent (a multiply on the log-likelihood).
//
// Where the window descriptors f_{x,m} come from (`window_features`):
//  * per_window (default, the paper's way): each window is cut from the map and described on its
//    own, exactly as a tactile image is — so a noiseless touch matches its own window exactly.
//    Once per map: one extraction per window. Per touch: M x M distances per window.
//  * shared_dense: neighbouring windows share patches (window x's patch m is the dense map patch
//    at x + offset_m), so the map is described once, densely, at stride 1, and each window's d is
//    a sum of M shifted copies of D_n(q) = || F(q) - g_n || — whole-grid block additions, about
//    M times less work per touch. The price: a window's patch sees the map around the window
//    (and the whole map's normalisation) where the tactile image sees its own borders; with
//    descriptors whose support is large next to the window (SIFT-lite's 9 px bins on an 18 px
//    wide window) this costs accuracy — measured in README.
//
// The sign of contrast (`contrast_sign`, beyond the paper): a touch shows raised parts as high
// pressure, a photo may show them darker than around them, which turns every gradient by 180
// degrees (reference/cross-modal-matching.md). With `either_per_patch` each aligned patch pair
// counts the better of the tactile image and its inversion z' = max(z) + min(z) - z:
//   either_per_patch:  d(x, z) = sum_m min(|| f_{x,m} - g_m ||, || f_{x,m} - g'_m ||)
// with g'_m the descriptors of z' (the same descriptor, so any descriptor works).
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <span>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

#include "tacmap/descriptor/concept.hpp"
#include "tacmap/detail/mass_sum.hpp"
#include "tacmap/detail/memory_budget.hpp"
#include "tacmap/detail/setting_ranges.hpp"
#include "tacmap/detail/type_name.hpp"
#include "tacmap/executor/concept.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/image.hpp"
#include "tacmap/measurement/concept.hpp"
#include "tacmap/measurement/detail/distance_kernel.hpp"
#include "tacmap/measurement/detail/quantized_kernel.hpp"
#include "tacmap/measurement/detail/state_ranges.hpp"

namespace tacmap {

/// Which tactile patch is compared with which window patch in eq. (1).
enum class pairing {
  all_pairs,  ///< the paper's eq. (1): every window patch against every tactile patch (M^2 terms)
  aligned,    ///< patch m against patch m only (M terms): sensitive to the patches' order
};

/// How a distance becomes a likelihood.
enum class likelihood_shape {
  inverse,      ///< the paper's eq. (2): eta' / d, guarded by epsilon as d -> 0
  exponential,  ///< exp(-d / tau)
};

/// Where a window's descriptors come from.
enum class window_features {
  /// The paper's way (Sec.\ III-C, "the same approach is also applied to the visual images"):
  /// every window is cut from the map and described on its own, exactly like a tactile image —
  /// same image borders, same normalisation. Precompute: one descriptor extraction per window
  /// (once per map); per touch: M descriptors per window to compare.
  per_window,
  /// Descriptors computed once, densely, over the whole map and shared by overlapping windows:
  /// far cheaper per touch, but a window's patch sees the map around the window (real
  /// neighbours, the whole map's normalisation) where the tactile image sees its own borders.
  shared_dense,
};

/// Which sign of contrast a tactile patch is matched with (beyond the paper).
enum class contrast_sign {
  /// The tactile image as it is: raised (high pressure) must look brighter in the map. The
  /// paper's assumption (its gecko is a light print on a dark base).
  as_is,
  /// Per aligned patch, the smaller distance of the tactile image and of its inversion
  /// max(z) + min(z) - z: raised parts may look brighter or darker, even differently in different
  /// patches of one touch. Costs a second tactile description and twice the distances per touch,
  /// and a patch may now also match contrast-reversed structure that is not its own. Aligned
  /// pairing only: with all pairs there is no patch pair whose sign the minimum would choose.
  either_per_patch,
};

/// How the per-window descriptors are stored (issue 14).
enum class descriptor_storage {
  /// As computed, in the descriptor's scalar type: the paper's.
  float32,
  /// 7-bit integers, round(254 v) in [0, 127] (measurement/detail/quantized_kernel.hpp), the
  /// touch's descriptors quantised alike, distances from exact integer dot products: a quarter
  /// of the bytes a touch streams. Elements above 0.5 are clamped at 127 (counted:
  /// `quantization_clamped()`); a negative element is refused at preparation. Applies to
  /// per-window features of a descriptor that declares such values (`byte_quantizable`,
  /// descriptor/concept.hpp H5: dense_sift); other configurations and descriptors keep float32
  /// (`stores_quantized()` tells).
  int8,
};

/// Configuration of `descriptor_likelihood`. The defaults are the best configuration measured
/// with tacmap-evaluate (README, "Localization results": aligned pairs with an exponential
/// likelihood beat the paper's all-pairs / inverse choice on every map and descriptor);
/// `paper()` gives the paper's eq. (1) and (2) exactly.
struct descriptor_likelihood_params {
  Eigen::Index spacing = 9;  ///< pixels between tactile patches (paper: 9)
  window_features features = window_features::per_window;  ///< paper: per window
  pairing pairs = pairing::aligned;                        ///< paper: all_pairs (eq. (1))
  likelihood_shape shape = likelihood_shape::exponential;  ///< paper: inverse (eq. (2))
  double epsilon = 1e-3;  ///< inverse: added to d so that d = 0 is finite
  /// Exponential: temperature, in distance units. 0.15: fitted by maximum likelihood with
  /// tacmap-calibrate (classic_sift, realistic scenario, 8 photographs tacmap-evaluate does not
  /// use, seed 101: 0.152), at which the belief's P(error <= 5 mm) is calibrated (README,
  /// "Confidence"); 0.25 before, underconfident by 13-16 points.
  double tau = 0.15;
  double tempering = 1.0;                         ///< exponent on the likelihood, [0, 1e3]
  contrast_sign contrast = contrast_sign::as_is;  ///< paper: as_is; either_per_patch: aligned only
  /// Prepare for `log_likelihood_both_signs` (the appearance hypotheses of
  /// `appearance_likelihood`): the map's descriptors are stored in the sum/difference basis of
  /// the descriptor's `contrast_permutation()`, where a touch and its inverted contrast are
  /// matched with the multiply-adds of one (distances are unchanged by the basis). Needs a
  /// descriptor with a contrast permutation (dense_sift), aligned pairing and contrast as_is.
  bool both_signs = false;
  /// How the per-window descriptors are stored. int8: as many sequences localized as float32
  /// in tacmap-evaluate with classic_sift (realistic scenario, seeds 1-3), a quarter of the
  /// bytes per touch (README, "Performance"). paper: float32.
  descriptor_storage storage = descriptor_storage::int8;

  /// The paper's configuration: all pairs (eq. (1)), inverse likelihood (eq. (2)), per window,
  /// float descriptors.
  [[nodiscard]] static descriptor_likelihood_params paper() {
    descriptor_likelihood_params p;
    p.pairs = pairing::all_pairs;
    p.shape = likelihood_shape::inverse;
    p.storage = descriptor_storage::float32;
    return p;
  }

  void validate() const {
    if (spacing <= 0)
      detail::fail("descriptor_likelihood_params: spacing = ", spacing,
                   "; expected a positive number of pixels between tactile patches (paper: 9)");
    // The ranges keep the float log-likelihood finite (setting_ranges.hpp).
    detail::check_range("descriptor_likelihood_params", "epsilon", epsilon, detail::min_epsilon,
                        detail::max_epsilon, "", "eq. (2)'s guard (it is unbounded as d -> 0)",
                        "the default is 1e-3");
    detail::check_range("descriptor_likelihood_params", "tau", tau, detail::min_tau,
                        detail::max_tau, " (descriptor distance units)", "a temperature",
                        "fit it with tacmap-calibrate, or keep the default 0.15");
    detail::check_range("descriptor_likelihood_params", "tempering", tempering, 0.0,
                        detail::max_tempering, "", "an exponent on the likelihood",
                        "1 is the likelihood itself, 0 ignores the touches");
    if (contrast == contrast_sign::either_per_patch && pairs == pairing::all_pairs)
      detail::fail(
          "descriptor_likelihood_params: contrast = either_per_patch with pairs = all_pairs; "
          "expected pairs = aligned (either_per_patch takes the nearer sign for each patch m "
          "against patch m; all pairs compare every patch with every other), or contrast = as_is");
    if (both_signs && pairs == pairing::all_pairs)
      detail::fail(
          "descriptor_likelihood_params: both_signs = true with pairs = all_pairs; "
          "expected pairs = aligned (the one-pass match of both contrast signs pairs "
          "patch m with patch m), or both_signs = false");
    if (both_signs && contrast == contrast_sign::either_per_patch)
      detail::fail(
          "descriptor_likelihood_params: both_signs = true with contrast = "
          "either_per_patch; expected one of them (both_signs scores each sign for the "
          "whole touch, either_per_patch picks a sign per patch)");
  }
};

// The optional descriptor hooks (euclidean_descriptor, samples_on_grid,
// contrast_symmetric_descriptor) are in tacmap/descriptor/concept.hpp.

namespace detail {

/// Checks what every descriptor measurement model needs of its map and window (`who` names the
/// model in messages) and returns the tactile patches' top-left offsets inside the window: the
/// grid of `patch` px patches every `spacing` px, row-major (the paper: 3 patches of 18 px,
/// spacing 9, down a 42 x 18 window).
inline std::vector<grid_cell> checked_patch_offsets(const char* who, const image<float>& map,
                                                    pixel_size window, Eigen::Index patch,
                                                    Eigen::Index spacing) {
  if (window.width <= 0 || window.height <= 0 || map.cols() < window.width ||
      map.rows() < window.height)
    fail(who, ": the map is ", map.cols(), " x ", map.rows(),
         " px (width x height) and the window ", window.width, " x ", window.height,
         "; expected a positive window no larger than the map");
  if (window.width < patch || window.height < patch)
    fail(who, ": a descriptor patch of ", patch, " px does not fit the ", window.width, " x ",
         window.height,
         " px tactile window; expected a patch no larger than the window's shorter side "
         "(paper: patch 18 on a 42 x 18 window)");
  if (!all_finite(map)) fail(who, ": the map contains NaN or infinite pixels");
  std::vector<grid_cell> offsets;
  for (Eigen::Index oy = 0; oy + patch <= window.height; oy += spacing)
    for (Eigen::Index ox = 0; ox + patch <= window.width; ox += spacing)
      offsets.push_back({oy, ox});
  return offsets;
}

/// The sum of every element of `values` in double, for check_descriptors: NaN or infinite
/// when any element is. Contiguous storage through `double_sum` (interleaved totals), not as
/// Eigen's one chain of dependent adds, whose latency made the check 7 % of a pose model's
/// preparation on the paper's map.
template <class Derived>
double finite_probe_sum(const Eigen::DenseBase<Derived>& values) {
  if constexpr (std::is_base_of_v<Eigen::PlainObjectBase<Derived>, Derived>)
    return double_sum(values.derived().data(), values.size());
  else
    return static_cast<double>(values.sum());
}

/// Checks descriptors a `descriptor` D delivered (`values`: dimension() rows, `columns`
/// columns expected) for what the models rely on: the right dimension and count, every value
/// finite. `what` says what was described ("the map", "a tactile image", ...). Throws
/// std::invalid_argument naming D and the offending value: a user's descriptor that returns
/// NaN or a field of the wrong shape is refused where it happens, not found later as a NaN
/// belief or an out-of-range read.
template <class D, class Derived>
void check_descriptor_shape(const D& d, const Eigen::DenseBase<Derived>& values,
                            Eigen::Index columns, const char* what) {
  if (values.rows() != d.dimension() || values.cols() != columns)
    fail("descriptor ", type_name<D>(), ": described ", what, " with ", values.cols(),
         " descriptors of ", values.rows(), " values; expected ", columns,
         " of dimension() = ", d.dimension(),
         " values (descriptor/concept.hpp, requirement 4: one column of dimension() values per "
         "patch position)");
}

/// check_descriptor_shape, then every value finite.
template <class D, class Derived>
void check_descriptors(const D& d, const Eigen::DenseBase<Derived>& values, Eigen::Index columns,
                       const char* what) {
  check_descriptor_shape(d, values, columns, what);
  // One vectorised sum finds any NaN or infinity (they propagate); only then (or when finite
  // values overflow the sum) the element-wise scan, which names the first one: a check over
  // every per-window descriptor of a map must cost little beside describing them.
  if (std::isfinite(finite_probe_sum(values))) return;
  for (Eigen::Index c = 0; c < values.cols(); ++c)
    for (Eigen::Index i = 0; i < values.rows(); ++i)
      if (!std::isfinite(static_cast<double>(values(i, c))))
        fail("descriptor ", type_name<D>(), ": described ", what, " with the value ", values(i, c),
             " at element ", i, " of descriptor ", c,
             "; expected finite values (descriptor/concept.hpp: a flat or dark patch must get a "
             "finite descriptor too, e.g. all zeros)");
}

/// Checks the shape of a dense field D::compute returned for an image of `rows` x `cols`
/// pixels: its positions (rows - patch + 1) x (cols - patch + 1), its dimension.
template <class D, class T>
void check_field_shape(const D& d, const descriptor_field<T>& f, Eigen::Index rows,
                       Eigen::Index cols, const char* what) {
  const Eigen::Index p = d.patch_size();
  if (f.rows != rows - p + 1 || f.cols != cols - p + 1 || f.values.cols() != f.rows * f.cols)
    fail("descriptor ", type_name<D>(), ": compute() of ", what, " (", rows, " x ", cols,
         " px) returned a field of ", f.rows, " x ", f.cols, " positions and ", f.values.cols(),
         " columns; expected ", rows - p + 1, " x ", cols - p + 1,
         " positions (image size - patch_size() + 1), one column each (descriptor/concept.hpp, "
         "requirement 4)");
  check_descriptor_shape(d, f.values, f.rows * f.cols, what);
}

/// Checks a dense field: check_field_shape, then its values (`check_descriptors`).
template <class D, class T>
void check_field(const D& d, const descriptor_field<T>& f, Eigen::Index rows, Eigen::Index cols,
                 const char* what) {
  check_field_shape(d, f, rows, cols, what);
  check_descriptors(d, f.values, f.rows * f.cols, what);
}

/// Checks a tactile image against the model's window: its size, then its pixels.
inline void check_tactile_image(const char* who, const image<float>& z, pixel_size window) {
  if (z.rows() != window.height || z.cols() != window.width)
    fail(who, ": tactile image is ", z.rows(), " x ", z.cols(), " px (rows x cols); expected ",
         window.height, " x ", window.width,
         " (the sensor window at map scale, in the sensor's own frame — preprocess the frame "
         "first)");
  if (!all_finite(z)) fail(who, ": the tactile image contains NaN or infinite pixels");
}

/// What `sample(img)` of a descriptor D returns.
template <class D>
using sample_result_t = decltype(std::declval<const D&>().sample(
    std::declval<const image<typename D::scalar_type>&>()));

/// A descriptor that can sample into memory it is given (dense_sift::sample(img, workspace,
/// out)): the descriptor models then describe a touch without allocating.
template <class D>
concept samples_into_workspace = samples_on_grid<D> &&
    requires(const D& d, const image<typename D::scalar_type>& img, typename D::workspace& w,
             sample_result_t<D>& out) {
  d.sample(img, w, out);
};

/// A descriptor model's memory for describing touches (empty for other descriptors).
template <class D>
struct touch_scratch {};
template <samples_into_workspace D>
struct touch_scratch<D> {
  typename D::workspace workspace;
  sample_result_t<D> samples;
};

/// The tracking hook's bound on log p(z | x) of the descriptor models (`P`: their parameters,
/// with shape, tempering, epsilon): distances are >= 0, so the exponential shape's
/// -tempering d / tau is <= 0 and eq. (2)'s -tempering log(d + epsilon) is
/// <= -tempering log(epsilon), returned a hair higher so that the float logarithm (and epsilon
/// rounded to float) of the model itself cannot exceed it.
template <class P>
[[nodiscard]] double log_likelihood_bound(const P& params) {
  if (params.shape == likelihood_shape::exponential) return 0.0;
  const double b = -params.tempering * std::log(params.epsilon);
  return b + 1e-5 * (1.0 + std::abs(b));
}

}  // namespace detail

/// The paper's measurement model over a `planar_grid`, for any `descriptor`.
template <descriptor Descriptor>
class descriptor_likelihood {
 public:
  using scalar_type = typename Descriptor::scalar_type;
  using measurement_type = image<float>;  ///< preprocessed tactile image at map scale
  /// Descriptors as columns (dimension x count).
  using descriptor_matrix = Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic>;

  /// Computes the map's dense descriptors once. `window` is the tactile image's size in map
  /// pixels (the grid's window). Throws std::invalid_argument when the map is smaller than the
  /// window, or the descriptor's patch and the spacing do not fit the window.
  descriptor_likelihood(Descriptor descriptor, const image<float>& map, pixel_size window,
                        descriptor_likelihood_params params = {});

  /// Number of tactile patches M (the paper: 3).
  [[nodiscard]] Eigen::Index patches_per_window() const {
    return static_cast<Eigen::Index>(offsets_.size());
  }
  /// Top-left pixel (row, col) of patch m inside the window.
  [[nodiscard]] grid_cell patch_offset(Eigen::Index m) const {
    return offsets_[static_cast<std::size_t>(m)];
  }
  [[nodiscard]] const descriptor_field<scalar_type>& map_descriptors() const { return field_; }
  [[nodiscard]] const Descriptor& descriptor() const { return descriptor_; }
  [[nodiscard]] const descriptor_likelihood_params& params() const { return params_; }
  /// True when the per-window descriptors are stored as 7-bit integers
  /// (`descriptor_storage::int8` where it applies).
  [[nodiscard]] bool stores_quantized() const { return quantized_; }
  /// Elements of the map's per-window descriptors clamped at 127 when they were quantised
  /// (values above 0.5; 0 with float storage).
  [[nodiscard]] std::uint64_t quantization_clamped() const { return clamped_; }
  /// Elements of the touch z's descriptors that quantisation clamps (the same range as the
  /// map's; 0 with float storage): the touch side of `quantization_clamped()`, on demand.
  [[nodiscard]] std::uint64_t quantization_clamped(const measurement_type& z) const {
    if (!quantized_) return 0;
    detail::quantized_query q;
    q.assign(tactile_descriptors(z));
    return q.clamped;
  }

  /// Runs the whole-grid distances on `e` (tacmap/executor/concept.hpp; empty: sequentially, the
  /// default): per-window features with contrast as_is (the default), split by tiles of window
  /// descriptors, each computed as the sequential pass computes it — the same values bit for
  /// bit. Other configurations stay sequential. `e` must outlive its use by this model (and by
  /// its copies, which share it).
  void set_executor(executor_ref e) { executor_ = e; }
  [[nodiscard]] executor_ref executor() const { return executor_; }

  /// The M descriptors of a tactile image (dimension x M), in patch order.
  [[nodiscard]] Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> tactile_descriptors(
      const measurement_type& z) const {
    detail::check_tactile_image("descriptor_likelihood", z, window_);
    const image<scalar_type> zt = z.template cast<scalar_type>();
    Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> g;
    describe_touch(zt, nullptr, g);
    return g;
  }

 private:
  // The touch's descriptors into g: with `scratch`, in its memory (no allocation once it has
  // seen a touch), else in the descriptor's own.
  void describe_touch(const image<scalar_type>& zt, detail::touch_scratch<Descriptor>* scratch,
                      descriptor_matrix& g) const {
    // A descriptor that can describe just its spacing grid (dense_sift::sample) saves most of the
    // tactile extraction: 3 of the 25 patch positions of a 42 x 18 image are needed.
    if constexpr (samples_on_grid<Descriptor>) {
      if (descriptor_.grid_spacing() == params_.spacing) {
        if constexpr (detail::samples_into_workspace<Descriptor>) {
          if (scratch != nullptr) {
            descriptor_.sample(zt, scratch->workspace, scratch->samples);
            g = scratch->samples.values;  // grid order = offsets_ order (row-major, same spacing)
            detail::check_descriptors(descriptor_, g, patches_per_window(), "a tactile image");
            return;
          }
        }
        g = descriptor_.sample(zt).values;
        detail::check_descriptors(descriptor_, g, patches_per_window(), "a tactile image");
        return;
      }
    }
    const auto zf = descriptor_.compute(zt);
    detail::check_field(descriptor_, zf, zt.rows(), zt.cols(), "a tactile image");
    g.resize(zf.values.rows(), patches_per_window());
    for (Eigen::Index m = 0; m < patches_per_window(); ++m)
      g.col(m) = zf.at(offsets_[static_cast<std::size_t>(m)].row,
                       offsets_[static_cast<std::size_t>(m)].col);
  }

  // The touch z's descriptors in the stored basis (in_stored_basis(tactile_descriptors(z))), in
  // the model's memory: valid until the next call. For the sequential paths (the default
  // update described a touch in 16 allocations).
  const descriptor_matrix& stored_touch(const measurement_type& z) const {
    detail::check_tactile_image("descriptor_likelihood", z, window_);
    touch_image_ = z.template cast<scalar_type>();
    describe_touch(touch_image_, &touch_scratch_, touch_);
    if (!stored_in_contrast_basis()) return touch_;
    to_stored_basis(touch_, touch_basis_);
    return touch_basis_;
  }

 public:
  /// The distance d(x, z) of eq. (1) for every state (row-major grid order).
  template <class G>
  void distances(const G& grid, const measurement_type& z, belief_array<G>& out)
      const requires std::same_as<typename G::scalar_type, scalar_type> {
    check_grid(grid);
    const descriptor_matrix& g = stored_touch(z);
    if (params_.contrast == contrast_sign::either_per_patch) {
      // The inverted touch, described like the touch itself (no assumption about the
      // descriptor's layout). It keeps z's range, so a descriptor that divides by the peak
      // (dense_sift) sees the same scale.
      const measurement_type inverted = detail::inverted_contrast(z);
      const auto g_inverted = in_stored_basis(tactile_descriptors(inverted));
      if (params_.features == window_features::per_window)
        per_window_distances(g, &g_inverted, out);
      else
        shared_distances(g, &g_inverted, out);
      return;
    }
    if (params_.features == window_features::per_window)
      per_window_distances(g, nullptr, out);
    else
      shared_distances(g, nullptr, out);
  }

  /// log p(z_k | x) for several tactile images at once: block k of `out` (`grid.size()` values
  /// from `out + k * grid.size()`) receives what `log_likelihood(grid, zs[k], ...)` would. With
  /// aligned pairing (the default) and a Euclidean descriptor, one pass over the windows'
  /// descriptors serves every image: `appearance_likelihood`'s hypotheses stream the 12.5 MB of
  /// per-window descriptors (classic_sift, 120 px map) once per touch instead of once each.
  template <class G>
  void log_likelihood_each(const G& grid, std::span<const measurement_type> zs, scalar_type* out)
      const requires std::same_as<typename G::scalar_type, scalar_type> {
    const Eigen::Index n = grid.size();
    const auto count = static_cast<Eigen::Index>(zs.size());
    bool shared_pass =
        params_.pairs == pairing::aligned && params_.contrast == contrast_sign::as_is && count > 1;
    if constexpr (!euclidean_descriptor<Descriptor>) shared_pass = false;
    if (!shared_pass) {
      belief_array<G> block(n);
      for (Eigen::Index k = 0; k < count; ++k) {
        log_likelihood(grid, zs[static_cast<std::size_t>(k)], block);
        Eigen::Map<Eigen::Array<scalar_type, Eigen::Dynamic, 1>>(out + k * n, n) = block;
      }
      return;
    }
    check_grid(grid);
    const Eigen::Index m_count = patches_per_window();
    // Every image's descriptors side by side, image-major: column k * M + m is image k's patch m.
    auto& all = signs_;
    for (Eigen::Index k = 0; k < count; ++k) {
      const descriptor_matrix& g = stored_touch(zs[static_cast<std::size_t>(k)]);
      if (k == 0) all.resize(g.rows(), count * m_count);
      all.middleCols(k * m_count, m_count) = g;
    }
    auto& dist = workspace_;
    if (params_.features == window_features::per_window) {
      // Per patch m: the windows' patch m against patch m of every image, in one pass.
      dist.resize(n, count);
      descriptor_matrix& column = patch_columns_;
      column.resize(all.rows(), count);
      for (Eigen::Index m = 0; m < m_count; ++m) {
        for (Eigen::Index k = 0; k < count; ++k) column.col(k) = all.col(k * m_count + m);
        distance_columns(per_window_[static_cast<std::size_t>(m)], column, dist);
        for (Eigen::Index k = 0; k < count; ++k) {
          Eigen::Map<Eigen::Array<scalar_type, Eigen::Dynamic, 1>> block(out + k * n, n);
          if (m == 0)
            block = dist.col(k);
          else
            block += dist.col(k);
        }
      }
    } else {
      // One pass over the dense field for every image's patches, then each image's windows
      // as sums of shifted columns (as shared_distances does for one).
      dist.resize(field_.rows * field_.cols, count * m_count);
      distance_columns(field_tiles_, all, dist);
      for (Eigen::Index k = 0; k < count; ++k)
        windows_from_columns(
            dist, [&](Eigen::Index m) { return k * m_count + m; }, out + k * n);
    }
    for (Eigen::Index k = 0; k < count; ++k) {
      Eigen::Map<Eigen::Array<scalar_type, Eigen::Dynamic, 1>> block(out + k * n, n);
      to_log_likelihood(block);
    }
  }

  /// log p(z | x) and log p(z^- | x) for the touch z and its inverted contrast
  /// z^- = max(z) + min(z) - z (the two appearance hypotheses of `appearance_likelihood`), into
  /// blocks 0 and 1 of `out` (`grid.size()` values each). With `params().both_signs` the map's
  /// descriptors sit in the sum/difference basis of the descriptor's contrast permutation, and
  /// one pass gives both (the multiply-adds of one touch); otherwise it is
  /// `log_likelihood_each(grid, {z, z^-}, out)`.
  template <class G>
  void log_likelihood_both_signs(const G& grid, const measurement_type& z, scalar_type* out)
      const requires std::same_as<typename G::scalar_type, scalar_type> {
    if (!params_.both_signs) {
      detail::check_tactile_image("descriptor_likelihood", z, window_);
      const measurement_type images[2] = {z, detail::inverted_contrast(z)};
      log_likelihood_each(grid, std::span<const measurement_type>(images), out);
      return;
    }
    check_grid(grid);
    const Eigen::Index n = grid.size();
    const Eigen::Index m_count = patches_per_window();
    if (quantized_) {
      quantized_both_signs(sign_queries(z), out, out + n, detail::tile_range{});
      for (Eigen::Index sign = 0; sign < 2; ++sign)
        to_log_likelihood(
            Eigen::Map<Eigen::Array<scalar_type, Eigen::Dynamic, 1>>(out + sign * n, n));
      return;
    }
    const descriptor_matrix& g = stored_touch(z);
    const Eigen::Index half = basis_.half();
    scalar_type* plus = out;
    scalar_type* minus = out + n;
    if (params_.features == window_features::per_window) {
      for (Eigen::Index m = 0; m < m_count; ++m)
        detail::accumulate_sign_pair(per_window_[static_cast<std::size_t>(m)].values, &g(0, m),
                                     half, plus, minus, m > 0);
    } else {
      // Per patch, both signs' distances over the dense field (columns m and M + m), then each
      // sign's windows as sums of shifted columns.
      auto& dist = workspace_;
      dist.resize(field_.rows * field_.cols, 2 * m_count);
      for (Eigen::Index m = 0; m < m_count; ++m)
        detail::accumulate_sign_pair(field_tiles_, &g(0, m), half, &dist(0, m),
                                     &dist(0, m_count + m), false);
      for (Eigen::Index sign = 0; sign < 2; ++sign)
        windows_from_columns(
            dist, [&](Eigen::Index m) { return sign * m_count + m; }, out + sign * n);
    }
    for (Eigen::Index sign = 0; sign < 2; ++sign)
      to_log_likelihood(
          Eigen::Map<Eigen::Array<scalar_type, Eigen::Dynamic, 1>>(out + sign * n, n));
  }

  /// log p(z | x) for every state: eq. (1) then eq. (2) or the exponential, times tempering.
  template <class G>
  void log_likelihood(const G& grid, const measurement_type& z, belief_array<G>& out)
      const requires std::same_as<typename G::scalar_type, scalar_type> {
    if (executor_ && params_.features == window_features::per_window &&
        params_.contrast == contrast_sign::as_is) {
      check_grid(grid);
      const descriptor_matrix g = in_stored_basis(tactile_descriptors(z));
      constexpr Eigen::Index width = detail::descriptor_tiles<scalar_type>::width;
      // Chunks of 8 tiles (64 states: 256 bytes of float output): no two threads write to one
      // cache line, and every chunk starts on a SIMD packet boundary of `out`, so that the
      // vectorised logarithm of eq. (2) splits a chunk as it splits the whole grid.
      constexpr Eigen::Index chunk = 8;
      const Eigen::Index tiles = (grid.size() + width - 1) / width;
      executor_.parallel_for(
          static_cast<std::size_t>((tiles + chunk - 1) / chunk), [&](std::size_t b, std::size_t e) {
            log_likelihood_tiles(g, out,
                                 {static_cast<Eigen::Index>(b) * chunk,
                                  std::min(static_cast<Eigen::Index>(e) * chunk, tiles)});
          });
      return;
    }
    distances(grid, z, out);
    to_log_likelihood(out);
  }

  /// Tracking hook (measurement/concept.hpp): an upper bound on log p(z | x) for every state and
  /// touch. Distances are >= 0, so the exponential shape's -tempering d / tau is <= 0 and eq.
  /// (2)'s -tempering log(d + epsilon) <= -tempering log(epsilon) (returned a hair higher, so
  /// that the float logarithm of the model itself cannot exceed it).
  [[nodiscard]] double log_likelihood_bound() const {
    return detail::log_likelihood_bound(params_);
  }

  /// Tracking hook: log p(z | x) at (at least) the states of `states` (sorted, disjoint ranges),
  /// bit for bit what `log_likelihood` writes there; other entries unspecified. Per-window
  /// features with contrast as_is (the default) stream only the tiles of window descriptors
  /// that hold those states (8 windows a tile); shared dense features and either_per_patch
  /// compute the whole grid (exact, no saving).
  template <class G>
  void log_likelihood_on(const G& grid, const measurement_type& z, belief_array<G>& out,
                         std::span<const state_range> states)
      const requires std::same_as<typename G::scalar_type, scalar_type> {
    if (params_.features != window_features::per_window ||
        params_.contrast != contrast_sign::as_is) {
      log_likelihood(grid, z, out);
      return;
    }
    check_grid(grid);
    const descriptor_matrix g = in_stored_basis(tactile_descriptors(z));
    constexpr Eigen::Index width = detail::descriptor_tiles<scalar_type>::width;
    detail::covering_tiles(states, width, grid.size(), tile_ranges_);
    for (const detail::tile_range& t : tile_ranges_) log_likelihood_tiles(g, out, t);
  }

  /// Tracking hook of `log_likelihood_both_signs`: blocks 0 and 1 of `out` at (at least) the
  /// states of `states` (ranges of one block, [0, grid.size())), bit for bit. The one-pass
  /// both_signs layout with per-window features and the exponential shape streams only the
  /// tiles that hold those states; otherwise the whole grid (exact, no saving).
  template <class G>
  void log_likelihood_both_signs_on(const G& grid, const measurement_type& z, scalar_type* out,
                                    std::span<const state_range> states)
      const requires std::same_as<typename G::scalar_type, scalar_type> {
    // The inverse shape's vectorised logarithm splits a block that does not start on a packet
    // boundary (block 1) differently than a range of it: the whole grid keeps it exact.
    if (!params_.both_signs || params_.features != window_features::per_window ||
        params_.shape != likelihood_shape::exponential) {
      log_likelihood_both_signs(grid, z, out);
      return;
    }
    detail::check_tactile_image("descriptor_likelihood", z, window_);
    check_grid(grid);
    const Eigen::Index n = grid.size();
    const descriptor_matrix* g = quantized_ ? nullptr : &stored_touch(z);
    const std::vector<detail::quantized_query>* q = quantized_ ? &sign_queries(z) : nullptr;
    const Eigen::Index half = basis_.half();
    constexpr Eigen::Index width = detail::descriptor_tiles<scalar_type>::width;
    detail::covering_tiles(states, width, n, tile_ranges_);
    for (const detail::tile_range& t : tile_ranges_) {
      scalar_type* plus = out + t.begin * width;
      scalar_type* minus = out + n + t.begin * width;
      if (quantized_)
        quantized_both_signs(*q, plus, minus, t);
      else
        for (Eigen::Index m = 0; m < patches_per_window(); ++m)
          detail::accumulate_sign_pair_tiles(per_window_[static_cast<std::size_t>(m)].values,
                                             &(*g)(0, m), half, plus, minus, m > 0, t);
      const state_range p = detail::tile_positions(t, width, n);
      for (Eigen::Index sign = 0; sign < 2; ++sign)
        to_log_likelihood(Eigen::Map<Eigen::Array<scalar_type, Eigen::Dynamic, 1>>(
            out + sign * n + p.begin, p.end - p.begin));
    }
  }

  /// Next-touch hook (filter/next_touch.hpp): the descriptors a noiseless touch would give at
  /// each of `states` (grid indices), as the model holds them — per-window features: the
  /// window's own (int8 storage decoded, the contrast basis kept: it is orthonormal, distances
  /// do not change); shared dense: the dense field at each patch's offset. Column i is state i,
  /// patch m in rows [m dimension(), (m + 1) dimension()).
  void window_descriptors(std::span<const Eigen::Index> states, Eigen::ArrayXXf& out) const {
    const Eigen::Index m_count = patches_per_window();
    const Eigen::Index dim = field_.values.rows();
    out.resize(dim * m_count, static_cast<Eigen::Index>(states.size()));
    for (std::size_t i = 0; i < states.size(); ++i) {
      const Eigen::Index q = states[i];
      TACMAP_ASSERT(q >= 0 && q < rows_ * cols_, "window_descriptors: state out of range");
      const auto col = static_cast<Eigen::Index>(i);
      for (Eigen::Index m = 0; m < m_count; ++m) {
        if (params_.features == window_features::per_window) {
          const window_patch& f = per_window_[static_cast<std::size_t>(m)];
          if (quantized_)
            for (Eigen::Index k = 0; k < dim; ++k)
              out(m * dim + k, col) =
                  static_cast<float>(f.quantized.at(q, k)) / detail::quantization_scale;
          else
            for (Eigen::Index k = 0; k < dim; ++k)
              out(m * dim + k, col) = static_cast<float>(f.values.at(q, k));
        } else {
          const grid_cell o = offsets_[static_cast<std::size_t>(m)];
          out.block(m * dim, col, dim, 1) =
              field_.at(q / cols_ + o.row, q % cols_ + o.col).template cast<float>();
        }
      }
    }
  }

  /// Next-touch hook: out(a, b) = log p(z_a | b), the touch z_a a noiseless one whose
  /// descriptors are column a of `touched`, at the window whose descriptors are column b of
  /// `at` (both from `window_descriptors`, of this model or one of the same configuration):
  /// eq. (1) with the model's pairing, then its shape and tempering. `either_per_patch` is
  /// scored as `as_is` (a noiseless touch has the map's sign).
  void predicted_log_likelihoods(const Eigen::ArrayXXf& touched, const Eigen::ArrayXXf& at,
                                 Eigen::ArrayXXf& out) const {
    const Eigen::Index m_count = patches_per_window();
    const Eigen::Index dim = field_.values.rows();
    TACMAP_ASSERT(touched.rows() == dim * m_count && at.rows() == dim * m_count,
                  "predicted_log_likelihoods: descriptors of another model");
    out.setZero(touched.cols(), at.cols());
    // ||t - s|| from ||t||^2 + ||s||^2 - 2 t.s: one matrix product per patch pair.
    const auto add_pair = [&](Eigen::Index mt, Eigen::Index ms) {
      const auto t = touched.middleRows(mt * dim, dim).matrix();
      const auto s = at.middleRows(ms * dim, dim).matrix();
      Eigen::MatrixXf d2 = -2.0F * (t.transpose() * s);
      d2.array().colwise() += t.colwise().squaredNorm().transpose().array();
      d2.array().rowwise() += s.colwise().squaredNorm().array();
      out += d2.array().max(0.0F).sqrt();
    };
    for (Eigen::Index m = 0; m < m_count; ++m) {
      if (params_.pairs == pairing::aligned)
        add_pair(m, m);
      else
        for (Eigen::Index n = 0; n < m_count; ++n) add_pair(n, m);
    }
    const auto temper = static_cast<float>(params_.tempering);
    if (params_.shape == likelihood_shape::inverse)
      out = -temper * (out + static_cast<float>(params_.epsilon)).log();
    else
      out *= -temper / static_cast<float>(params_.tau);
  }

 private:
  // log p(z | x) of the windows in tiles `t` (per-window features, contrast as_is; g: the
  // touch's descriptors in the stored basis): as per_window_distances then to_log_likelihood, on
  // these tiles only — the same kernel, register by register, so the same values bit for bit.
  template <class Array>
  void log_likelihood_tiles(const descriptor_matrix& g, Array& out,
                            const detail::tile_range& t) const {
    constexpr Eigen::Index width = detail::descriptor_tiles<scalar_type>::width;
    scalar_type* o = out.data() + t.begin * width;
    for (Eigen::Index m = 0; m < patches_per_window(); ++m) {
      const auto& f = per_window_[static_cast<std::size_t>(m)];
      if (params_.pairs == pairing::all_pairs)
        accumulate_on(f, g, 0, g.cols(), o, m > 0, t);
      else
        accumulate_on(f, g, m, 1, o, m > 0, t);
    }
    const state_range p = detail::tile_positions(t, width, out.size());
    to_log_likelihood(out.segment(p.begin, p.end - p.begin));
  }

  // Patch m of every window: as floats (descriptor_tiles) or, with `descriptor_storage::int8`,
  // as 7-bit integers; the overloads of accumulate, accumulate_on and distance_columns below
  // take either.
  struct window_patch {
    detail::descriptor_tiles<scalar_type> values;
    detail::quantized_tiles quantized;
  };
  static_assert(detail::quantized_tiles::width == detail::descriptor_tiles<float>::width,
                "tile ranges of the window descriptors mean the same states in both storages");

  // Quantised storage with both_signs: per patch m, the touch's patch m and its inversion (the
  // descriptor's contrast permutation of it: what describing max + min - z gives), quantised.
  // The map stays in its own basis: the sum/difference basis has negative elements, the
  // permutation costs a second multiply-add per byte instead.
  // In the model's memory (valid until the next call): a touch allocates nothing.
  [[nodiscard]] const std::vector<detail::quantized_query>& sign_queries(
      const measurement_type& z) const {
    const descriptor_matrix& g = stored_touch(z);  // quantised: the descriptor's own basis
    std::vector<detail::quantized_query>& q = sign_queries_;
    q.resize(static_cast<std::size_t>(g.cols()));
    descriptor_matrix& pair = sign_pair_;
    pair.resize(g.rows(), 2);
    for (Eigen::Index m = 0; m < g.cols(); ++m) {
      pair.col(0) = g.col(m);
      for (Eigen::Index k = 0; k < g.rows(); ++k)
        pair(k, 1) = g(permutation_[static_cast<std::size_t>(k)], m);
      q[static_cast<std::size_t>(m)].assign(pair);
    }
    return q;
  }

  // plus(q) (+)= || F_m(q) - g_m ||, minus(q) (+)= || F_m(q) - P g_m || summed over patches m,
  // on the tiles `t` (outputs relative to its first position).
  void quantized_both_signs(const std::vector<detail::quantized_query>& q, scalar_type* plus,
                            scalar_type* minus, const detail::tile_range& t) const {
    if constexpr (std::is_same_v<scalar_type, float>) {
      float* const outs[2] = {plus, minus};
      for (Eigen::Index m = 0; m < patches_per_window(); ++m)
        detail::quantized_distances(per_window_[static_cast<std::size_t>(m)].quantized,
                                    q[static_cast<std::size_t>(m)], outs, false, m > 0, t);
    }
  }

  // Distances of the columns [first, first + count) of g to the quantised patches `f`: summed
  // into out (all of them) or one output column each (`each`: out + j * stride).
  // `scratch`: where to quantise the query (the model's own on sequential paths, so that a touch
  // allocates nothing: 3-4 % of the default update went to malloc and its fresh vectors), or
  // null for a local one (the executor's chunks run this concurrently).
  void quantized_accumulate(const detail::quantized_tiles& f, const descriptor_matrix& g,
                            Eigen::Index first, Eigen::Index count, scalar_type* out,
                            Eigen::Index stride, bool sum, bool add, const detail::tile_range& t,
                            detail::quantized_query* scratch) const {
    if constexpr (std::is_same_v<scalar_type, float>) {
      // Quantised per call (a few hundred elements, next to the 8,000 windows' pass).
      detail::quantized_query local;
      detail::quantized_query& q = scratch != nullptr ? *scratch : local;
      q.assign(g.middleCols(first, count));
      constexpr std::size_t few = 8;
      float* fixed[few];
      std::vector<float*> many;
      const auto n = static_cast<std::size_t>(sum ? 1 : count);
      if (n > few) many.resize(n);
      float** outs = n > few ? many.data() : fixed;
      for (std::size_t j = 0; j < n; ++j) outs[j] = out + static_cast<Eigen::Index>(j) * stride;
      detail::quantized_distances(f, q, outs, sum, add, t);
    }
  }

  void accumulate(const window_patch& f, const descriptor_matrix& g, Eigen::Index first,
                  Eigen::Index count, scalar_type* out, bool add) const {
    if (quantized_)
      quantized_accumulate(f.quantized, g, first, count, out, 0, true, add, {}, &query_);
    else
      accumulate(f.values, g, first, count, out, add);
  }
  void accumulate_on(const window_patch& f, const descriptor_matrix& g, Eigen::Index first,
                     Eigen::Index count, scalar_type* out, bool add,
                     const detail::tile_range& t) const {
    if (quantized_)
      quantized_accumulate(f.quantized, g, first, count, out, 0, true, add, t, nullptr);
    else
      accumulate_on(f.values, g, first, count, out, add, t);
  }
  void distance_columns(const window_patch& f, const descriptor_matrix& g,
                        descriptor_matrix& dist) const {
    if (quantized_)
      quantized_accumulate(f.quantized, g, 0, g.cols(), dist.data(), dist.rows(), false, false, {},
                           &query_);
    else
      distance_columns(f.values, g, dist);
  }

  // Descriptors as columns, in the basis the map's descriptors are stored in: the contrast
  // basis with both_signs (float storage), else as they are.
  template <class Derived>
  [[nodiscard]] descriptor_matrix in_stored_basis(const Eigen::DenseBase<Derived>& columns) const {
    descriptor_matrix out = columns;
    if (stored_in_contrast_basis()) to_stored_basis(columns, out);
    return out;
  }
  [[nodiscard]] bool stored_in_contrast_basis() const { return params_.both_signs && !quantized_; }
  // out = the contrast basis of `columns`, column by column (out sized here; not aliased).
  template <class Derived>
  void to_stored_basis(const Eigen::DenseBase<Derived>& columns, descriptor_matrix& out) const {
    out.resize(columns.rows(), columns.cols());
    for (Eigen::Index j = 0; j < out.cols(); ++j) basis_.apply(columns.col(j), out.col(j));
  }

  // Distances -> eq. (2) or the exponential, times tempering, in place.
  template <class Array>
  void to_log_likelihood(Array&& d) const {
    const auto temper = static_cast<scalar_type>(params_.tempering);
    if (params_.shape == likelihood_shape::inverse)
      d = -temper * (d + static_cast<scalar_type>(params_.epsilon)).log();
    else
      d *= -temper / static_cast<scalar_type>(params_.tau);
  }

  template <class G>
  void check_grid(const G& grid) const {
    if (grid.rows() != rows_ || grid.cols() != cols_ || grid.size() != rows_ * cols_)
      detail::fail("descriptor_likelihood: the grid has ", grid.rows(), " x ", grid.cols(),
                   " states but the map and window give ", rows_, " x ", cols_,
                   "; build the grid and the model from the same map and window");
  }

  // out(q) (+)= sum over n in [first, first + count) of || F(q) - g_n ||, F position-major;
  // stored rather than added when !add.
  void accumulate(const detail::descriptor_tiles<scalar_type>& f, const descriptor_matrix& g,
                  Eigen::Index first, Eigen::Index count, scalar_type* out, bool add) const {
    if constexpr (euclidean_descriptor<Descriptor>) {
      detail::accumulate_distances(f, g, first, count, out, add);
    } else {
      Eigen::Array<scalar_type, Eigen::Dynamic, 1> column(f.dimension());
      for (Eigen::Index q = 0; q < f.positions(); ++q) {
        for (Eigen::Index k = 0; k < f.dimension(); ++k) column(k) = f.at(q, k);
        if (!add) out[q] = 0;
        for (Eigen::Index n = first; n < first + count; ++n)
          out[q] += descriptor_.distance(column, g.col(n));
      }
    }
  }

  // `accumulate` on the tiles `t` only, `out` pointing at their first position.
  void accumulate_on(const detail::descriptor_tiles<scalar_type>& f, const descriptor_matrix& g,
                     Eigen::Index first, Eigen::Index count, scalar_type* out, bool add,
                     const detail::tile_range& t) const {
    if constexpr (euclidean_descriptor<Descriptor>) {
      detail::accumulate_distances_tiles(f, g, first, count, out, add, t);
    } else {
      constexpr Eigen::Index width = detail::descriptor_tiles<scalar_type>::width;
      const state_range p = detail::tile_positions(t, width, f.positions());
      Eigen::Array<scalar_type, Eigen::Dynamic, 1> column(f.dimension());
      for (Eigen::Index q = p.begin; q < p.end; ++q) {
        for (Eigen::Index k = 0; k < f.dimension(); ++k) column(k) = f.at(q, k);
        scalar_type& o = out[q - p.begin];
        if (!add) o = 0;
        for (Eigen::Index n = first; n < first + count; ++n)
          o += descriptor_.distance(column, g.col(n));
      }
    }
  }

  // `inverted` (either_per_patch, aligned): the inverted touch's descriptors, else null.
  void per_window_distances(const descriptor_matrix& g, const descriptor_matrix* inverted,
                            Eigen::Array<scalar_type, Eigen::Dynamic, 1>& out) const {
    if (inverted != nullptr) {
      per_window_either(g, *inverted, out);
      return;
    }
    for (Eigen::Index m = 0; m < patches_per_window(); ++m) {
      const auto& f = per_window_[static_cast<std::size_t>(m)];
      if (params_.pairs == pairing::all_pairs)
        accumulate(f, g, 0, g.cols(), out.data(), m > 0);
      else
        accumulate(f, g, m, 1, out.data(), m > 0);
    }
  }

  // either_per_patch, per window: for each patch m, the distances of every window's patch m to
  // g_m and to g'_m (two columns, one pass over the windows' descriptors), then their minimum.
  void per_window_either(const descriptor_matrix& g, const descriptor_matrix& inverted,
                         Eigen::Array<scalar_type, Eigen::Dynamic, 1>& out) const {
    const Eigen::Index positions = rows_ * cols_;
    auto& dist = workspace_;
    dist.resize(positions, 2);
    auto& pair = signs_;
    pair.resize(g.rows(), 2);
    for (Eigen::Index m = 0; m < patches_per_window(); ++m) {
      const auto& f = per_window_[static_cast<std::size_t>(m)];
      pair.col(0) = g.col(m);
      pair.col(1) = inverted.col(m);
      distance_columns(f, pair, dist);
      if (m == 0)
        out = dist.col(0).min(dist.col(1));
      else
        out += dist.col(0).min(dist.col(1));
    }
  }

  // dist.col(n) = || F(q) - g_n || for every descriptor n of g, for the leading f.positions()
  // entries of each column (dist must have at least that many rows and g.cols() columns).
  void distance_columns(const detail::descriptor_tiles<scalar_type>& f, const descriptor_matrix& g,
                        descriptor_matrix& dist) const {
    if constexpr (euclidean_descriptor<Descriptor>) {
      detail::squared_norms(g, g_norms_);  // one pass over f, g.cols() outputs:
      detail::distances_each(f, g, g_norms_.data(), dist.data(), dist.rows());
    } else {
      for (Eigen::Index n = 0; n < g.cols(); ++n) accumulate(f, g, n, 1, &dist(0, n), false);
    }
  }

  // `inverted` (either_per_patch, aligned): the inverted touch's descriptors, else null.
  void shared_distances(const descriptor_matrix& g, const descriptor_matrix* inverted,
                        Eigen::Array<scalar_type, Eigen::Dynamic, 1>& out) const {
    const Eigen::Index m_count = patches_per_window();
    const Eigen::Index positions = field_.rows * field_.cols;
    // all pairs: one column S = sum_n D_n; aligned: one column D_n per tactile patch. Only the
    // leading field_tiles_.positions() entries are computed and read (see the constructor).
    auto& dist = workspace_;
    if (params_.pairs == pairing::all_pairs) {
      dist.resize(positions, 1);
      accumulate(field_tiles_, g, 0, m_count, dist.data(), false);
    } else if (inverted == nullptr) {
      dist.resize(positions, m_count);
      distance_columns(field_tiles_, g, dist);
    } else {
      // Both signs in one pass over the field: columns D_n (touch) then D'_n (inverted touch),
      // and D_n becomes min(D_n, D'_n) — what the block additions below read.
      auto& both = signs_;
      both.resize(g.rows(), 2 * m_count);
      both << g, *inverted;
      dist.resize(positions, 2 * m_count);
      distance_columns(field_tiles_, both, dist);
      const Eigen::Index used = field_tiles_.positions();
      for (Eigen::Index n = 0; n < m_count; ++n)
        dist.col(n).head(used) = dist.col(n).head(used).min(dist.col(m_count + n).head(used));
    }
    // sum_m sum_n D_n(x + o_m) = sum_m S(x + o_m); aligned: sum_m D_m(x + o_m).
    const bool summed = params_.pairs == pairing::all_pairs;
    windows_from_columns(
        dist, [&](Eigen::Index m) { return summed ? 0 : m; }, out.data());
  }

  // Shared dense features: every window's distance as the sum over its patches m of the dense
  // distance column `column(m)` of `dist`, read at the window's position shifted by patch m's
  // offset (the field is field_.rows x field_.cols, row-major, in each column); into `out`
  // (rows_ x cols_, row-major).
  template <class Column>
  void windows_from_columns(const descriptor_matrix& dist, Column column, scalar_type* out) const {
    Eigen::Map<image<scalar_type>> d(out, rows_, cols_);
    for (Eigen::Index m = 0; m < patches_per_window(); ++m) {
      const Eigen::Map<const image<scalar_type>> dn(&dist(0, column(m)), field_.rows, field_.cols);
      const grid_cell o = offsets_[static_cast<std::size_t>(m)];
      if (m == 0)
        d = dn.block(o.row, o.col, rows_, cols_);
      else
        d += dn.block(o.row, o.col, rows_, cols_);
    }
  }

  Descriptor descriptor_;
  descriptor_likelihood_params params_;
  pixel_size window_;
  std::vector<grid_cell> offsets_;
  Eigen::Index rows_ = 0;  // states down
  Eigen::Index cols_ = 0;  // states across
  descriptor_field<scalar_type> field_;
  detail::descriptor_tiles<scalar_type> field_tiles_;  // field_ tiled (shared_dense only)
  std::vector<window_patch> per_window_;               // patch m of every window
  bool quantized_ = false;                             // descriptor_storage::int8 applies
  std::uint64_t clamped_ = 0;                          // map elements clamped by quantisation
  std::vector<Eigen::Index> permutation_;  // quantised both_signs: the contrast permutation
  mutable detail::quantized_query query_;  // the touch quantised, on sequential paths
  // stored_touch: the touch as scalar_type, its descriptors (and in the stored basis), and the
  // descriptor's memory for describing it.
  mutable image<scalar_type> touch_image_;
  mutable descriptor_matrix touch_, touch_basis_;
  mutable detail::touch_scratch<Descriptor> touch_scratch_;
  mutable std::vector<detail::quantized_query> sign_queries_;  // quantised both_signs
  mutable descriptor_matrix sign_pair_;                        // sign_queries: patch m, +-
  // Per-touch distances, kept between calls so that log_likelihood() does not allocate. This
  // makes one model object non-reentrant: give each thread its own filter.
  mutable Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> workspace_;
  mutable std::vector<scalar_type> g_norms_;  // the tactile descriptors' squared norms
  // either_per_patch: a touch's and its inversion's descriptors side by side (kept, like
  // workspace_, so that a measurement does not allocate them).
  mutable descriptor_matrix signs_;
  mutable descriptor_matrix patch_columns_;  // log_likelihood_each: patch m of every image
  detail::contrast_basis basis_;  // both_signs: the basis the map's descriptors are stored in
  mutable std::vector<detail::tile_range> tile_ranges_;  // log_likelihood_on: tiles to stream
  executor_ref executor_;                                // empty: sequential (set_executor)
};

// The heavy members, defined out of the class: not inline, so that where tacmap::precompiled
// declares an instantiation `extern template` (tacmap/precompiled.hpp) the compiler does not
// instantiate them again for inlining. (Not being inline, an instantiation on a type local to a
// translation unit that leaves one unused would be reported by -Wunused-function.)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"

template <descriptor Descriptor>
descriptor_likelihood<Descriptor>::descriptor_likelihood(Descriptor descriptor,
                                                         const image<float>& map, pixel_size window,
                                                         descriptor_likelihood_params params)
    : descriptor_(std::move(descriptor)), params_(params), window_(window) {
  params.validate();
  const Eigen::Index p = descriptor_.patch_size();
  offsets_ = detail::checked_patch_offsets("descriptor_likelihood", map, window, p, params.spacing);
  if constexpr (byte_quantizable_descriptor<Descriptor> && std::is_same_v<scalar_type, float>)
    quantized_ = params.storage == descriptor_storage::int8 &&
                 params.features == window_features::per_window;
  {
    // Refused before allocating (issue 14, "Bad input"): the dense field and its tiled copy,
    // and per window M descriptors of every window — 1.4 GB for classic SIFT on 640 x 480.
    const auto dim = static_cast<std::uint64_t>(descriptor_.dimension());
    const auto field_count = detail::saturating_product(map.rows() - p + 1, map.cols() - p + 1);
    const auto windows =
        detail::saturating_product(map.rows() - window.height + 1, map.cols() - window.width + 1);
    // The field, and its tiled copy for shared_dense.
    const std::uint64_t field_bytes =
        detail::saturating_product(params.features == window_features::shared_dense ? 2 : 1,
                                   field_count, dim, sizeof(scalar_type));
    const std::uint64_t window_bytes =
        params.features != window_features::per_window ? 0
        : quantized_
            ? detail::saturating_product(windows, offsets_.size(),
                                         detail::quantized_tiles::bytes_per_position(dim))
            : detail::saturating_product(windows, offsets_.size(), dim, sizeof(scalar_type));
    const std::uint64_t total = window_bytes > ~std::uint64_t{0} - field_bytes
                                    ? ~std::uint64_t{0}
                                    : field_bytes + window_bytes;
    std::ostringstream what;
    what << "the map's dense descriptors (" << field_count << " x " << dim << " values"
         << (params.features == window_features::shared_dense ? ", twice)" : ")");
    if (window_bytes > 0)
      what << " and the per-window descriptors (" << windows << " windows x " << offsets_.size()
           << " patches x " << dim << (quantized_ ? " bytes" : " values") << ")";
    detail::check_memory("descriptor_likelihood", what.str(), total,
                         "use a coarser map (fewer mm per px means more states), "
                         "window_features::shared_dense (no per-window copies), or a machine "
                         "with more memory");
  }
  const image<scalar_type> map_t = map.template cast<scalar_type>();
  field_ = descriptor_.compute(map_t);
  detail::check_field(descriptor_, field_, map.rows(), map.cols(), "the map");
  // Windows read field rows [0, rows_ + max offset row) only (the patches' offsets grow down
  // the window): the kernel skips the rest (6 of 103 rows for the paper's map).
  Eigen::Index last_offset_row = 0;
  for (const grid_cell& o : offsets_) last_offset_row = std::max(last_offset_row, o.row);
  const Eigen::Index used_rows = (map.rows() - window.height + 1) + last_offset_row;
  if (params.both_signs) {
    if constexpr (contrast_symmetric_descriptor<Descriptor>) {
      basis_ = detail::contrast_basis(descriptor_.contrast_permutation());
      permutation_ = descriptor_.contrast_permutation();
      if (basis_.dimension() != descriptor_.dimension())
        detail::fail("descriptor_likelihood: the descriptor's contrast_permutation() has ",
                     basis_.dimension(), " elements but its dimension() is ",
                     descriptor_.dimension(), "; expected one entry per descriptor element");
    } else {
      detail::fail(
          "descriptor_likelihood_params: both_signs = true, but this descriptor has no "
          "contrast_permutation() (what inverting the contrast does to its values); "
          "use both_signs = false (appearance_likelihood then scores each sign in its "
          "own pass)");
    }
  }
  // The field tiled for the kernel: read by shared_dense only (per_window reads its own tiles;
  // skipping it is 11 % of preparing the default model). Without the basis, straight from the
  // field: no 5 MB copy of it.
  if (params.features == window_features::shared_dense) {
    if (params.both_signs)
      field_tiles_ = detail::descriptor_tiles<scalar_type>(
          in_stored_basis(field_.values.leftCols(used_rows * field_.cols)));
    else
      field_tiles_ =
          detail::descriptor_tiles<scalar_type>(field_.values.leftCols(used_rows * field_.cols));
  }
  rows_ = map.rows() - window.height + 1;
  cols_ = map.cols() - window.width + 1;
  if (params.features == window_features::per_window) {
    // One extraction per window, as for a tactile image; patch m of window i goes to column i
    // of per_window_[m].
    const Eigen::Index m_count = patches_per_window();
    const Eigen::Index dim = field_.values.rows();
    per_window_.clear();  // each built in place: no copies of 4 MB of zeros
    per_window_.reserve(static_cast<std::size_t>(m_count));
    for (Eigen::Index m = 0; m < m_count; ++m) {  // every window is set below
      if (quantized_)
        per_window_.push_back({{}, detail::quantized_tiles(rows_ * cols_, dim)});
      else
        per_window_.push_back(
            {detail::descriptor_tiles<scalar_type>(
                 rows_ * cols_, dim, detail::descriptor_tiles<scalar_type>::for_overwrite),
             {}});
    }
    descriptor_matrix column(dim, 1);  // both_signs: one window patch
    // Quantised storage: windows q0 .. of patch m from float columns (both_signs or not: the
    // quantised map stays in the descriptor's own basis, see sign_queries).
    const auto quantize = [&](Eigen::Index m, Eigen::Index q0, const auto& columns) {
      auto& tiles = per_window_[static_cast<std::size_t>(m)].quantized;
      const std::uint64_t before = tiles.clamped();
      if (!tiles.set_columns(q0, columns)) {
        // -infinity is below zero too: name a non-finite value as such first.
        detail::check_descriptors(descriptor_, columns, columns.cols(), "a window of the map");
        detail::fail(
            "descriptor_likelihood: descriptor_storage::int8 stores non-negative "
            "descriptor elements (SIFT histograms), but a window's patch ",
            m,
            " has a negative element; use descriptor_storage::float32 for this "
            "descriptor");
      }
      clamped_ += tiles.clamped() - before;
    };
    if constexpr (describes_windows<Descriptor>) {
      // The same descriptors from work the windows share (dense_sift: 178 -> 8.2 ms for
      // classic_sift on 120 px, issue 14), a row of windows at a time; patch m of the row's
      // windows is every M-th column of the block.
      descriptor_matrix basis_row;
      descriptor_.describe_windows(
          map_t, window, std::span<const grid_cell>(offsets_),
          [&](Eigen::Index r, const descriptor_matrix& block) {
            constexpr const char* what = "a row of the map's windows (describe_windows)";
            // int8 storage: the quantiser counts NaN and infinities among the elements it
            // clamps, so the values are scanned again only where it clamped, instead of read a
            // second time (that read was 5-8 % of preparing the paper's map).
            if (quantized_)
              detail::check_descriptor_shape(descriptor_, block, cols_ * m_count, what);
            else
              detail::check_descriptors(descriptor_, block, cols_ * m_count, what);
            const std::uint64_t clamped_before = clamped_;
            for (Eigen::Index m = 0; m < m_count; ++m) {
              const Eigen::Map<const descriptor_matrix, 0, Eigen::OuterStride<>> patch(
                  block.data() + m * dim, dim, cols_, Eigen::OuterStride<>(m_count * dim));
              auto& tiles = per_window_[static_cast<std::size_t>(m)].values;
              if (quantized_) {
                quantize(m, r * cols_, patch);
              } else if (params.both_signs) {
                basis_row.resize(dim, cols_);
                for (Eigen::Index c = 0; c < cols_; ++c)
                  basis_.apply(patch.col(c), basis_row.col(c));
                tiles.set_columns(r * cols_, basis_row);
              } else {
                tiles.set_columns(r * cols_, patch);
              }
            }
            if (clamped_ != clamped_before)
              detail::check_descriptors(descriptor_, block, cols_ * m_count, what);
          });
      return;
    }
    image<scalar_type> cut(window.height, window.width);
    for (Eigen::Index r = 0; r < rows_; ++r)
      for (Eigen::Index c = 0; c < cols_; ++c) {
        cut = map_t.block(r, c, window.height, window.width);
        const auto wf = descriptor_.compute(cut);
        detail::check_field(descriptor_, wf, window.height, window.width, "a window of the map");
        for (Eigen::Index m = 0; m < m_count; ++m) {
          const grid_cell o = offsets_[static_cast<std::size_t>(m)];
          if (quantized_) {
            column.col(0) = wf.at(o.row, o.col);
            quantize(m, r * cols_ + c, column);
          } else if (params.both_signs) {
            basis_.apply(wf.at(o.row, o.col), column.col(0));
            per_window_[static_cast<std::size_t>(m)].values.set(r * cols_ + c, column.col(0));
          } else {
            per_window_[static_cast<std::size_t>(m)].values.set(r * cols_ + c, wf.at(o.row, o.col));
          }
        }
      }
  }
}

#pragma GCC diagnostic pop
}  // namespace tacmap

// Compiled once in tacmap::precompiled where it is linked (tacmap/precompiled.hpp): the model with
// SIFT-lite and classic SIFT, and the planar filters of the Gaussian odometry model with them.
#include "tacmap/precompiled.hpp"
#ifdef TACMAP_EXTERN_TEMPLATE
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"
namespace tacmap {
TACMAP_EXTERN_TEMPLATE class descriptor_likelihood<sift_lite>;
TACMAP_EXTERN_TEMPLATE class descriptor_likelihood<classic_sift>;
TACMAP_EXTERN_TEMPLATE void descriptor_likelihood<sift_lite>::log_likelihood(
    const planar_grid<float>&, const image<float>&, Eigen::ArrayXf&) const;
TACMAP_EXTERN_TEMPLATE void descriptor_likelihood<classic_sift>::log_likelihood(
    const planar_grid<float>&, const image<float>&, Eigen::ArrayXf&) const;
TACMAP_EXTERN_FILTER_CORE(planar_grid<float>, odometry_gaussian);
TACMAP_EXTERN_FILTER(planar_grid<float>, odometry_gaussian, descriptor_likelihood<sift_lite>);
TACMAP_EXTERN_FILTER(planar_grid<float>, odometry_gaussian, descriptor_likelihood<classic_sift>);
}  // namespace tacmap
#endif
