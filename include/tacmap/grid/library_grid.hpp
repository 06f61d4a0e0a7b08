// tacmap: `library_grid` — which object, and where: the states of several objects' grids, one
// block per object, as one state space.
//
// The paper assumes the robot knows which object it holds. A robot that photographed several
// objects does not know which one its hand closed on; the touches answer both questions at once,
// because a tactile sequence that fits one map's windows well and another's poorly identifies
// the object while it localizes the contact (issue 15). Like the appearance of the photograph
// (`latent_grid`), the object is a discrete latent variable k of the one Bayes filter of
// Table 1, over the joint state (k, x):
//
//   bel(k, x) = eta p(z | x, k) sum_{x'} p(x | u, x', k) bel(k, x')     (the object is static)
//
// Unlike the appearance hypotheses, the objects do not share their positions: each has its own
// map, of its own size and scale, so each has its own grid G_k, and the belief is the blocks of
// all of them one after the other (object-major; state i belongs to the object whose block
// [object_offset(k), object_offset(k) + object_size(k)) holds it). An object's grid may itself
// carry hypotheses (a `latent_grid` of its appearance): the object's block is then that grid's
// whole belief, and each object has its own appearance, as each object in the world does.
//
// The prior over objects (uniform by default) is spread evenly over each object's states:
// p(k, x) = prior(k) / |G_k|, so a large map is not favoured over a small one for its size alone,
// and the evidence of the touches, sum_x p(z | x, k) bel(k, x), weighs the objects against each
// other: the posterior p(k) = sum_x bel(k, x) is Bayes's answer to "which object", provided the
// likelihoods of the different maps share one scale (one descriptor and one tau; calibrated by
// tacmap-calibrate, README "Confidence"). Objects whose maps are identical keep identical
// posteriors; `bayes_filter::estimate()` names such ties (`state_estimate::tied_objects`).
//
// Positions of different objects are in different maps and are never averaged together:
// `bayes_filter::estimate()` reports each object's posterior and the pose on the most probable
// object (conditioned on it); `probability_within` and `most_probable_disc` act on that object's
// block and give the joint probability (right object and within the radius).
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "tacmap/config.hpp"
#include "tacmap/grid/concept.hpp"
#include "tacmap/grid/latent_grid.hpp"

namespace tacmap {

/// The objects of a library, each with its own grid `G`, one block per object (see the file
/// comment). Models `state_grid` with G's dimension, coordinates (each in its own object's map
/// frame) and scalar type; its belief is one row of `size()` states (the blocks do not form one
/// image): see `object_belief` for one object's belief.
template <state_grid G>
class library_grid : public detail::circular_flags<G> {
 public:
  using object_grid_type = G;
  using scalar_type = typename G::scalar_type;
  static constexpr int dimension = G::dimension;
  using state_type = typename G::state_type;

  /// `objects`: each object's grid; `names`: one short, distinct, non-empty name per object (how
  /// estimates and figures report them); `prior`: each object's prior probability (finite,
  /// >= 0, summing to one within 1e-6), empty for uniform. Throws std::invalid_argument for an
  /// empty library, mismatched counts, repeated or empty names, or an invalid prior.
  library_grid(std::vector<G> objects, std::vector<std::string> names,
               std::vector<double> prior = {})
      : objects_(std::move(objects)), names_(std::move(names)), prior_(std::move(prior)) {
    if (objects_.empty())
      detail::fail(
          "library_grid: the library is empty; expected at least one object (one map per "
          "object the robot may touch)");
    if (names_.size() != objects_.size())
      detail::fail("library_grid: ", objects_.size(), " objects but ", names_.size(),
                   " names; expected one name per object");
    for (std::size_t a = 0; a < names_.size(); ++a) {
      if (names_[a].empty())
        detail::fail("library_grid: object ", a,
                     " has an empty name; expected a short name (how estimates report it)");
      for (std::size_t b = a + 1; b < names_.size(); ++b)
        if (names_[a] == names_[b])
          detail::fail("library_grid: objects ", a, " and ", b, " are both named '", names_[a],
                       "'; expected one entry per object — a duplicate entry would only split "
                       "that object's posterior in two");
    }
    if (prior_.empty()) prior_.assign(objects_.size(), 1.0 / static_cast<double>(objects_.size()));
    check_prior(prior_, objects_.size());
    offsets_.reserve(objects_.size() + 1);
    offsets_.push_back(0);
    for (const G& g : objects_) offsets_.push_back(offsets_.back() + g.size());
  }

  /// One row: the objects' blocks do not form one image.
  [[nodiscard]] Eigen::Index rows() const { return 1; }
  [[nodiscard]] Eigen::Index cols() const { return size(); }
  [[nodiscard]] Eigen::Index size() const { return offsets_.back(); }
  /// State i's coordinates, in its object's map frame.
  [[nodiscard]] state_type state_mm(Eigen::Index i) const {
    TACMAP_ASSERT(i >= 0 && i < size(), "state index out of range");
    const Eigen::Index k = object_of(i);
    return objects_[static_cast<std::size_t>(k)].state_mm(i - object_offset(k));
  }

