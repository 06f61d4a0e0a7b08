// tacmap: `latent_grid` — the states of a grid times a discrete latent variable (hypotheses).
//
// Some things the filter cannot observe directly are not positions: whether the object's raised
// parts look bright or dark in the photograph (the relation between the map and the touch), or,
// later, which of several objects is touched. Instead of running one filter per hypothesis and
// comparing them by hand, the one Bayes filter of Table 1 reasons over the joint state
// (hypothesis h, pose x): its belief is H copies of the base grid's belief, one block per
// hypothesis, and
//
//   bel(h, x) = eta p(z | x, h) sum_{x'} p(x | u, x') bel(h, x')      (the hypothesis is static,
//                                                                       or switches rarely)
//
// Marginalising gives what a user asks: p(x) = sum_h bel(h, x) (where is the sensor, whatever
// the appearance) and p(h) = sum_x bel(h, x) (which appearance the object has), both reported by
// `bayes_filter::estimate()`. The motion model acts per block (`latent_motion`), the measurement
// model gives each hypothesis its own likelihood (`appearance_likelihood`); the evidence of the
// touches weighs the hypotheses against each other, so hypotheses that explain the touches
// equally well keep equal posteriors (a symmetric pattern) — nothing picks one silently.
//
// Layout: hypothesis-major. State i of the latent grid is state (i mod n) of the base grid under
// hypothesis (i div n), n = base().size(); so block h is a whole base belief, layers and all.
#pragma once

#include <array>
#include <concepts>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "tacmap/config.hpp"
#include "tacmap/grid/concept.hpp"
#include "tacmap/image.hpp"

namespace tacmap {

namespace detail {
// Grids that flag angle coordinates (pose_grid): the latent grid forwards the flags, and only
// then declares them (bayes_filter takes the circular path only for grids that have angles).
template <class G>
concept flags_circular_coordinates = requires {
  G::circular[0];
};
template <class G, bool = flags_circular_coordinates<G>>
struct circular_flags {};
template <class G>
struct circular_flags<G, true> {
  static constexpr auto circular = G::circular;
};
}  // namespace detail

/// H discrete hypotheses times the states of a base grid `G`, hypothesis-major (see the file
/// comment). Models `state_grid` with G's dimension, coordinates and scalar type: a state's
/// coordinates are its base state's (the hypothesis is not a coordinate).
template <state_grid G>
class latent_grid : public detail::circular_flags<G> {
 public:
  using base_type = G;
  using scalar_type = typename G::scalar_type;
  static constexpr int dimension = G::dimension;
  using state_type = typename G::state_type;

  /// `base`: the states each hypothesis holds; `names`: one short name per hypothesis
  /// (e.g.\ "as photographed", "inverted"), at least one, all different. Throws
  /// std::invalid_argument otherwise.
  latent_grid(G base, std::vector<std::string> names)
      : base_(std::move(base)), names_(std::move(names)) {
    if (names_.empty())
      detail::fail(
          "latent_grid: no hypotheses; expected at least one name (one hypothesis is "
          "the base grid itself)");
    for (std::size_t a = 0; a < names_.size(); ++a)
      for (std::size_t b = a + 1; b < names_.size(); ++b)
        if (names_[a] == names_[b])
          detail::fail("latent_grid: hypotheses ", a, " and ", b, " are both named '", names_[a],
                       "'; expected distinct names (they are how estimate() reports them)");
  }

  [[nodiscard]] Eigen::Index rows() const { return base_.rows(); }
  [[nodiscard]] Eigen::Index cols() const { return base_.cols(); }
  [[nodiscard]] Eigen::Index size() const { return hypotheses() * base_.size(); }
  [[nodiscard]] state_type state_mm(Eigen::Index i) const {
    TACMAP_ASSERT(i >= 0 && i < size(), "state index out of range");
    return base_.state_mm(i % base_.size());
  }

  /// The grid each hypothesis holds.
  [[nodiscard]] const G& base() const { return base_; }
  /// Number of hypotheses H.
  [[nodiscard]] Eigen::Index hypotheses() const { return static_cast<Eigen::Index>(names_.size()); }
  /// States per hypothesis (the base grid's size): block h is [h * n, (h + 1) * n).
  [[nodiscard]] Eigen::Index hypothesis_size() const { return base_.size(); }
  /// The name of hypothesis h.
  [[nodiscard]] const std::string& hypothesis_name(Eigen::Index h) const {
    if (h < 0 || h >= hypotheses())
      detail::fail("latent_grid::hypothesis_name: hypothesis ", h, "; expected 0 .. ",
                   hypotheses() - 1);
    return names_[static_cast<std::size_t>(h)];
  }
  [[nodiscard]] const std::vector<std::string>& hypothesis_names() const { return names_; }

 private:
  G base_;
  std::vector<std::string> names_;
};

/// Grids whose belief carries a discrete latent variable: `bayes_filter::estimate()` reports
/// each hypothesis's posterior and marginalises it out of the position estimate.
template <class G>
concept latent_state_grid = state_grid<G> && requires(const G& g, Eigen::Index h) {
  typename G::base_type;
  requires state_grid<typename G::base_type>;
  { g.base() } -> std::convertible_to<const typename G::base_type&>;
  { g.hypotheses() } -> std::same_as<Eigen::Index>;
  { g.hypothesis_size() } -> std::same_as<Eigen::Index>;
  { g.hypothesis_name(h) } -> std::convertible_to<const std::string&>;
};

namespace detail {
template <class G, class Belief>
void check_latent_belief(const char* who, const G& grid, const Belief& belief) {
  if (belief.size() != grid.size())
    fail(who, ": the belief has ", belief.size(), " values but the grid ", grid.size(), " (",
         grid.hypotheses(), " hypotheses x ", grid.hypothesis_size(),
         " states); expected the belief of a filter over this grid");
}
}  // namespace detail

/// p(x) = sum_h bel(h, x): the belief over the base grid's states, whatever the hypothesis.
template <latent_state_grid G>
[[nodiscard]] belief_array<typename G::base_type> marginal_belief(const G& grid,
                                                                  const belief_array<G>& belief) {
  detail::check_latent_belief("marginal_belief", grid, belief);
  const Eigen::Index n = grid.hypothesis_size();
  belief_array<typename G::base_type> out = belief.head(n);
  for (Eigen::Index h = 1; h < grid.hypotheses(); ++h) out += belief.segment(h * n, n);
  return out;
}

/// p(h) = sum_x bel(h, x): the posterior of each hypothesis.
template <latent_state_grid G>
[[nodiscard]] std::vector<double> hypothesis_posterior(const G& grid,
                                                       const belief_array<G>& belief) {
  detail::check_latent_belief("hypothesis_posterior", grid, belief);
  const Eigen::Index n = grid.hypothesis_size();
  std::vector<double> out(static_cast<std::size_t>(grid.hypotheses()));
  for (Eigen::Index h = 0; h < grid.hypotheses(); ++h)
    out[static_cast<std::size_t>(h)] = belief.segment(h * n, n).template cast<double>().sum();
  return out;
}

}  // namespace tacmap
