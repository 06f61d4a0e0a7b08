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
// Sharing: neighbouring windows share patches (window x's patch m is the dense map patch at
// x + offset_m), so the map's descriptors are computed once, densely, at stride 1. Per touch we
// compute D_n(q) = || F(q) - g_n || for every dense map position q (one matrix product for
// Euclidean descriptors: ||F||^2 - 2 F^T g + ||g||^2), then each window's d is a sum of M shifted
// copies of D — whole-grid block additions, no per-window loop.
#pragma once

#include "tacmap/descriptor/concept.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/image.hpp"
#include "tacmap/measurement/concept.hpp"

#include <cmath>
#include <concepts>
#include <stdexcept>
#include <utility>
#include <vector>

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

/// Configuration of `descriptor_likelihood`. Defaults: the paper's choices.
struct descriptor_likelihood_params {
  Eigen::Index spacing = 9;                       ///< pixels between tactile patches (paper: 9)
  pairing pairs = pairing::all_pairs;             ///< paper: all_pairs (eq. (1))
  likelihood_shape shape = likelihood_shape::inverse;  ///< paper: inverse (eq. (2))
  double epsilon = 1e-3;                          ///< inverse: added to d so that d = 0 is finite
  double tau = 1.0;                               ///< exponential: temperature, in distance units
  double tempering = 1.0;                         ///< exponent on the likelihood, >= 0

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

/// Descriptors whose `distance` is the Euclidean norm opt into the matrix-product fast path by
/// declaring `static constexpr bool euclidean_distance = true;`.
template <class D>
concept euclidean_descriptor = descriptor<D> && requires {
  requires D::euclidean_distance;
};

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
    if (window.width <= 0 || window.height <= 0 || map.cols() < window.width ||
        map.rows() < window.height)
      detail::fail("descriptor_likelihood: the map is ", map.cols(), " x ", map.rows(),
                   " px (width x height) and the window ", window.width, " x ", window.height,
                   "; expected a positive window no larger than the map");
    if (window.width < p || window.height < p)
      detail::fail("descriptor_likelihood: a descriptor patch of ", p, " px does not fit the ",
                   window.width, " x ", window.height,
                   " px tactile window; expected a patch no larger than the window's shorter side "
                   "(paper: patch 18 on a 42 x 18 window)");
    for (Eigen::Index oy = 0; oy + p <= window.height; oy += params.spacing)
      for (Eigen::Index ox = 0; ox + p <= window.width; ox += params.spacing)
        offsets_.push_back({oy, ox});
    if (!detail::all_finite(map))
      detail::fail("descriptor_likelihood: the map contains NaN or infinite pixels");
    field_ = descriptor_.compute(map.template cast<scalar_type>());
    TACMAP_ASSERT(field_.rows == map.rows() - p + 1 && field_.cols == map.cols() - p + 1,
                  "descriptor::compute returned a field of the wrong shape");
    field_sq_norm_ = field_.values.colwise().squaredNorm().transpose();
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
    if (z.rows() != window_.height || z.cols() != window_.width)
      detail::fail("descriptor_likelihood: tactile image is ", z.rows(), " x ", z.cols(),
                   " px (rows x cols); expected ", window_.height, " x ", window_.width,
                   " (the sensor window at map scale — preprocess the frame first)");
    if (!detail::all_finite(z))
      detail::fail("descriptor_likelihood: the tactile image contains NaN or infinite pixels");
    const auto zf = descriptor_.compute(z.template cast<scalar_type>());
    Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> g(zf.values.rows(),
                                                                 patches_per_window());
    for (Eigen::Index m = 0; m < patches_per_window(); ++m)
      g.col(m) = zf.at(offsets_[static_cast<std::size_t>(m)].row,
                       offsets_[static_cast<std::size_t>(m)].col);
    return g;
  }

  /// The distance d(x, z) of eq. (1) for every state (row-major grid order).
  template <class G>
  void distances(const G& grid, const measurement_type& z, belief_array<G>& out) const
    requires std::same_as<typename G::scalar_type, scalar_type>
  {
    const Eigen::Index rows = field_.rows - (window_.height - descriptor_.patch_size());
    const Eigen::Index cols = field_.cols - (window_.width - descriptor_.patch_size());
    if (grid.rows() != rows || grid.cols() != cols || grid.size() != rows * cols)
      detail::fail("descriptor_likelihood: the grid has ", grid.rows(), " x ", grid.cols(),
                   " states but the map and window give ", rows, " x ", cols,
                   "; build the grid and the model from the same map and window");
    const auto g = tactile_descriptors(z);
    const Eigen::Index positions = field_.rows * field_.cols;
    const Eigen::Index m_count = patches_per_window();
    auto& dist = workspace_;  // positions x M: D_n(q) = || F(q) - g_n ||
    dist.resize(positions, m_count);
    if constexpr (euclidean_descriptor<Descriptor>) {
      // ||F - g||^2 = ||F||^2 - 2 F.g + ||g||^2, one matrix product for all positions.
      dist.matrix().noalias() = field_.values.matrix().transpose() * g.matrix();
      const auto g_sq = g.colwise().squaredNorm().eval();
      for (Eigen::Index n = 0; n < m_count; ++n)
        dist.col(n) = (field_sq_norm_ - scalar_type(2) * dist.col(n) + g_sq(n)).max(0).sqrt();
    } else {
      for (Eigen::Index n = 0; n < m_count; ++n)
        for (Eigen::Index q = 0; q < positions; ++q)
          dist(q, n) = descriptor_.distance(field_.values.col(q), g.col(n));
    }
    Eigen::Map<image<scalar_type>> d(out.data(), rows, cols);
    d.setZero();
    const auto shifted = [&](Eigen::Index n, Eigen::Index m) {
      const Eigen::Map<const image<scalar_type>> dn(dist.col(n).data(), field_.rows, field_.cols);
      const grid_cell o = offsets_[static_cast<std::size_t>(m)];
      return dn.block(o.row, o.col, rows, cols);
    };
    if (params_.pairs == pairing::all_pairs) {
      // sum_m sum_n D_n(x + o_m) = sum_m S(x + o_m) with S = sum_n D_n.
      for (Eigen::Index n = 1; n < m_count; ++n) dist.col(0) += dist.col(n);
      for (Eigen::Index m = 0; m < m_count; ++m) d += shifted(0, m);
    } else {
      for (Eigen::Index m = 0; m < m_count; ++m) d += shifted(m, m);
    }
  }

  /// log p(z | x) for every state: eq. (1) then eq. (2) or the exponential, times tempering.
  template <class G>
  void log_likelihood(const G& grid, const measurement_type& z, belief_array<G>& out) const
    requires std::same_as<typename G::scalar_type, scalar_type>
  {
    distances(grid, z, out);
    const auto temper = static_cast<scalar_type>(params_.tempering);
    if (params_.shape == likelihood_shape::inverse)
      out = -temper * (out + static_cast<scalar_type>(params_.epsilon)).log();
    else
      out *= -temper / static_cast<scalar_type>(params_.tau);
  }

 private:
  Descriptor descriptor_;
  descriptor_likelihood_params params_;
  pixel_size window_;
  std::vector<grid_cell> offsets_;
  descriptor_field<scalar_type> field_;
  Eigen::Array<scalar_type, Eigen::Dynamic, 1> field_sq_norm_;
  // Per-touch distances, kept between calls so that log_likelihood() does not allocate. This
  // makes one model object non-reentrant: give each thread its own filter.
  mutable Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> workspace_;
};

}  // namespace tacmap
