// tacmap: `state_estimate` — what `bayes_filter::estimate()` reports about a belief.
#pragma once

#include <Eigen/Core>
#include <concepts>
#include <tuple>
#include <type_traits>
#include <vector>

namespace tacmap {

/// Summary of a belief in the map frame (millimetres; radians for angles).
///
/// Over a `latent_grid` (a discrete latent variable such as the object's appearance) every
/// figure describes the *position* marginal p(x) = sum_h bel(h, x) — where the sensor is,
/// whatever the hypothesis — and `hypothesis_probability` holds p(h) = sum_x bel(h, x).
///
/// Over a `library_grid` (which of several objects, each with its own map) the positions of
/// different objects are in different maps and cannot be averaged: `object_probability` holds
/// p(k) = sum_x bel(k, x), and every other figure describes the most probable object
/// (`map_object`), its position belief *conditioned* on that object, p(x | k), in that object's
/// map frame — except `map_probability`, which stays the joint probability of the MAP state.
template <int Dimension>
struct state_estimate {
  using vector_type = Eigen::Matrix<double, Dimension, 1>;
  using matrix_type = Eigen::Matrix<double, Dimension, Dimension>;
  /// Index of the most probable state (MAP). Latent grids: the most probable position, in the
  /// block of the most probable hypothesis (`map_hypothesis`); library grids: in the block of
  /// the most probable object (`map_object`).
  Eigen::Index map_index = 0;
  vector_type map_mm;            ///< the MAP state's coordinates
  double map_probability = 0.0;  ///< its posterior probability (latent: summed over hypotheses)
  vector_type mean_mm;           ///< posterior mean
  matrix_type covariance_mm2;    ///< posterior covariance
  /// -sum p log p of the position belief: 0 when certain, log(N) when uniform over N positions.
  double entropy_nats = 0.0;
  /// Latent grids: the posterior of each hypothesis (sums to 1; names in the grid's
  /// `hypothesis_name(h)`). Empty for grids without a latent variable. Library grids whose
  /// objects carry hypotheses: those of the most probable object, conditioned on it.
  std::vector<double> hypothesis_probability;
  /// Latent grids: the most probable hypothesis (0 otherwise). Equal posteriors (e.g. a map
  /// whose appearances cannot be told apart) show as equal `hypothesis_probability` values;
  /// the lowest index is named here.
  Eigen::Index map_hypothesis = 0;
  /// Library grids: the posterior of each object (sums to 1; names in the grid's
  /// `object_name(k)`). Empty for other grids.
  std::vector<double> object_probability;
  /// Library grids: the most probable object (0 otherwise); the lowest index among ties.
  Eigen::Index map_object = 0;
  /// Library grids: the other objects whose posterior equals `map_object`'s (relative
  /// difference below 1e-6), e.g. two objects with identical maps, which no touch can tell
  /// apart: the estimate's pose is then as likely on each of them. Empty when the leader is
  /// unique.
  std::vector<Eigen::Index> tied_objects;
};

/// Grids that flag some coordinates as angles: `static constexpr std::array<bool, dimension>
/// circular` (pose_grid: theta). `estimate()` then uses circular statistics for them.
template <class G>
concept has_circular_coordinates = requires {
  { G::circular[0] } -> std::convertible_to<bool>;
  requires std::tuple_size_v<std::remove_cvref_t<decltype(G::circular)>>
  == G::dimension;
};

}  // namespace tacmap
