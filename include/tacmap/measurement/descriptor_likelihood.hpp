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
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>
#include <stdexcept>
#include <utility>
#include <vector>

#include "tacmap/descriptor/concept.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/image.hpp"
#include "tacmap/measurement/concept.hpp"
#include "tacmap/measurement/detail/distance_kernel.hpp"

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
  /// The paper's way (Sec. III-C, "the same approach is also applied to the visual images"):
  /// every window is cut from the map and described on its own, exactly like a tactile image —
  /// same image borders, same normalisation. Precompute: one descriptor extraction per window
  /// (once per map); per touch: M descriptors per window to compare.
  per_window,
  /// Descriptors computed once, densely, over the whole map and shared by overlapping windows:
  /// far cheaper per touch, but a window's patch sees the map around the window (real
  /// neighbours, the whole map's normalisation) where the tactile image sees its own borders.
  shared_dense,
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
  double epsilon = 1e-3;   ///< inverse: added to d so that d = 0 is finite
  double tau = 1.0;        ///< exponential: temperature, in distance units
  double tempering = 1.0;  ///< exponent on the likelihood, >= 0

  /// The paper's configuration: all pairs (eq. (1)), inverse likelihood (eq. (2)), per window.
  [[nodiscard]] static descriptor_likelihood_params paper() {
    descriptor_likelihood_params p;
    p.pairs = pairing::all_pairs;
    p.shape = likelihood_shape::inverse;
    return p;
  }

  void validate() const {
    if (spacing <= 0)
      detail::fail("descriptor_likelihood_params: spacing = ", spacing,
                   "; expected a positive number of pixels between tactile patches (paper: 9)");
    if (!(std::isfinite(epsilon) && epsilon > 0.0))
      detail::fail("descriptor_likelihood_params: epsilon = ", epsilon,
                   "; expected a finite guard > 0 (eq. (2) is unbounded as d -> 0)");
    if (!(std::isfinite(tau) && tau > 0.0))
      detail::fail("descriptor_likelihood_params: tau = ", tau, "; expected a finite value > 0");
    if (!(std::isfinite(tempering) && tempering >= 0.0))
      detail::fail("descriptor_likelihood_params: tempering = ", tempering,
                   "; expected a finite exponent >= 0");
  }
};

/// Descriptors whose `distance` is the Euclidean norm opt into the vectorised whole-array
/// distance path by declaring `static constexpr bool euclidean_distance = true;` (others are
/// called through `distance()` once per pair).
template <class D>
concept euclidean_descriptor = descriptor<D> && requires {
  requires D::euclidean_distance;
};

/// Descriptors that can also describe only the patches on their own spacing grid (top-left at
/// multiples of `grid_spacing()`, row-major), as `dense_sift::sample` does: the tactile side then
/// skips the positions it does not use. Column order must be row-major over that grid.
template <class D>
concept samples_on_grid = descriptor<D> &&
    requires(const D& d, const image<typename D::scalar_type>& img) {
  { d.grid_spacing() } -> std::same_as<Eigen::Index>;
  {
    d.sample(img).values
    } -> std::convertible_to<Eigen::Array<typename D::scalar_type, Eigen::Dynamic, Eigen::Dynamic>>;
};

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

/// Checks a tactile image against the model's window: its size, then its pixels.
inline void check_tactile_image(const char* who, const image<float>& z, pixel_size window) {
  if (z.rows() != window.height || z.cols() != window.width)
    fail(who, ": tactile image is ", z.rows(), " x ", z.cols(), " px (rows x cols); expected ",
         window.height, " x ", window.width,
         " (the sensor window at map scale, in the sensor's own frame — preprocess the frame "
         "first)");
  if (!all_finite(z)) fail(who, ": the tactile image contains NaN or infinite pixels");
}

}  // namespace detail

/// The paper's measurement model over a `planar_grid`, for any `descriptor`.
template <descriptor Descriptor>
class descriptor_likelihood {
 public:
  using scalar_type = typename Descriptor::scalar_type;
  using measurement_type = image<float>;  ///< preprocessed tactile image at map scale

