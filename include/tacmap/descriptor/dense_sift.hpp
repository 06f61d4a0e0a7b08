// tacmap: dense SIFT descriptors, including the paper's 32-element "SIFT-lite" (Sec. III-C, IV-A).
//
// The paper drops SIFT's scale space and keypoint detection and computes descriptors densely,
// with a "sub-patch size of 18 and a grid spacing of 9": the parameters of Lazebnik's dense SIFT
// (spatial-pyramid code, Torralba's convolution form). This header implements that descriptor
// for any number of spatial bins and orientations; see reference/dense-sift.md for the facts.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <span>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include "tacmap/descriptor/concept.hpp"
#include "tacmap/descriptor/detail/dense_sift_kernels.hpp"
#include "tacmap/descriptor/detail/dense_sift_windows.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/image.hpp"

namespace tacmap {

/// Parameters of `dense_sift`. Defaults: Lazebnik's dense SIFT with the paper's patch 18 and
/// spacing 9 (Sec. IV-A). A configured value: `dense_sift` validates it on construction.
struct dense_sift_params {
  /// Side, px, of the square patch one descriptor describes. Must be even (the grid starts at
  /// patch/2) and a multiple of the number of spatial bins per side (bins are patch/num_bins px).
  Eigen::Index patch_size = 18;
  /// Pixels between neighbouring grid points of `dense_sift::sample` (`compute` uses stride 1).
  Eigen::Index grid_spacing = 9;
  /// Standard deviation, px, of the derivative-of-Gaussian gradient filters (4*ceil(sigma)+1
  /// taps). In (0, 64].
  double sigma_edge = 1.0;
  /// Sharpness of the soft orientation assignment max(0, cos(theta - a_k))^alpha. Positive.
  double alpha = 9.0;
  /// Descriptors whose L2 norm exceeds this are normalised; weaker ones (flat areas) are kept
  /// as they are. >= 0; +infinity switches normalisation off (raw pooled gradient energy).
  double norm_threshold = 1.0;
  /// Clamp applied to a unit-normalised descriptor before it is renormalised. Positive.
  double clamp = 0.2;

  friend bool operator==(const dense_sift_params&, const dense_sift_params&) = default;
};

/// Descriptors at the points of a regular grid of patches (what `dense_sift::sample` returns).
///
/// Grid point (i, j) is the patch whose top-left pixel is (i * spacing, j * spacing); its
/// descriptor is column i * cols + j of `values` (one descriptor per column, like
/// `descriptor_field`). For the paper's 42 x 18 tactile image, patch 18 and spacing 9: rows = 3,
/// cols = 1, top-left rows 0, 9, 18.
template <class T>
struct descriptor_samples {
  Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic> values;  ///< dimension x (rows * cols)
  Eigen::Index rows = 0;                                   ///< grid points down the image
  Eigen::Index cols = 0;                                   ///< grid points across the image
  Eigen::Index spacing = 0;                                ///< pixels between grid points

