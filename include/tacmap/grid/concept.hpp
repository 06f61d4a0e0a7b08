// tacmap: the `state_grid` concept — the set of candidate sensor poses the filter reasons over.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <concepts>
#include <type_traits>
#include <utility>

#include "tacmap/config.hpp"

namespace tacmap {

/// The floating-point types a belief may be held in.
template <class T>
concept belief_scalar = std::same_as<T, float> || std::same_as<T, double>;

/// A finite set of candidate sensor states laid out as an image-shaped belief.
///
/// A type `G` models `state_grid` when, for a `const G g` and an `Eigen::Index i`:
///  1. `G::scalar_type` is `float` or `double`: the precision of beliefs over this grid.
///  2. `G::dimension` is a `static constexpr int` > 0: the number of coordinates of a state
///     (2 for x, y; 3 for x, y, theta).
///  3. `G::state_type` is `Eigen::Matrix<double, G::dimension, 1>`: a state's coordinates,
///     millimetres (and radians for angles) in the map frame.
///  4. `g.rows()` and `g.cols()` return `Eigen::Index`: the shape of one belief image.
///  5. `g.size()` returns `Eigen::Index`, the number of states; a positive multiple of
///     `rows() * cols()` (the belief is `size() / (rows() * cols())` images, layer after layer,
///     each row-major).
///  6. `g.state_mm(i)` returns `G::state_type` for every `0 <= i < size()`.
///  7. `G` is copyable: the filter keeps its own copy.
///
/// Minimal conforming type:
/// ```
/// struct corridor {                       // a 1-D corridor of 10 cells, 5 mm apart
///   using scalar_type = double;
///   static constexpr int dimension = 1;
///   using state_type = Eigen::Matrix<double, 1, 1>;
///   Eigen::Index rows() const { return 1; }
///   Eigen::Index cols() const { return 10; }
///   Eigen::Index size() const { return 10; }
///   state_type state_mm(Eigen::Index i) const { return state_type(5.0 * double(i)); }
/// };
/// ```
template <class G>
concept state_grid = std::copy_constructible<G> && belief_scalar<typename G::scalar_type> &&
                     std::same_as < std::remove_cvref_t<decltype(G::dimension)>,
int > &&(G::dimension > 0) &&
    std::same_as<typename G::state_type, Eigen::Matrix<double, G::dimension, 1>>&& requires(
        const G& g, Eigen::Index i) {
  { g.rows() } -> std::same_as<Eigen::Index>;
  { g.cols() } -> std::same_as<Eigen::Index>;
  { g.size() } -> std::same_as<Eigen::Index>;
  { g.state_mm(i) } -> std::same_as<typename G::state_type>;
};

/// The flat belief (or log-likelihood) array over a grid: one value per state, layer after
/// layer, each layer a row-major `rows() x cols()` image.
template <state_grid G>
using belief_array = Eigen::Array<typename G::scalar_type, Eigen::Dynamic, 1>;

namespace detail {

/// The distance (mm) between neighbouring states of a layer along x (columns) and along y
/// (rows), from the first states' positions; 1 along an axis with a single state. For the
/// whole-layer operations that work in states but are configured in millimetres.
template <state_grid G>
[[nodiscard]] std::pair<double, double> lattice_pitch_mm(const G& grid) {
  const Eigen::Index rows = grid.rows(), cols = grid.cols();
  return {cols > 1 ? std::abs(grid.state_mm(1)(0) - grid.state_mm(0)(0)) : 1.0,
          rows > 1 ? std::abs(grid.state_mm(cols)(1) - grid.state_mm(0)(1)) : 1.0};
}

}  // namespace detail

}  // namespace tacmap
