// tacmap: the `motion_model` concept — the control update of the Bayes filter (paper, Table 1).
#pragma once

#include <algorithm>
#include <concepts>
#include <span>
#include <vector>

#include "tacmap/grid/concept.hpp"

namespace tacmap {

/// What a motion model reports about one prediction.
struct prediction_report {
  /// Fraction of belief mass (0..1) that the motion carried off the grid before renormalising.
  double mass_lost = 0.0;
  /// Tracking mode (`bayes_filter::set_tracking`): only the mass inside the boxes around the
  /// last tracked update's support was moved (`moves_box`); the rest stayed where it was.
  bool windowed = false;
  /// When `windowed`: a bound on the total-variation distance to the whole-grid prediction of
  /// the same belief (the mass left outside the boxes, plus what was moved off the grid); 0
  /// otherwise.
  double tracking_error_bound = 0.0;
};

/// A rectangle of a single-layer grid's belief image: rows [row, row + rows), columns
/// [col, col + cols).
struct grid_box {
  Eigen::Index row = 0;
  Eigen::Index col = 0;
  Eigen::Index rows = 0;
  Eigen::Index cols = 0;
};

namespace detail {
/// The part of `b` inside a rows x cols image (empty: rows or cols 0).
inline grid_box clip_box(const grid_box& b, Eigen::Index rows, Eigen::Index cols) {
  const Eigen::Index r0 = std::max<Eigen::Index>(b.row, 0), c0 = std::max<Eigen::Index>(b.col, 0);
  const Eigen::Index r1 = std::min(b.row + b.rows, rows), c1 = std::min(b.col + b.cols, cols);
  return {r0, c0, std::max<Eigen::Index>(r1 - r0, 0), std::max<Eigen::Index>(c1 - c0, 0)};
}

/// The sum, in double, of `window`'s values outside its part `inside` (a `clip_box` of it,
/// given in the same coordinates as `window`): the strips above, below, left and right of it.
/// Summed directly rather than as sum(window) - sum(inside): that difference of two float sums
/// comes out a few ulps below zero when next to nothing lies outside (-9e-10 was seen on a
/// 640 x 480 map after thousands of tracked touches), and a negative dropped mass is a broken
/// contract for `bayes_filter`. Non-negative for non-negative values.
template <class Img>
double mass_outside(const Img& window, const grid_box& w, const grid_box& inside) {
  const Eigen::Index top = inside.row - w.row, left = inside.col - w.col;
  const Eigen::Index bottom = w.rows - top - inside.rows, right = w.cols - left - inside.cols;
  const auto sum = [](const auto& block) { return block.template cast<double>().sum(); };
  if (inside.rows == 0 || inside.cols == 0) return sum(window);
  return sum(window.topRows(top)) + sum(window.bottomRows(bottom)) +
         sum(window.block(top, 0, inside.rows, left)) +
         sum(window.block(top, w.cols - right, inside.rows, right));
}
}  // namespace detail

/// The control update bel_bar(x_t) = sum over x_{t-1} of p(x_t | u_t, x_{t-1}) bel(x_{t-1}),
/// done for the whole grid in one call (never per cell, never as a dense transition matrix).
///
/// A type `M` models `motion_model<M, G>` for a `state_grid G` when, for a `const M m`,
/// a `const G g`, a `const M::control_type u`, a normalised belief `in` and an output `out`
/// (both `belief_array<G>` of size `g.size()`):
///  1. `M::control_type` names the control (odometry) the model consumes.
///  2. `m.predict(g, in, out, u)` writes the predicted belief into `out` (already sized; it may
///     not be resized) and returns a `prediction_report`.
///  3. On success `out` is finite, non-negative and sums to 1 (the model decides, and documents,
///     what happens to mass that leaves the grid, and reports it in `mass_lost`).
///  4. A control it cannot apply (NaN, infinite) or a motion that leaves no mass on the grid
///     throws `std::invalid_argument` or `std::domain_error` naming the value; `out` may then be
///     garbage and the filter keeps its previous belief.
///
/// Minimal conforming type (the identity motion):
/// ```
/// struct stay_put {
///   struct control_type {};
///   template <class G>
///   prediction_report predict(const G&, const belief_array<G>& in, belief_array<G>& out,
///                             const control_type&) const { out = in; return {}; }
/// };
/// ```
template <class M, class G>
concept motion_model = state_grid<G> &&
    requires(const M& m, const G& g, const belief_array<G>& in, belief_array<G>& out,
             const typename M::control_type& u) {
  { m.predict(g, in, out, u) } -> std::same_as<prediction_report>;
};

/// Motion models that can move part of a belief in place (tracking mode): for a `const M m`, a
/// `const G g`, a normalised `belief_array<G> b`, pairwise disjoint `grid_box`es `boxes` inside
/// the belief image (of every layer, for layered grids), a control `u` and a
/// `std::vector<grid_box> landed` and a `double dropped`,
/// `m.predict_boxes(g, b, boxes, u, landed, dropped)` replaces the mass inside the boxes by its
/// prediction, exactly as `predict` would move it (reading every box before writing any), leaves
/// every state outside them unchanged, sets `landed[i]` to a rectangle of the grid holding all
/// of box i's moved mass, sets `dropped` to the mass carried off the grid (which `predict`
/// would drop before renormalising; not renormalised here) and returns true; or returns false
/// with `b` unchanged when it cannot (mass would reach an edge where `predict` does anything
/// but drop it, a control `predict` would refuse): the caller then predicts the whole grid.
/// Otherwise `b`'s sum changes only by rounding and `dropped`. `odometry_gaussian` and
/// `pose_odometry_gaussian` model it (and offer `predict_box` for one box).
template <class M, class G>
concept moves_box = motion_model<M, G> &&
    requires(const M& m, const G& g, belief_array<G>& b, std::span<const grid_box> boxes,
             const typename M::control_type& u, std::vector<grid_box>& landed, double& dropped) {
  { m.predict_boxes(g, b, boxes, u, landed, dropped) } -> std::same_as<bool>;
};

/// Motion models whose prediction puts the same probability on every state (a "uniform floor":
/// `robust_motion`'s lost_probability lambda), p(x_t | x_{t-1}, u_t) = (1 - lambda) p_0 +
/// lambda / N: `m.uniform_floor()` returns lambda in [0, 1). A tracking filter
/// (`bayes_filter::set_tracking`) then carries the floor's share as one number — the mass it
/// leaves on the states outside the tracked support — instead of moving it, and checks the
/// whole grid when the touch may fit better there.
template <class M>
concept has_uniform_floor = requires(const M& m) {
  { m.uniform_floor() } -> std::convertible_to<double>;
};

}  // namespace tacmap