  /// The descriptor of grid point (i, j).
  [[nodiscard]] auto at(Eigen::Index i, Eigen::Index j) const { return values.col(i * cols + j); }
  /// Number of grid points.
  [[nodiscard]] Eigen::Index size() const { return rows * cols; }
  /// Top-left pixel row of grid row i's patches: i * spacing.
  [[nodiscard]] Eigen::Index top_left_row(Eigen::Index i) const { return i * spacing; }
  /// Top-left pixel column of grid column j's patches: j * spacing.
  [[nodiscard]] Eigen::Index top_left_col(Eigen::Index j) const { return j * spacing; }
};

/// Dense SIFT with `NumBins` x `NumBins` spatial bins and `NumAngles` orientations: Lazebnik's
/// dense SIFT, as named by the paper's parameters (Sec.\ III-C; reference/dense-sift.md).
///
/// **Pipeline** (on the whole image, never per patch):
///  1. The image is divided by its maximum (by its largest magnitude if it has negative values,
///     so the gradient never flips). Once per image, not per patch: `compute` on a map and
///     `sample` on a tactile image each see their whole image scaled to a peak of 1, as the
///     paper's preprocessing does for tactile frames. An all-zero or constant image has no
///     gradient and gives all-zero descriptors.
///  2. Gradients by derivative-of-Gaussian filters (sigma_edge, 4*ceil(sigma_edge)+1 taps, each
///     derivative kernel scaled to absolute sum 2) on the image padded with 2 mirrored pixels per
///     side, the padded image's mean subtracted (zero beyond the padding).
///  3. theta = atan2(gy, gx), x to the right and y **down** (rows): theta = 0 points right,
///     pi/2 points down. The gradient points towards brighter pixels. (Lazebnik's MATLAB applies
///     the kernels with `filter2`, a correlation, which negates both derivatives: its channel k
///     is our channel (k + NumAngles/2) mod NumAngles. Distances between descriptors of one
///     convention are unaffected.)
///  4. Channel k (centre a_k = 2 pi k / NumAngles) = magnitude * max(0, cos(theta - a_k))^alpha.
///  5. Spatial pooling: each channel is filtered with the separable triangular kernel of
///     Lazebnik's code (its `patch` taps, conv2 'same'), bins of q = patch/NumBins px; the
///     channels are zero outside the image. Along each axis, bin b of the patch with top-left t
///     pools pixel t + b*q + d, d in [1 - patch/2, patch/2], with weight
///     max(0, 1 - |d - 1.5| / q): a triangle of half-width q centred at t + 1.5 + b*q. For
///     q = 4 (`classic_sift`'s 16 px patch, Lazebnik's default) these are the nominal bin
///     centres; for q = 9 (`sift_lite`) the bins sit 2.5 px up-left of them and reach 7 px
///     above/left of the patch (and 1 px below/right), with the kernel's last tap on the far
///     side cut off. That is the reference's semantics, kept as is.
///  6. Element order: bins outer, column-major over the bin grid (bin row fastest, as MATLAB's
///     (:) of its sample meshgrid), angles inner: element_index(by, bx, k) =
///     k + NumAngles * (by + NumBins * bx), by the bin row (down), bx the bin column (right).
///  7. Normalisation "that respects flat areas": a descriptor whose L2 norm exceeds
///     norm_threshold (1) becomes unit length, is clamped at `clamp` (0.2) and renormalised;
///     a weaker one is left unnormalised, so near-empty tactile regions stay near zero instead
///     of amplifying noise.
///
/// **Positions.** `compute` returns every patch position at stride 1: column r * cols + c of the
/// field is the patch with top-left pixel (r, c). `sample` returns the patches with top-left
/// (i * grid_spacing, j * grid_spacing) for every one that fits in the image; each is the
/// `compute` column of the same top-left (the same whole-image computation, only the pooled
/// values it needs; equal up to the last bits of rounding). The patch
/// centre (the paper's "key point") is at top-left + (patch - 1)/2 in pixel coordinates (pixel
/// centres at integers); Lazebnik's 1-based grid coordinate patch/2 + i*spacing is the pixel just
/// above-left of it. Lazebnik's grid bound (size - patch/2 + 1) admits one more point, whose
/// patch would overhang the image by a pixel, when (size - patch + 1) is a multiple of the
/// spacing; `sample` leaves that point out so that every sample is a `compute` column.
/// `describe_at` returns the patches of any list of top-lefts (off-grid, repeated), each the
/// `compute` column of the same top-left, computing channels only where their pooling reaches.
///
/// **Cost.** Orientation channels and separable filters, O(pixels x NumAngles x taps) for all
/// patches at once. On one AVX2 core (-O3 -march=x86-64-v3) the paper's 120 x 120 map takes
/// about 0.3 ms for `sift_lite` (10,609 descriptors) and 0.55 ms for `classic_sift`; a 42 x 18
/// tactile image's three descriptors about 8 us (bench/descriptor_bench.cpp).
///
/// `compute`, `sample` and `describe_at` are const and keep no state between calls: one object
/// can serve several threads.
template <int NumBins, int NumAngles, class T = float>
class dense_sift {
  static_assert(NumBins >= 1, "dense_sift needs at least one spatial bin per side");
  static_assert(NumAngles >= 1, "dense_sift needs at least one orientation channel");
  static_assert(belief_scalar<T>, "dense_sift computes in float or double");

 public:
  using scalar_type = T;
  /// A read-only descriptor column.
  using column = Eigen::Ref<const Eigen::Array<T, Eigen::Dynamic, 1>>;
  static constexpr int num_bins = NumBins;
  static constexpr int num_angles = NumAngles;
  /// Elements of one descriptor: NumBins^2 * NumAngles (32 for sift_lite, 128 for classic).
  static constexpr int descriptor_size = NumBins * NumBins * NumAngles;
  /// `distance` is the Euclidean norm of the difference: measurement models may use
  /// ||a||^2 - 2 a.b + ||b||^2 over whole fields instead of calling it pair by pair.
  static constexpr bool euclidean_distance = true;
  /// Elements >= 0, and <= 0.5 but in descriptors with at most 3 strong bins (normalised,
  /// clamped, renormalised): descriptor_storage::int8 applies (concept.hpp, H5).
  static constexpr bool byte_quantizable = true;

  /// The default configuration: the paper's patch 18 and spacing 9 when 18 is an even multiple
  /// of NumBins (sift_lite); otherwise the largest such patch <= 18 with spacing 9 (16 for
  /// classic_sift: 4 px bins, Lazebnik's own default patch, and still three descriptors on the
  /// paper's 42 x 18 tactile image).
  [[nodiscard]] static dense_sift_params default_params() {
    dense_sift_params p;
    const Eigen::Index step = NumBins % 2 == 0 ? NumBins : 2 * NumBins;
    p.patch_size = std::max(step, (18 / step) * step);
    return p;
  }

  /// The default configuration (`default_params()`).
  dense_sift() : dense_sift(default_params()) {}

  /// Validates `params`; throws `std::invalid_argument` naming the offending value.
  explicit dense_sift(const dense_sift_params& params) : params_(params) {
    validate(params);
    bin_ = params.patch_size / NumBins;
    gradient_ = detail::dsift::make_gradient_taps<T>(params.sigma_edge);
    pooling_ = detail::dsift::make_pooling_taps<T>(params.patch_size, bin_);
    for (int k = 0; k < NumAngles; ++k) {
      const double a = 2.0 * std::numbers::pi * k / NumAngles;
      cos_a_(k) = static_cast<T>(std::cos(a));
      sin_a_(k) = static_cast<T>(std::sin(a));
    }
  }

  [[nodiscard]] const dense_sift_params& params() const noexcept { return params_; }
  [[nodiscard]] Eigen::Index dimension() const noexcept { return descriptor_size; }
  [[nodiscard]] Eigen::Index patch_size() const noexcept { return params_.patch_size; }
  [[nodiscard]] Eigen::Index grid_spacing() const noexcept { return params_.grid_spacing; }
  /// Side of one spatial bin, px: patch_size / NumBins.
  [[nodiscard]] Eigen::Index bin_size() const noexcept { return bin_; }

