// tacmap: the `motion_model` concept — the control update of the Bayes filter (paper, Table 1).
#pragma once

#include <concepts>

#include "tacmap/grid/concept.hpp"

namespace tacmap {

/// What a motion model reports about one prediction.
struct prediction_report {
  /// Fraction of belief mass (0..1) that the motion carried off the grid before renormalising.
  double mass_lost = 0.0;
};

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

}  // namespace tacmap