  /// Computes the map's dense descriptors once. `window` is the tactile image's size in map
  /// pixels (the grid's window). Throws std::invalid_argument when the map is smaller than the
  /// window, or the descriptor's patch and the spacing do not fit the window.
  descriptor_likelihood(Descriptor descriptor, const image<float>& map, pixel_size window,
                        descriptor_likelihood_params params = {})
      : descriptor_(std::move(descriptor)), params_(params), window_(window) {
    params.validate();
    const Eigen::Index p = descriptor_.patch_size();
    offsets_ =
        detail::checked_patch_offsets("descriptor_likelihood", map, window, p, params.spacing);
    const image<scalar_type> map_t = map.template cast<scalar_type>();
    field_ = descriptor_.compute(map_t);
    TACMAP_ASSERT(field_.rows == map.rows() - p + 1 && field_.cols == map.cols() - p + 1,
                  "descriptor::compute returned a field of the wrong shape");
    // Windows read field rows [0, rows_ + max offset row) only (the patches' offsets grow down
    // the window): the kernel skips the rest (6 of 103 rows for the paper's map).
    Eigen::Index last_offset_row = 0;
    for (const grid_cell& o : offsets_) last_offset_row = std::max(last_offset_row, o.row);
    const Eigen::Index used_rows = (map.rows() - window.height + 1) + last_offset_row;
    field_tiles_ =
        detail::descriptor_tiles<scalar_type>(field_.values.leftCols(used_rows * field_.cols));
    rows_ = map.rows() - window.height + 1;
    cols_ = map.cols() - window.width + 1;
    if (params.features == window_features::per_window) {
      // One extraction per window, as for a tactile image; patch m of window i goes to column i
      // of per_window_[m].
      const Eigen::Index m_count = patches_per_window();
      per_window_.assign(
          static_cast<std::size_t>(m_count),
          detail::descriptor_tiles<scalar_type>(rows_ * cols_, field_.values.rows()));
      image<scalar_type> cut(window.height, window.width);
      for (Eigen::Index r = 0; r < rows_; ++r)
        for (Eigen::Index c = 0; c < cols_; ++c) {
          cut = map_t.block(r, c, window.height, window.width);
          const auto wf = descriptor_.compute(cut);
          for (Eigen::Index m = 0; m < m_count; ++m) {
            const grid_cell o = offsets_[static_cast<std::size_t>(m)];
            per_window_[static_cast<std::size_t>(m)].set(r * cols_ + c, wf.at(o.row, o.col));
          }
        }
    }
  }

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

  /// The M descriptors of a tactile image (dimension x M), in patch order.
  [[nodiscard]] Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> tactile_descriptors(
      const measurement_type& z) const {
    detail::check_tactile_image("descriptor_likelihood", z, window_);
    const image<scalar_type> zt = z.template cast<scalar_type>();
    Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> g;
    // A descriptor that can describe just its spacing grid (dense_sift::sample) saves most of the
    // tactile extraction: 3 of the 25 patch positions of a 42 x 18 image are needed.
    if constexpr (samples_on_grid<Descriptor>) {
      if (descriptor_.grid_spacing() == params_.spacing) {
        const auto samples = descriptor_.sample(zt);
        TACMAP_ASSERT(samples.size() == patches_per_window(),
                      "descriptor::sample returned the wrong number of patches");
        g = samples.values;  // grid order = offsets_ order (row-major, same spacing)
        return g;
      }
    }
    const auto zf = descriptor_.compute(zt);
    g.resize(zf.values.rows(), patches_per_window());
    for (Eigen::Index m = 0; m < patches_per_window(); ++m)
      g.col(m) = zf.at(offsets_[static_cast<std::size_t>(m)].row,
                       offsets_[static_cast<std::size_t>(m)].col);
    return g;
  }