  /// Position of (bin row `by`, bin column `bx`, orientation `angle`) in a descriptor.
  [[nodiscard]] static constexpr Eigen::Index element_index(Eigen::Index by, Eigen::Index bx,
                                                            Eigen::Index angle) noexcept {
    return angle + NumAngles * (by + NumBins * bx);
  }
  /// What inverting the image's contrast does to a descriptor: element i of the descriptor of
  /// (max + min - image) is element perm[i] of the image's descriptor. Every gradient turns by
  /// half a turn, so channel k of each bin becomes channel k + NumAngles / 2; the image scale
  /// (step 1 of the pipeline: division by the maximum) is the same for both when the image is
  /// non-negative, and the normalise-and-clamp step commutes with a permutation. An involution
  /// without fixed points: `descriptor_likelihood` (`both_signs`) uses it to match both
  /// contrast signs in one pass.
  [[nodiscard]] static std::vector<Eigen::Index> contrast_permutation() requires(NumAngles % 2 ==
                                                                                 0) {
    std::vector<Eigen::Index> perm(static_cast<std::size_t>(descriptor_size));
    for (Eigen::Index bx = 0; bx < NumBins; ++bx)
      for (Eigen::Index by = 0; by < NumBins; ++by)
        for (Eigen::Index k = 0; k < NumAngles; ++k)
          perm[static_cast<std::size_t>(element_index(by, bx, k))] =
              element_index(by, bx, (k + NumAngles / 2) % NumAngles);
    return perm;
  }
  /// Centre angle of orientation channel k, radians (y down: pi/2 points down the image).
  [[nodiscard]] static double channel_angle(Eigen::Index k) noexcept {
    return 2.0 * std::numbers::pi * static_cast<double>(k) / NumAngles;
  }

  /// Descriptors of every patch position at stride 1 (the `descriptor` concept's member): column
  /// r * cols + c is the patch with top-left pixel (r, c); rows = H - patch + 1,
  /// cols = W - patch + 1. Throws `std::invalid_argument` when `img` is smaller than a patch or
  /// not finite.
  [[nodiscard]] descriptor_field<T> compute(const image_view<T>& img) const {
    descriptor_field<T> field;
    workspace scratch;
    compute(img, field, scratch);
    return field;
  }

 private:
  /// `compute` after the orientation channels: pooled rows from `pool` (called with increasing
  /// rows), assembled and normalised one patch row at a time.
  template <class Pooler>
  void compute_rows(Pooler& pool, Eigen::Index h, Eigen::Index w, Eigen::Index nx,
                    descriptor_field<T>& field) const {
    const Eigen::Index ring_rows = (NumBins - 1) * bin_ + 1;
    const Eigen::Index row_size = nx * NumAngles;
    Eigen::Array<T, Eigen::Dynamic, 1> ring(ring_rows * row_size);
    const auto slot = [ring_rows](Eigen::Index y) { return y % ring_rows; };

    field.rows = h - params_.patch_size + 1;
    field.cols = w - params_.patch_size + 1;
    field.values.resize(descriptor_size, field.rows * field.cols);
    detail::dsift::advise_huge_pages(field.values.data(),
                                     static_cast<std::size_t>(field.values.size()) * sizeof(T));
    // With whole-register bins, each pooled pixel's squared norm is kept beside the ring and the
    // descriptors are assembled and normalised in one pass (detail::dsift::
    // assemble_normalise_simd); the padding (zeros) covers the last register's reads.
    constexpr bool fused = detail::dsift::simd_assemble<NumAngles, T>;
    using arch = detail::kernel_arch<T>;
    const Eigen::Index square_size = nx + static_cast<Eigen::Index>(xsimd::batch<T, arch>::size);
    Eigen::Array<T, Eigen::Dynamic, 1> squares =
        Eigen::Array<T, Eigen::Dynamic, 1>::Zero(fused ? ring_rows * square_size : 0);

    Eigen::Index next = 0;  // the next pooled row to compute
    for (Eigen::Index r = 0; r < field.rows; ++r) {
      for (; next < r + ring_rows; ++next) {
        pool(next, ring.data() + slot(next) * row_size);
        if constexpr (fused) {
          detail::dsift::pixel_square_norms_simd<arch, NumAngles>(
              ring.data() + slot(next) * row_size, nx, squares.data() + slot(next) * square_size);
        }
      }
      const auto rows = bin_rows(ring.data(), row_size, r, slot);
      T* out = field.values.col(r * field.cols).data();
      if constexpr (fused) {
        detail::dsift::assemble_normalise_simd<arch, NumBins, NumAngles>(
            rows.data(), bin_rows(squares.data(), square_size, r, slot).data(), bin_, field.cols,
            static_cast<T>(params_.norm_threshold), static_cast<T>(params_.clamp), out);
      } else {
        for (Eigen::Index c = 0; c < field.cols; ++c) {
          assemble(rows, c, field.values.col(r * field.cols + c).data());
        }
        // One row of patches at a time, while it is still in cache.
        normalise(out, field.cols);
      }
    }
  }

