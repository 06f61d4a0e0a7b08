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
#include <span>
#include <stdexcept>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "tacmap/detail/mass_sum.hpp"
#include "tacmap/filter/detail/support.hpp"
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

  /// Tracking mode (`moves_box`, motion/concept.hpp): the base model's `predict_boxes` in every
  /// hypothesis's block (the boxes are on the belief image, so each block's states inside
  /// them), then the switch between hypotheses on the states where the moved mass landed
  /// (`landed`, each box's window united over the blocks). Every state outside those windows
  /// keeps its value in every block: the switch would only move such a state's mass between
  /// blocks, which leaves the mass outside the windows — what the filter's bound counts — as it
  /// is. Not renormalised (`dropped`: the blocks' mass carried off the grid). False, the belief
  /// unchanged, when the base model cannot move the boxes (its refusals depend on the grid, the
  /// boxes and the control only, so every block agrees; a base model whose second block refuses
  /// after the first moved is a broken contract: std::logic_error).
  template <latent_state_grid G>
  requires moves_box<Motion, typename G::base_type>
  bool predict_boxes(const G& grid, belief_array<G>& b, std::span<const grid_box> boxes,
                     const control_type& u, std::vector<grid_box>& landed, double& dropped) const {
    using base_grid = typename G::base_type;
    using T = typename G::scalar_type;
    const Eigen::Index hypotheses = grid.hypotheses(), n = grid.hypothesis_size();
    const double s = params_.switch_probability;
    if (b.size() != grid.size()) return false;
    if (hypotheses > 1 && s > 1.0 - 1.0 / static_cast<double>(hypotheses)) return false;
    dropped = 0.0;
    for (Eigen::Index h = 0; h < hypotheses; ++h) {
      Eigen::Map<belief_array<base_grid>> block(b.data() + h * n, n);
      double lost = 0.0;
      std::vector<grid_box>& mine = h == 0 ? landed : block_landed_;
      if (!motion_.predict_boxes(grid.base(), block, boxes, u, mine, lost)) {
        if (h == 0) return false;
        detail::fail<std::logic_error>(
            "latent_motion::predict_boxes: the base model moved hypothesis 0's boxes but refused "
            "hypothesis ",
            h,
            "'s (same grid, boxes and control); expected the same answer for every block. The "
            "belief is changed; reset the filter");
      }
      dropped += lost;
      if (h > 0)
        for (std::size_t i = 0; i < landed.size() && i < mine.size(); ++i)
          landed[i] = detail::box_union(landed[i], mine[i]);
    }
    if (hypotheses == 1 || !(s > 0.0)) return true;
    // The switch, out_h <- (1 - s) out_h + s / (H - 1) (total - out_h), on the windows' states
    // (overlapping windows united first, so that each state is mixed once).
    windows_ = landed;
    detail::merge_boxes(windows_, 0);
    const Eigen::Index rows = grid.rows(), cols = grid.cols(), plane = rows * cols;
    const Eigen::Index layers = n / plane;
    const auto move = static_cast<T>(s / static_cast<double>(hypotheses - 1));
    const auto stay = static_cast<T>(1.0 - s) - move;
    auto& total = scratch<T>(0);
    for (const grid_box& w : windows_)
      for (Eigen::Index a = 0; a < layers; ++a)
        for (Eigen::Index r = w.row; r < w.row + w.rows; ++r) {
          const Eigen::Index at = a * plane + r * cols + w.col;
          total = b.segment(at, w.cols);
          for (Eigen::Index h = 1; h < hypotheses; ++h) total += b.segment(h * n + at, w.cols);
          for (Eigen::Index h = 0; h < hypotheses; ++h)
            b.segment(h * n + at, w.cols) = stay * b.segment(h * n + at, w.cols) + move * total;
        }
    return true;
  }

 private:
  Motion motion_;
  latent_motion_params params_;
  mutable std::vector<grid_box> block_landed_, windows_;  // predict_boxes' scratch
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
