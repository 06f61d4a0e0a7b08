// tacmap: the `measurement_model` concept — the measurement update's p(z_t | x_t) (Table 1).
#pragma once

#include <concepts>

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
template <class M, class G>
concept measurement_model = state_grid<G> &&
    requires(const M& m, const G& g, const typename M::measurement_type& z, belief_array<G>& out) {
  { m.log_likelihood(g, z, out) } -> std::same_as<void>;
};

}  // namespace tacmap