 public:
  /// Scratch memory `describe_at`, `compute` and `sample` can reuse between calls (one per
  /// thread). Why: the orientation channels of a 46 x 46 canvas take 128 KB, glibc serves
  /// blocks that large straight from the OS, and the fresh pages' faults cost more than
  /// computing the channels (measured: 50 us per call allocating, 13 us reusing). It also keeps
  /// the gradient buffers (no allocation per call) and, for images of the size it last saw, the
  /// channels' zero margins (not cleared again: 62 KB per 46 x 46 canvas). Together 9 % of the
  /// pose model's 36 canvases per touch.
  struct workspace {
    Eigen::Array<T, Eigen::Dynamic, 1> channels;
    // The image size and margin whose zero margins `channels` holds (nothing writes them).
    Eigen::Index zeroed_rows = -1, zeroed_cols = -1, zeroed_margin = -1;
    Eigen::Array<T, Eigen::Dynamic, 1> gx, gy;
    std::vector<detail::dsift::column_span> spans;
    detail::dsift::span_gradient_scratch<T> gradients;
    // sample: the pooled rows the grid reads, and where each image row's lands (-1: unused).
    Eigen::Array<T, Eigen::Dynamic, 1> pooled;
    std::vector<Eigen::Index> slots;
  };

  /// Number of grid points (rows = down, cols = across) `sample` gives on an image of `size`:
  /// floor((H - patch) / spacing) + 1 by floor((W - patch) / spacing) + 1, or 0 x 0 when the
  /// image is smaller than a patch.
  [[nodiscard]] pixel_size sample_grid_size(pixel_size size) const noexcept {
    const Eigen::Index p = params_.patch_size;
    const Eigen::Index s = params_.grid_spacing;
    if (size.width < p || size.height < p) return {0, 0};
    return {(size.width - p) / s + 1, (size.height - p) / s + 1};
  }

  /// Descriptors of the patches on the grid_spacing grid (Sec.\ III-C: a tactile image gives
  /// "three overlapped sub-images", one descriptor each). Grid point (i, j) is the patch with
  /// top-left (i * grid_spacing, j * grid_spacing); see `descriptor_samples`. Only the pooled
  /// values those patches need are computed. Throws `std::invalid_argument` when the image is
  /// smaller than a patch (no patch fits) or not finite.
  [[nodiscard]] descriptor_samples<T> sample(const image_view<T>& img) const {
    workspace scratch;
    descriptor_samples<T> out;
    sample(img, scratch, out);
    return out;
  }

  /// `sample(img)` into `out`, reusing its memory and `scratch`'s: for a caller describing
  /// many images of one size (every touch of a tactile sensor), no allocation after the first
  /// but the pooling's own buffers. The same descriptors as `sample(img)`, bit for bit. Throws
  /// as `sample(img)` does, with `out` then unspecified.
  void sample(const image_view<T>& img, workspace& scratch, descriptor_samples<T>& out) const {
    check_image(img, "sample");
    const Eigen::Index h = img.rows();
    const Eigen::Index w = img.cols();
    const Eigen::Index s = params_.grid_spacing;
    const pixel_size grid = sample_grid_size({w, h});
    Eigen::Array<T, Eigen::Dynamic, 1>& channels = scratch.channels;
    const T top = with_zero_margins(h, w, scratch, [&](bool zeroed) {
      return orientation_channels(img, channels, scratch.gx, scratch.gy, zeroed,
                                  &scratch.gradients);
    });

    // The pooled rows the grid's bins read, and where each lands in `pooled` (-1: unused).
    std::vector<Eigen::Index>& slot = scratch.slots;
    slot.assign(static_cast<std::size_t>(h), -1);
    for (Eigen::Index i = 0; i < grid.height; ++i) {
      for (Eigen::Index by = 0; by < NumBins; ++by) {
        slot[static_cast<std::size_t>(i * s + by * bin_)] = 0;
      }
    }
    Eigen::Index n_rows = 0;
    for (Eigen::Index& k : slot) {
      if (k == 0) k = n_rows++;
    }
    const Eigen::Index nx = (grid.width - 1) * s + (NumBins - 1) * bin_ + 1;
    const Eigen::Index row_size = nx * NumAngles;
    Eigen::Array<T, Eigen::Dynamic, 1>& pooled = scratch.pooled;
    pooled.resize(n_rows * row_size);
    // The same pooling as `compute`'s, so that every sample is a `compute` column.
    const auto pool_rows = [&](auto& pool) {
      for (Eigen::Index y = 0; y < h; ++y) {
        const Eigen::Index k = slot[static_cast<std::size_t>(y)];
        if (k >= 0) pool(y, pooled.data() + k * row_size);
      }
    };
    bool pooled_exactly = false;
    if constexpr (std::is_same_v<T, float>) {
      if (detail::dsift::box_pooler<NumAngles>::applies(pooling_, bin_, margin())) {
        detail::dsift::box_pooler<NumAngles> pool(pooling_, channels.data(), h, w, margin(), bin_,
                                                  nx, top);
        pool_rows(pool);
        pooled_exactly = true;
      }
    }
    if (!pooled_exactly) {
      detail::dsift::row_pooler<NumAngles, T> pool(pooling_, channels.data(), w, margin(), 0, nx);
      pool_rows(pool);
    }

    out.rows = grid.height;
    out.cols = grid.width;
    out.spacing = s;
    out.values.resize(descriptor_size, out.rows * out.cols);
    for (Eigen::Index i = 0; i < out.rows; ++i) {
      const auto rows = bin_rows(pooled.data(), row_size, i * s, [&slot](Eigen::Index y) {
        return slot[static_cast<std::size_t>(y)];
      });
      for (Eigen::Index j = 0; j < out.cols; ++j) {
        assemble(rows, j * s, out.values.col(i * out.cols + j).data());
      }
    }
    normalise(out.values.data(), out.values.cols());
  }

