// tacmap: `latent_motion` — a motion model over a `latent_grid`: the base grid's motion in every
// hypothesis block, and (optionally) a small chance that the hypothesis changes between touches.
//
// The control update of Table 1 over the joint state (h, x):
//
//   bel_bar(h, x) = sum_{h'} p(h | h') sum_{x'} p(x | u, x') bel(h', x')
//
// with p(h | h') = 1 - s for h = h' and s / (H - 1) otherwise. The hypothesis is a property of
// the object (s = 0, the default: the object's appearance does not change while it is touched);
// s > 0 lets the filter follow a relation that changes across the object (parts of different
// polarity), at the price of keeping a share s of the belief on every other hypothesis.
//
// The base motion model normalises its own output, so each block goes in normalised and its
// result is scaled back to the mass the block kept (its mass before, times one minus the
// fraction it lost off the grid): hypotheses keep their relative weights through a prediction,
// however unlikely one has become. A block whose motion leaves no
// mass on the grid keeps none (other blocks may still hold some); only when every block loses
// everything does the prediction throw, as the base model would.
#pragma once

#include <algorithm>
#include <cmath>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "tacmap/detail/mass_sum.hpp"
#include "tacmap/grid/latent_grid.hpp"
#include "tacmap/motion/concept.hpp"
#include "tacmap/motion/detail/block_prediction.hpp"

namespace tacmap {

/// Configuration of `latent_motion`.
struct latent_motion_params {
  /// Probability that the hypothesis changes between two touches (spread evenly over the other
  /// hypotheses); 0 = the hypothesis is a fixed property of the object. In [0, 1 - 1/H].
  double switch_probability = 0.0;
};

/// `Motion` (a motion model of the base grid) applied to every hypothesis of a `latent_grid`.
/// Keeps per-call workspaces, like the base models: one object is not reentrant (one filter per
/// thread).
template <class Motion>
class latent_motion {
 public:
  using control_type = typename Motion::control_type;

  /// Throws std::invalid_argument for a switch probability outside [0, 1).
  explicit latent_motion(Motion motion, latent_motion_params params = {})
      : motion_(std::move(motion)), params_(params) {
    if (!(std::isfinite(params.switch_probability) && params.switch_probability >= 0.0 &&
          params.switch_probability < 1.0))
      detail::fail("latent_motion: switch_probability = ", params.switch_probability,
                   "; expected a probability in [0, 1) (0 = the hypothesis never changes)");
  }

  [[nodiscard]] const Motion& base() const { return motion_; }
  [[nodiscard]] Motion& base() { return motion_; }
  [[nodiscard]] const latent_motion_params& params() const { return params_; }

  template <latent_state_grid G>
  requires motion_model<Motion, typename G::base_type> prediction_report
  predict(const G& grid, const belief_array<G>& in, belief_array<G>& out, const control_type& u)
  const {
    const Eigen::Index hypotheses = grid.hypotheses();
    const double s = params_.switch_probability;
    if (hypotheses > 1 && s > 1.0 - 1.0 / static_cast<double>(hypotheses))
      detail::fail("latent_motion: switch_probability = ", s, " with ", hypotheses,
                   " hypotheses would favour changing over staying; expected at most ",
                   1.0 - 1.0 / static_cast<double>(hypotheses));
    // One hypothesis: the base model itself (same belief type, no copies).
    if (hypotheses == 1) return motion_.predict(grid.base(), in, out, u);

    using T = typename G::scalar_type;
    const Eigen::Index n = grid.hypothesis_size();
    auto& block_in = scratch<T>(0);
    auto& block_out = scratch<T>(1);
    const detail::block_masses m = detail::predict_blocks<T>(
        hypotheses,
        [n](Eigen::Index h) {
          return std::pair{h * n, n};
        },
        [&](Eigen::Index) { return std::tie(block_in, block_out); },
        [&](Eigen::Index, const auto& block, auto& moved) {
          return motion_.predict(grid.base(), block, moved, u);
        },
        in, out, kept_, "latent_motion", "hypotheses");
    if (s > 0.0) {
      // out_h <- (1 - s) out_h + s / (H - 1) (total - out_h), in place: a block-wise affine map.
      auto& total = block_out;
      total = out.segment(0, n);
      for (Eigen::Index h = 1; h < hypotheses; ++h) total += out.segment(h * n, n);
      const auto move = static_cast<T>(s / static_cast<double>(hypotheses - 1));
      const auto stay = static_cast<T>(1.0 - s) - move;
      for (Eigen::Index h = 0; h < hypotheses; ++h)
        out.segment(h * n, n) = stay * out.segment(h * n, n) + move * total;
    }
    out *= static_cast<T>(1.0 / detail::mass_sum(out));
    return {std::clamp(1.0 - m.kept / m.before, 0.0, 1.0)};
  }

 private:
  Motion motion_;
  latent_motion_params params_;
  template <class T>
  Eigen::Array<T, Eigen::Dynamic, 1>& scratch(int which) const {
    if constexpr (std::is_same_v<T, float>)
      return scratch_f_[which];
    else
      return scratch_d_[which];
  }

  // One hypothesis block in and out, kept between calls (no allocation per predict): like the
  // base models, one object is not reentrant.
  mutable Eigen::ArrayXf scratch_f_[2];
  mutable Eigen::ArrayXd scratch_d_[2];
  mutable std::vector<double> kept_;  // per hypothesis: the mass its block kept
};

}  // namespace tacmap
