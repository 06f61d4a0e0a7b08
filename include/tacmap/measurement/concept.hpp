// tacmap: the `measurement_model` concept — the measurement update's p(z_t | x_t) (Table 1).
#pragma once

#include <Eigen/Core>
#include <concepts>
#include <span>

#include "tacmap/grid/concept.hpp"

namespace tacmap {

/// Fills log p(z_t | x_t) for every state of the grid at once.
///
/// Log-likelihoods rather than likelihoods: the filter subtracts their maximum before
/// exponentiating, so sharp likelihoods cannot underflow and tempering is a multiply.
///
/// A type `M` models `measurement_model<M, G>` for a `state_grid G` when, for a `const M m`, a
/// `const G g`, a `const M::measurement_type z` and an output `out` of type `belief_array<G>`:
///  1. `M::measurement_type` names what one measurement is (a tactile image, a frame, ...).
///  2. `m.log_likelihood(g, z, out)` writes one value per state into `out`, which the filter
///     has already sized to `g.size()` (the model must not resize it).
///  3. Every value is finite or minus infinity (a state the measurement rules out). NaN and
///     plus infinity are errors; the filter rejects them.
///  4. Only differences between values matter: adding a constant changes nothing.
///  5. A measurement the model cannot use (wrong size, NaN) throws `std::invalid_argument`
///     naming the value and what was expected.
///
/// Optional hook: a model that also declares `m.log_likelihood(g, z, out, predicted)`, with
/// `predicted` the filter's belief before this update (`belief_array<G>`), gets that call from
/// `bayes_filter::update` instead: it may skip states the prediction has ruled out
/// (`library_likelihood` skips objects whose predicted posterior is negligible).
///
/// Optional hook (tracking mode, `bayes_filter::set_tracking`): a model that also declares
///  * `m.log_likelihood_bound()` -> double: an upper bound on log p(z | x) over every state and
///    every measurement (0 for `-d / tau` with distances d >= 0), or +infinity when it has none
///    (the filter then always takes the whole grid), and
///  * `m.log_likelihood_on(g, z, out, states)`, `states` a `std::span<const state_range>`
///    (sorted, disjoint, non-empty half-open ranges of state indices): fills `out` at least at
///    those states with exactly (bit for bit) what `m.log_likelihood(g, z, out)` writes there;
///    other entries are left unspecified,
/// is evaluated by a tracking filter only where the predicted belief holds all but a stated
/// epsilon of its mass. A model may implement `log_likelihood_on` by filling the whole grid
/// (exact, no saving) for configurations it cannot restrict. `tacmap::testing::
/// check_log_likelihood_on` (testing/conformance.hpp) checks both promises on a grid.
///
/// Minimal conforming type (a measurement that carries no information):
/// ```
/// struct uninformative {
///   struct measurement_type {};
///   template <class G>
///   void log_likelihood(const G&, const measurement_type&, belief_array<G>& out) const {
///     out.setZero();
///   }
/// };
/// ```
/// A half-open range [begin, end) of state indices (the tracking hook's argument).
struct state_range {
  Eigen::Index begin = 0;
  Eigen::Index end = 0;
  friend bool operator==(const state_range&, const state_range&) = default;
};

template <class M, class G>
concept measurement_model = state_grid<G> &&
    requires(const M& m, const G& g, const typename M::measurement_type& z, belief_array<G>& out) {
  { m.log_likelihood(g, z, out) } -> std::same_as<void>;
};

/// Measurement models with the tracking hook (see `measurement_model`): an upper bound on the
/// log-likelihood and an evaluation restricted to ranges of states. Minimal conforming type:
/// ```
/// struct uninformative_tracked {
///   struct measurement_type {};
///   template <class G>
///   void log_likelihood(const G&, const measurement_type&, belief_array<G>& out) const {
///     out.setZero();
///   }
///   double log_likelihood_bound() const { return 0.0; }
///   template <class G>
///   void log_likelihood_on(const G&, const measurement_type&, belief_array<G>& out,
///                          std::span<const state_range> states) const {
///     for (const state_range& r : states) out.segment(r.begin, r.end - r.begin).setZero();
///   }
/// };
/// ```
template <class M, class G>
concept measures_on_states = measurement_model<M, G> &&
    requires(const M& m, const G& g, const typename M::measurement_type& z, belief_array<G>& out,
             std::span<const state_range> states) {
  { m.log_likelihood_bound() } -> std::convertible_to<double>;
  m.log_likelihood_on(g, z, out, states);
};

}  // namespace tacmap