  /// Descriptors of the patches whose top-left pixels are `top_left` (columns, in order), equal to
  /// compute(img).at(r, c) for each (within 1e-5; the same whole-image orientation channels and
  /// the same sums, only the NumBins^2 pooled values each patch needs). For a few patches at
  /// arbitrary positions, e.g. a rotated tactile image's three sub-images: the cost is the
  /// orientation channels of the image plus a few thousand vector FMAs per patch, not the
  /// pooling of every position. Positions may repeat. An empty list gives a dimension() x 0
  /// array. Throws `std::invalid_argument` when the image is smaller than a patch or not finite
  /// (as `compute`), or when a patch does not lie inside the image.
  [[nodiscard]] Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic> describe_at(
      const image_view<T>& img, std::span<const grid_cell> top_left) const {
    workspace scratch;
    return describe_at(img, top_left, scratch);
  }

  /// `compute(img)` into `field`, reusing its memory and `scratch`'s: for a caller describing
  /// many images of one size (camera frames, a map prepared again), no allocation after the
  /// first. Fresh memory is what a new field costs most at camera resolution: at 640 x 480 the
  /// kernel zeroing its 37 MB of new pages took a quarter of `compute(img)` (profile, issue 14).
  /// The same descriptors as `compute(img)`, bit for bit. Throws as `compute(img)` does, with
  /// `field` then unspecified.
  void compute(const image_view<T>& img, descriptor_field<T>& field, workspace& scratch) const {
    check_image(img, "compute");
    const Eigen::Index h = img.rows();
    const Eigen::Index w = img.cols();
    // The channels' margins are cleared only when the workspace has not seen this size (the
    // whole-image pass writes every pixel inside them, never the margins; 2 % of a 120 px
    // field).
    Eigen::Array<T, Eigen::Dynamic, 1>& channels = scratch.channels;
    const T top = with_zero_margins(h, w, scratch, [&](bool zeroed) {
      return orientation_channels(img, channels, scratch.gx, scratch.gy, zeroed,
                                  &scratch.gradients);
    });

    // Bin b of the patch at top-left t samples the pooled channels at t + b * bin, for every
    // row and column in [0, size - bin]. A patch row needs pooled rows r .. r + (NumBins-1)*bin:
    // a ring of that many rows (about 44 KB for sift_lite on 120 px) instead of all of them.
    const Eigen::Index nx = w - bin_ + 1;
    // Float with the default kernels: exact running box sums (detail::dsift::box_pooler);
    // otherwise one weighted sum per tap.
    if constexpr (std::is_same_v<T, float>) {
      if (detail::dsift::box_pooler<NumAngles>::applies(pooling_, bin_, margin())) {
        detail::dsift::box_pooler<NumAngles> pool(pooling_, channels.data(), h, w, margin(), bin_,
                                                  nx, top);
        compute_rows(pool, h, w, nx, field);
        return;
      }
    }
    detail::dsift::row_pooler<NumAngles, T> pool(pooling_, channels.data(), w, margin(), 0, nx);
    compute_rows(pool, h, w, nx, field);
  }

  /// `describe_at` reusing `scratch`'s memory.
  [[nodiscard]] Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic> describe_at(
      const image_view<T>& img, std::span<const grid_cell> top_left, workspace& scratch) const {
    check_image(img, "describe_at");
    const Eigen::Index last_row = img.rows() - params_.patch_size;
    const Eigen::Index last_col = img.cols() - params_.patch_size;
    for (std::size_t i = 0; i < top_left.size(); ++i) {
      const grid_cell p = top_left[i];
      if (p.row < 0 || p.row > last_row || p.col < 0 || p.col > last_col) {
        detail::fail<std::invalid_argument>(
            "dense_sift::describe_at: top_left[", i, "] = (row ", p.row, ", col ", p.col,
            ") puts the ", params_.patch_size, " x ", params_.patch_size, " px patch outside the ",
            img.rows(), " x ", img.cols(),
            " px image (rows x cols); expected 0 <= row <= ", last_row,
            " and 0 <= col <= ", last_col, " (image size - patch_size)");
      }
    }
    const auto n = static_cast<Eigen::Index>(top_left.size());
    Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic> out(descriptor_size, n);
    if (n == 0) return out;
    // Only the channel pixels the patches' pooling taps reach: per image row, the hull of the
    // column ranges of the patches whose taps reach that row (about half of a rotation canvas).
    const auto lo = pooling_.front().offset;
    const auto hi = (NumBins - 1) * bin_ + pooling_.back().offset;
    std::vector<detail::dsift::column_span>& spans = scratch.spans;
    spans.assign(static_cast<std::size_t>(img.rows()), {img.cols(), 0});
    for (const grid_cell p : top_left) {
      const Eigen::Index x0 = std::max<Eigen::Index>(p.col + lo, 0);
      const Eigen::Index x1 = std::min(p.col + hi + 1, img.cols());
      const Eigen::Index y1 = std::min(p.row + hi + 1, img.rows());
      for (Eigen::Index y = std::max<Eigen::Index>(p.row + lo, 0); y < y1; ++y) {
        auto& sp = spans[static_cast<std::size_t>(y)];
        sp.begin = std::min(sp.begin, x0);
        sp.end = std::max(sp.end, x1);
      }
    }
    Eigen::Array<T, Eigen::Dynamic, 1>& channels = scratch.channels;
    span_channels(img, spans, scratch);
    detail::dsift::patch_pooler<NumBins, NumAngles, T> pool(pooling_, channels.data(), img.cols(),
                                                            margin(), bin_);
    for (Eigen::Index i = 0; i < n; ++i) {
      const grid_cell p = top_left[static_cast<std::size_t>(i)];
      pool(p.row, p.col, out.col(i).data());
    }
    normalise(out.data(), n);
    return out;
  }