  /// Number of objects.
  [[nodiscard]] Eigen::Index objects() const { return static_cast<Eigen::Index>(objects_.size()); }
  /// Object k's grid.
  [[nodiscard]] const G& object(Eigen::Index k) const {
    check_object("library_grid::object", k);
    return objects_[static_cast<std::size_t>(k)];
  }
  /// The first state of object k's block.
  [[nodiscard]] Eigen::Index object_offset(Eigen::Index k) const {
    check_object("library_grid::object_offset", k);
    return offsets_[static_cast<std::size_t>(k)];
  }
  /// The number of states of object k's block (its grid's size).
  [[nodiscard]] Eigen::Index object_size(Eigen::Index k) const {
    check_object("library_grid::object_size", k);
    return objects_[static_cast<std::size_t>(k)].size();
  }
  [[nodiscard]] const std::string& object_name(Eigen::Index k) const {
    check_object("library_grid::object_name", k);
    return names_[static_cast<std::size_t>(k)];
  }
  [[nodiscard]] const std::vector<std::string>& object_names() const { return names_; }
  /// Each object's prior probability (what `bayes_filter::reset()` starts from).
  [[nodiscard]] const std::vector<double>& object_prior() const { return prior_; }
  /// The object whose block holds state i.
  [[nodiscard]] Eigen::Index object_of(Eigen::Index i) const {
    TACMAP_ASSERT(i >= 0 && i < size(), "state index out of range");
    return static_cast<Eigen::Index>(std::upper_bound(offsets_.begin(), offsets_.end(), i) -
                                     offsets_.begin()) -
           1;
  }

 private:
  void check_object(const char* who, Eigen::Index k) const {
    if (k < 0 || k >= objects())
      detail::fail(who, ": object ", k, "; expected 0 .. ", objects() - 1);
  }
  static void check_prior(const std::vector<double>& prior, std::size_t objects) {
    if (prior.size() != objects)
      detail::fail("library_grid: the prior has ", prior.size(), " values for ", objects,
                   " objects; expected one probability per object (or none for uniform)");
    double sum = 0.0;
    for (std::size_t k = 0; k < prior.size(); ++k) {
      if (!(std::isfinite(prior[k]) && prior[k] >= 0.0))
        detail::fail("library_grid: prior of object ", k, " = ", prior[k],
                     "; expected a finite probability >= 0");
      sum += prior[k];
    }
    if (!(std::abs(sum - 1.0) <= 1e-6))
      detail::fail("library_grid: the prior sums to ", sum,
                   "; expected probabilities summing to 1 (divide by their sum, or pass none for "
                   "a uniform prior)");
  }

  std::vector<G> objects_;
  std::vector<std::string> names_;
  std::vector<double> prior_;
  std::vector<Eigen::Index> offsets_;  // object k's block starts at offsets_[k]; back() = size
};

/// Grids made of several objects' grids, one block each (`library_grid`): `bayes_filter`
/// reports each object's posterior and the pose on the most probable one, and starts from the
/// grid's prior over objects.
template <class G>
concept library_state_grid = state_grid<G> && requires(const G& g, Eigen::Index k) {
  typename G::object_grid_type;
  requires state_grid<typename G::object_grid_type>;
  { g.objects() } -> std::same_as<Eigen::Index>;
  { g.object(k) } -> std::convertible_to<const typename G::object_grid_type&>;
  { g.object_offset(k) } -> std::same_as<Eigen::Index>;
  { g.object_size(k) } -> std::same_as<Eigen::Index>;
  { g.object_name(k) } -> std::convertible_to<const std::string&>;
  { g.object_prior() } -> std::convertible_to<const std::vector<double>&>;
};

/// p(k) = sum_x bel(k, x): the posterior of each object.
template <library_state_grid G>
[[nodiscard]] std::vector<double> object_posterior(const G& grid, const belief_array<G>& belief) {
  if (belief.size() != grid.size())
    detail::fail("object_posterior: the belief has ", belief.size(), " values but the library ",
                 grid.size(), "; expected the belief of a filter over this library");
  std::vector<double> out(static_cast<std::size_t>(grid.objects()));
  for (Eigen::Index k = 0; k < grid.objects(); ++k)
    out[static_cast<std::size_t>(k)] =
        belief.segment(grid.object_offset(k), grid.object_size(k)).template cast<double>().sum();
  return out;
}

/// p(x | k): object k's block of the belief, normalised (a belief over `grid.object(k)`, e.g.
/// for a heat map on that object's map). Throws std::domain_error when the belief gives object
/// k no mass at all (its conditional belief is then undefined).
template <library_state_grid G>
[[nodiscard]] belief_array<typename G::object_grid_type> object_belief(
    const G& grid, const belief_array<G>& belief, Eigen::Index k) {
  if (belief.size() != grid.size())
    detail::fail("object_belief: the belief has ", belief.size(), " values but the library ",
                 grid.size(), "; expected the belief of a filter over this library");
  belief_array<typename G::object_grid_type> out =
      belief.segment(grid.object_offset(k), grid.object_size(k));
  const double mass = static_cast<double>(out.template cast<double>().sum());
  if (!(mass > 0.0))
    detail::fail<std::domain_error>("object_belief: object ", k, " ('", grid.object_name(k),
                                    "') has posterior 0; its position belief is undefined");
  out = (out.template cast<double>() / mass).template cast<typename G::scalar_type>();
  return out;
}

}  // namespace tacmap