  /// The distance d(x, z) of eq. (1) for every state (row-major grid order).
  template <class G>
  void distances(const G& grid, const measurement_type& z, belief_array<G>& out)
      const requires std::same_as<typename G::scalar_type, scalar_type> {
    if (grid.rows() != rows_ || grid.cols() != cols_ || grid.size() != rows_ * cols_)
      detail::fail("descriptor_likelihood: the grid has ", grid.rows(), " x ", grid.cols(),
                   " states but the map and window give ", rows_, " x ", cols_,
                   "; build the grid and the model from the same map and window");
    const auto g = tactile_descriptors(z);
    if (params_.features == window_features::per_window)
      per_window_distances(g, out);
    else
      shared_distances(g, out);
  }

  /// log p(z | x) for every state: eq. (1) then eq. (2) or the exponential, times tempering.
  template <class G>
  void log_likelihood(const G& grid, const measurement_type& z, belief_array<G>& out)
      const requires std::same_as<typename G::scalar_type, scalar_type> {
    distances(grid, z, out);
    const auto temper = static_cast<scalar_type>(params_.tempering);
    if (params_.shape == likelihood_shape::inverse)
      out = -temper * (out + static_cast<scalar_type>(params_.epsilon)).log();
    else
      out *= -temper / static_cast<scalar_type>(params_.tau);
  }

 private:
  using descriptor_matrix = Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic>;

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

  void per_window_distances(const descriptor_matrix& g,
                            Eigen::Array<scalar_type, Eigen::Dynamic, 1>& out) const {
    for (Eigen::Index m = 0; m < patches_per_window(); ++m) {
      const auto& f = per_window_[static_cast<std::size_t>(m)];
      if (params_.pairs == pairing::all_pairs)
        accumulate(f, g, 0, g.cols(), out.data(), m > 0);
      else
        accumulate(f, g, m, 1, out.data(), m > 0);
    }
  }

  void shared_distances(const descriptor_matrix& g,
                        Eigen::Array<scalar_type, Eigen::Dynamic, 1>& out) const {
    const Eigen::Index m_count = patches_per_window();
    const Eigen::Index positions = field_.rows * field_.cols;
    // all pairs: one column S = sum_n D_n; aligned: one column D_n per tactile patch. Only the
    // leading field_tiles_.positions() entries are computed and read (see the constructor).
    auto& dist = workspace_;
    dist.resize(positions, params_.pairs == pairing::all_pairs ? 1 : m_count);
    if (params_.pairs == pairing::all_pairs) {
      accumulate(field_tiles_, g, 0, m_count, dist.data(), false);
    } else if constexpr (euclidean_descriptor<Descriptor>) {
      detail::squared_norms(g, g_norms_);  // one pass over the field, M outputs:
      detail::distances_each(field_tiles_, g, g_norms_.data(), dist.data(), positions);
    } else {
      for (Eigen::Index n = 0; n < m_count; ++n)
        accumulate(field_tiles_, g, n, 1, &dist(0, n), false);
    }
    Eigen::Map<image<scalar_type>> d(out.data(), rows_, cols_);
    for (Eigen::Index m = 0; m < m_count; ++m) {
      // sum_m sum_n D_n(x + o_m) = sum_m S(x + o_m); aligned: sum_m D_m(x + o_m).
      const Eigen::Index n = params_.pairs == pairing::all_pairs ? 0 : m;
      const Eigen::Map<const image<scalar_type>> dn(&dist(0, n), field_.rows, field_.cols);
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
  detail::descriptor_tiles<scalar_type> field_tiles_;              // field_, tiled for the kernel
  std::vector<detail::descriptor_tiles<scalar_type>> per_window_;  // patch m of every window
  // Per-touch distances, kept between calls so that log_likelihood() does not allocate. This
  // makes one model object non-reentrant: give each thread its own filter.
  mutable Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> workspace_;
  mutable std::vector<scalar_type> g_norms_;  // the tactile descriptors' squared norms
};

}  // namespace tacmap