  /// H4 (descriptor/concept.hpp): the descriptors of the patches at `offsets` (top-left pixels
  /// inside a window) of every `window`-sized window of `map`, each what `compute` gives on the
  /// window cut from the map: for each window row r = 0 .. map rows - window height, in order,
  /// calls sink(r, block) with block(descriptor_size x cols * M), column c * M + m = patch m of
  /// the window with top-left (r, c), cols = map cols - window width + 1, M = offsets.size().
  /// Equal to compute(map.block(r, c, h, w)).at(offsets[m].row, offsets[m].col) within 1e-5.
  ///
  /// Not one extraction per window: from shared intermediates (detail/dense_sift_windows.hpp).
  /// The window's division by its peak is a factor on its pooled values; its mirrored padding
  /// only changes pixels within 2 px of its border, whose stencils depend on where in the window
  /// they are, not on the window; and its zero outside is which taps each bin keeps, the same
  /// for every window. So the channels and pooled sums are computed once per map and each
  /// window's patches are a few weighted rows of them (issue 14; measured in
  /// bench/measurement_bench.cpp, `classic_sift_map_precompute`). Falls back to the per-window
  /// extraction where that reasoning does not hold: sigma_edge > 1 (filters wider than the
  /// mirrored padding, which then reach the padded image's mean), windows narrower than 4 px,
  /// and single windows whose peak is below 2^-24 of the map's (the shared channels would lose
  /// precision in float there).
  ///
  /// Throws `std::invalid_argument` when the map is smaller than a patch or not finite (as
  /// `compute`), the window is empty or larger than the map, or a patch at an offset does not
  /// lie inside the window.
  template <class Sink>
  void describe_windows(const image_view<T>& map, pixel_size window,
                        std::span<const grid_cell> offsets, Sink&& sink) const {
    check_image(map, "describe_windows");
    check_windows(map, window, offsets);
    const Eigen::Index rows = map.rows() - window.height + 1;
    const Eigen::Index cols = map.cols() - window.width + 1;
    const auto m_count = static_cast<Eigen::Index>(offsets.size());
    Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic> block(descriptor_size, cols * m_count);
    const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& done = block;
    const auto from_cut = [&](Eigen::Index r, Eigen::Index c) {  // the reference path
      const descriptor_field<T> f = compute(map.block(r, c, window.height, window.width));
      for (Eigen::Index m = 0; m < m_count; ++m) {
        const grid_cell o = offsets[static_cast<std::size_t>(m)];
        block.col(c * m_count + m) = f.at(o.row, o.col);
      }
    };
    constexpr Eigen::Index frame = detail::dsift::mirror_pad;
    if (m_count == 0 || gradient_.radius != frame || !detail::dsift::antisymmetric(gradient_) ||
        window.height < 2 * frame || window.width < 2 * frame) {
      for (Eigen::Index r = 0; r < rows; ++r) {
        for (Eigen::Index c = 0; c < cols; ++c) from_cut(r, c);
        sink(r, done);
      }
      return;
    }
    // Pipeline step 1 as a factor: the map's channels are of map / (map peak); a window's are
    // (map peak / window peak) times those.
    const T map_peak = peak(map);
    const image<T> scaled = map / map_peak;
    const image<T> window_peak = detail::dsift::window_peaks<T>(map, window);
    constexpr T precision_limit = T(16777216);  // 2^24
    detail::dsift::window_pooler<NumBins, NumAngles, T> pool(
        scaled, window, offsets, bin_, gradient_, pooling_, cos_a_, sin_a_, params_.alpha);
    std::vector<Eigen::Index> cut;
    std::vector<T> factor(static_cast<std::size_t>(cols));
    for (Eigen::Index r = 0; r < rows; ++r) {
      cut.clear();
      for (Eigen::Index c = 0; c < cols; ++c) {
        const T s = window_peak(r, c);
        // An all-zero window has zero channels: factor 0 keeps it zero (`compute` gives zeros).
        const T f = s > T(0) ? map_peak / s : T(0);
        if (f > precision_limit) cut.push_back(c);
        factor[static_cast<std::size_t>(c)] = f;
      }
      pool(r, factor.data(), block.data());
      normalise(block.data(), cols * m_count);
      for (const Eigen::Index c : cut) from_cut(r, c);
      sink(r, done);
    }
  }

  /// Euclidean distance between two descriptors (the paper's eq.\ (1) sums these). Throws
  /// `std::invalid_argument` when a column's length is not `dimension()`.
  [[nodiscard]] T distance(column a, column b) const {
    if (a.size() != descriptor_size || b.size() != descriptor_size) {
      detail::fail<std::invalid_argument>("dense_sift::distance: descriptors of length ", a.size(),
                                          " and ", b.size(), " given, expected ", descriptor_size,
                                          " each; pass columns of this descriptor's output");
    }
    return (a - b).matrix().norm();
  }

 private:
  static void validate(const dense_sift_params& p) {
    using detail::fail;
    if (p.patch_size <= 0 || p.patch_size > 65536) {
      fail<std::invalid_argument>("dense_sift: patch_size = ", p.patch_size,
                                  " px, expected a positive even size up to 65536 px (the paper "
                                  "uses 18)");
    }
    if (p.patch_size % NumBins != 0) {
      fail<std::invalid_argument>(
          "dense_sift: patch_size = ", p.patch_size,
          " px is not a multiple of num_bins = ", NumBins,
          ", so the spatial bins would not have a whole number of pixels; use a multiple"
          " of ",
          NumBins, " (default_params() gives ", default_params().patch_size, ")");
    }
    if (p.patch_size % 2 != 0) {
      fail<std::invalid_argument>("dense_sift: patch_size = ", p.patch_size,
                                  " px is odd; the grid starts at patch_size / 2, so use an "
                                  "even multiple of num_bins = ",
                                  NumBins);
    }
    if (p.grid_spacing <= 0) {
      fail<std::invalid_argument>("dense_sift: grid_spacing = ", p.grid_spacing,
                                  " px, expected a positive spacing (the paper uses 9)");
    }
    if (!(p.sigma_edge > 0.0 && p.sigma_edge <= 64.0)) {
      fail<std::invalid_argument>("dense_sift: sigma_edge = ", p.sigma_edge,
                                  " px, expected 0 < sigma_edge <= 64 (the default is 1)");
    }
    if (!(p.alpha > 0.0 && std::isfinite(p.alpha))) {
      fail<std::invalid_argument>("dense_sift: alpha = ", p.alpha,
                                  ", expected a finite positive exponent (the default is 9)");
    }
    if (!(p.norm_threshold >= 0.0)) {
      fail<std::invalid_argument>("dense_sift: norm_threshold = ", p.norm_threshold,
                                  ", expected >= 0 (1 by default; +infinity disables "
                                  "normalisation)");
    }
    if (!(p.clamp > 0.0)) {
      fail<std::invalid_argument>("dense_sift: clamp = ", p.clamp,
                                  ", expected a positive clamp (the default is 0.2)");
    }
  }

  void check_image(const image_view<T>& img, const char* what) const {
    const Eigen::Index p = params_.patch_size;
    if (img.rows() < p || img.cols() < p) {
      detail::fail<std::invalid_argument>(
          "dense_sift::", what, ": the image is ", img.rows(), " x ", img.cols(),
          " px (rows x cols), smaller than one ", p, " x ", p,
          " px patch; pass an image at least patch_size in both directions or use a smaller "
          "patch_size");
    }
    // x * 0 is NaN exactly for NaN and infinite x, so the sum is 0 iff every pixel is finite:
    // one vectorised pass in the image's row order (isFinite().all() walks it column by column,
    // one pixel at a time, longer than a few patches' descriptors take).
    if (!((img * T(0)).sum() == T(0))) {
      detail::fail<std::invalid_argument>("dense_sift::", what, ": the ", img.rows(), " x ",
                                          img.cols(),
                                          " image holds NaN or infinite pixels; replace them "
                                          "(e.g. by 0) before extracting descriptors");
    }
  }

  void check_windows(const image_view<T>& map, pixel_size window,
                     std::span<const grid_cell> offsets) const {
    if (window.width <= 0 || window.height <= 0 || window.width > map.cols() ||
        window.height > map.rows()) {
      detail::fail<std::invalid_argument>(
          "dense_sift::describe_windows: the window is ", window.width, " x ", window.height,
          " px (width x height) and the map ", map.cols(), " x ", map.rows(),
          "; expected a positive window no larger than the map");
    }
    const Eigen::Index last_row = window.height - params_.patch_size;
    const Eigen::Index last_col = window.width - params_.patch_size;
    for (std::size_t i = 0; i < offsets.size(); ++i) {
      const grid_cell o = offsets[i];
      if (o.row < 0 || o.row > last_row || o.col < 0 || o.col > last_col) {
        detail::fail<std::invalid_argument>(
            "dense_sift::describe_windows: offsets[", i, "] = (row ", o.row, ", col ", o.col,
            ") puts the ", params_.patch_size, " x ", params_.patch_size, " px patch outside the ",
            window.height, " x ", window.width,
            " px window (rows x cols); expected 0 <= row <= ", last_row,
            " and 0 <= col <= ", last_col, " (window size - patch_size)");
      }
    }
  }

  /// What the image is divided by (pipeline step 1): its largest magnitude, or 1 for an
  /// all-zero image (no gradient, zero descriptors, no NaN).
  [[nodiscard]] static T peak(const image_view<T>& img) {
    const T scale = img.abs().maxCoeff();
    return scale > T(0) ? scale : T(1);
  }

  /// The orientation channels of `img` (layout of detail::dsift::orientation_channels); returns
  /// their largest value.
  T orientation_channels(const image_view<T>& img,
                         Eigen::Array<T, Eigen::Dynamic, 1>& channels) const {
    Eigen::Array<T, Eigen::Dynamic, 1> gx;
    Eigen::Array<T, Eigen::Dynamic, 1> gy;
    return orientation_channels(img, channels, gx, gy);
  }
  /// `gradients`: the gradient passes' buffers to reuse (null: their own).
  T orientation_channels(const image_view<T>& img, Eigen::Array<T, Eigen::Dynamic, 1>& channels,
                         Eigen::Array<T, Eigen::Dynamic, 1>& gx,
                         Eigen::Array<T, Eigen::Dynamic, 1>& gy, bool margins_zero = false,
                         detail::dsift::span_gradient_scratch<T>* gradients = nullptr) const {
    const Eigen::Index stride =
        gradients != nullptr
            ? detail::dsift::gradients(img, peak(img), gradient_, gx, gy, *gradients)
            : detail::dsift::gradients(img, peak(img), gradient_, gx, gy);
    return detail::dsift::orientation_channels<NumAngles>(gx, gy, img.rows(), img.cols(), stride,
                                                          margin(), cos_a_, sin_a_, params_.alpha,
                                                          channels, nullptr, margins_zero);
  }

  /// `orientation_channels` at the columns spans[y] of each row y, into scratch.channels, all
  /// through the workspace's memory (no allocation once it has seen an image of this size).
  void span_channels(const image_view<T>& img, const std::vector<detail::dsift::column_span>& spans,
                     workspace& scratch) const {
    const Eigen::Index stride = detail::dsift::gradients(img, peak(img), gradient_, spans,
                                                         scratch.gx, scratch.gy, scratch.gradients);
    with_zero_margins(img.rows(), img.cols(), scratch, [&](bool zeroed) {
      return detail::dsift::orientation_channels<NumAngles>(
          scratch.gx, scratch.gy, img.rows(), img.cols(), stride, margin(), cos_a_, sin_a_,
          params_.alpha, scratch.channels, spans.data(), zeroed);
    });
  }

  /// Returns `fill(zeroed)`, which writes scratch.channels for an h x w image but never its
  /// margins, told whether they are known zero already, and keeps the workspace's record of
  /// it. The margins are known zero only for the very buffer that had them cleared: same layout
  /// and still that size (a moved-from workspace has them cleared again); unknown while `fill`
  /// runs, so an exception leaves them unknown.
  template <class Fill>
  auto with_zero_margins(Eigen::Index h, Eigen::Index w, workspace& scratch,
                         const Fill& fill) const {
    const Eigen::Index size = (h + 2 * margin()) * (w + 2 * margin()) * NumAngles;
    const bool zeroed = scratch.zeroed_rows == h && scratch.zeroed_cols == w &&
                        scratch.zeroed_margin == margin() && scratch.channels.size() == size;
    scratch.zeroed_rows = scratch.zeroed_cols = scratch.zeroed_margin = -1;
    const auto result = fill(zeroed);
    scratch.zeroed_rows = h;
    scratch.zeroed_cols = w;
    scratch.zeroed_margin = margin();
    return result;
  }

  /// Zero pixels around the channels: the pooling taps reach patch/2 px from a sample point.
  [[nodiscard]] Eigen::Index margin() const noexcept { return params_.patch_size / 2; }

  using bin_row_pointers = std::array<const T*, static_cast<std::size_t>(NumBins)>;

  /// Copies the NumBins^2 pooled orientation vectors of the patch whose top-left column is c
  /// into `out` (element_index order). rows[by] is the pooled row of bin row by.
  void assemble(const bin_row_pointers& rows, Eigen::Index c, T* out) const {
    using angles = Eigen::Array<T, NumAngles, 1>;
    for (Eigen::Index bx = 0; bx < NumBins; ++bx) {
      for (Eigen::Index by = 0; by < NumBins; ++by) {
        const T* src = rows[static_cast<std::size_t>(by)] + (c + bx * bin_) * NumAngles;
        Eigen::Map<angles>(out + element_index(by, bx, 0)) = Eigen::Map<const angles>(src);
      }
    }
  }

  /// The pooled rows of bin rows 0 .. NumBins-1 for the patches of top-left row r.
  template <class Slot>
  bin_row_pointers bin_rows(const T* pooled, Eigen::Index row_size, Eigen::Index r,
                            const Slot& slot) const {
    bin_row_pointers rows{};
    for (Eigen::Index by = 0; by < NumBins; ++by) {
      rows[static_cast<std::size_t>(by)] = pooled + slot(r + by * bin_) * row_size;
    }
    return rows;
  }

  /// Normalises `count` consecutive descriptors in place.
  void normalise(T* data, Eigen::Index count) const {
    detail::dsift::normalise<descriptor_size>(data, count, static_cast<T>(params_.norm_threshold),
                                              static_cast<T>(params_.clamp));
  }

  dense_sift_params params_;
  Eigen::Index bin_ = 1;
  detail::dsift::gradient_taps<T> gradient_;
  std::vector<detail::dsift::pooling_tap<T>> pooling_;
  Eigen::Array<T, NumAngles, 1> cos_a_;
  Eigen::Array<T, NumAngles, 1> sin_a_;
};

/// The paper's descriptor (Sec. III-C): 2 x 2 bins x 8 orientations = 32 elements.
using sift_lite = dense_sift<2, 8>;
/// Classic SIFT layout: 4 x 4 bins x 8 orientations = 128 elements (default patch 16).
using classic_sift = dense_sift<4, 8>;

static_assert(descriptor<sift_lite>);
static_assert(descriptor<classic_sift>);
static_assert(descriptor<dense_sift<2, 8, double>>);
static_assert(describes_windows<sift_lite>);

}  // namespace tacmap

// Compiled once in tacmap::precompiled where it is linked (tacmap/precompiled.hpp).
#include "tacmap/precompiled.hpp"
#ifdef TACMAP_EXTERN_TEMPLATE
namespace tacmap {
TACMAP_EXTERN_TEMPLATE class dense_sift<2, 8, float>;
TACMAP_EXTERN_TEMPLATE class dense_sift<4, 8, float>;
}  // namespace tacmap
#endif
