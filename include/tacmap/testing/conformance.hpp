// tacmap: conformance suites a user runs on their own descriptor types (doctest).
//
// Usage, in ONE test translation unit of your project (doctest's main elsewhere):
//
//   #include <doctest/doctest.h>
//   #include <tacmap/testing/conformance.hpp>
//   TEST_CASE_TEMPLATE_INVOKE(tacmap_descriptor_conformance, my_descriptor);
//
// Requirements on the descriptor type D beyond the `tacmap::descriptor` concept: D is default
// constructible (its default configuration is what gets tested) and its patch is at most 18 px
// (the paper's tactile window is 42 x 18 px). The suites check what the filter relies on:
//  * compute() gives a field of dimension() x positions, finite on textured, flat and all-zero
//    images, and rejects an image smaller than a patch or holding NaN with
//    std::invalid_argument;
//  * distance(a, a) == 0, distance(a, b) == distance(b, a) >= 0, finite;
//  * each optional hook the type declares (tacmap/descriptor/concept.hpp, H1-H4) keeps its
//    promise: `euclidean_distance` -> distance() is the Euclidean norm; `sample()` -> compute()'s
//    columns on the spacing grid, row-major; `contrast_permutation()` -> an involution without
//    fixed points that maps the image's descriptors to the inverted image's;
//    `describe_windows()` -> compute()'s columns of every window cut from a map, row by row;
//  * plugged into `descriptor_likelihood` on the paper's grid, a measurement update leaves a
//    finite, normalised posterior, and (aligned pairing) a tactile image cut from the map ranks
//    within 5 mm of its window.
#pragma once

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <stdexcept>
#include <vector>

#include "tacmap/descriptor/concept.hpp"
#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/measurement/concept.hpp"
#include "tacmap/measurement/descriptor_likelihood.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"

namespace tacmap::testing {

/// A deterministic textured test image in [0, 1]: blobs, bars and an edge (no RNG from the
/// standard library, whose distributions differ between implementations).
inline image<float> conformance_image(Eigen::Index rows, Eigen::Index cols, std::uint32_t seed) {
  image<float> img = image<float>::Zero(rows, cols);
  std::uint32_t state = seed * 2654435761U + 1U;
  const auto next = [&state] {  // xorshift32
    state ^= state << 13U;
    state ^= state >> 17U;
    state ^= state << 5U;
    return state;
  };
  for (int k = 0; k < 8; ++k) {
    const auto r0 = static_cast<Eigen::Index>(next() % static_cast<std::uint32_t>(rows));
    const auto c0 = static_cast<Eigen::Index>(next() % static_cast<std::uint32_t>(cols));
    const auto h = std::min<Eigen::Index>(rows - r0, 3 + next() % 12);
    const auto w = std::min<Eigen::Index>(cols - c0, 3 + next() % 12);
    img.block(r0, c0, h, w) += 0.3F + static_cast<float>(next() % 70) / 100.0F;
  }
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index c = 0; c < cols; ++c)
      img(r, c) += 0.2F * std::sin(0.3F * static_cast<float>(r) + 0.17F * static_cast<float>(c));
  img -= img.minCoeff();
  return img / img.maxCoeff();
}

}  // namespace tacmap::testing

TEST_CASE_TEMPLATE_DEFINE("tacmap descriptor conformance", D, tacmap_descriptor_conformance) {
  static_assert(tacmap::descriptor<D>, "the type must model tacmap::descriptor");
  using T = typename D::scalar_type;
  const D d{};
  const Eigen::Index p = d.patch_size();
  REQUIRE(d.dimension() > 0);
  REQUIRE(p > 0);
  REQUIRE(p <= 18);

  SUBCASE("compute() has the documented shape and finite values") {
    const tacmap::image<T> img = tacmap::testing::conformance_image(40, 33, 1).template cast<T>();
    const auto f = d.compute(img);
    CHECK(f.rows == 40 - p + 1);
    CHECK(f.cols == 33 - p + 1);
    CHECK(f.values.rows() == d.dimension());
    CHECK(f.values.cols() == f.rows * f.cols);
    CHECK(f.values.allFinite());
    CHECK(d.compute(tacmap::image<T>::Zero(p + 2, p + 3)).values.allFinite());
    CHECK(d.compute(tacmap::image<T>::Constant(p + 2, p + 3, T(0.5))).values.allFinite());
    CHECK_THROWS_AS((void)d.compute(tacmap::image<T>::Zero(p - 1, p + 3)), std::invalid_argument);
    // Requirement 4: NaN is refused, not described.
    tacmap::image<T> with_nan = img;
    with_nan(7, 5) = std::numeric_limits<T>::quiet_NaN();
    CHECK_THROWS_AS((void)d.compute(with_nan), std::invalid_argument);
  }

  if constexpr (tacmap::euclidean_descriptor<D>) {
    SUBCASE("H1: a descriptor that declares euclidean_distance measures the Euclidean norm") {
      // The models never call distance() for such a type: it must agree with what they use.
      const tacmap::image<T> img = tacmap::testing::conformance_image(30, 30, 4).template cast<T>();
      const auto f = d.compute(img);
      const Eigen::Index n = f.values.cols();
      for (Eigen::Index i = 0; i < n; i += 13) {
        const Eigen::Index j = (i * 5 + 7) % n;
        const double norm =
            (f.values.col(i) - f.values.col(j)).matrix().template cast<double>().norm();
        CHECK(static_cast<double>(d.distance(f.values.col(i), f.values.col(j))) ==
              doctest::Approx(norm).epsilon(1e-5));
      }
    }
  }

  if constexpr (tacmap::byte_quantizable_descriptor<D>) {
    SUBCASE("H5: a descriptor that declares byte_quantizable has elements >= 0, rarely > 0.5") {
      // descriptor_storage::int8 stores round(254 v) in [0, 127]: a negative element is refused
      // at preparation, elements above 0.5 are clamped (counted); a few, not most.
      const tacmap::image<T> img = tacmap::testing::conformance_image(40, 36, 6).template cast<T>();
      const auto f = d.compute(img);
      CHECK(f.values.minCoeff() >= T(0));
      const auto above = (f.values > T(0.5)).count();
      CHECK(above * 100 <= f.values.size());
    }
  }

  if constexpr (tacmap::samples_on_grid<D>) {
    SUBCASE("H2: sample() gives compute()'s columns on the spacing grid, row-major") {
      const tacmap::image<T> img = tacmap::testing::conformance_image(42, 29, 5).template cast<T>();
      const auto f = d.compute(img);
      const auto s = d.sample(img);
      const Eigen::Index spacing = d.grid_spacing();
      REQUIRE(spacing > 0);
      const Eigen::Index grid_rows = (f.rows - 1) / spacing + 1;
      const Eigen::Index grid_cols = (f.cols - 1) / spacing + 1;
      REQUIRE(s.values.rows() == d.dimension());
      REQUIRE(s.values.cols() == grid_rows * grid_cols);
      for (Eigen::Index i = 0; i < grid_rows; ++i)
        for (Eigen::Index j = 0; j < grid_cols; ++j) {
          CAPTURE(i);
          CAPTURE(j);
          const auto want = f.at(i * spacing, j * spacing);
          const auto got = s.values.col(i * grid_cols + j);
          CHECK(static_cast<double>((got - want).abs().maxCoeff()) <= 1e-5);
        }
    }
  }

  if constexpr (tacmap::contrast_symmetric_descriptor<D>) {
    SUBCASE("H3: contrast_permutation() maps the image's descriptors to the inverted image's") {
      const auto perm = d.contrast_permutation();
      REQUIRE(static_cast<Eigen::Index>(perm.size()) == d.dimension());
      for (std::size_t i = 0; i < perm.size(); ++i) {
        REQUIRE(perm[i] >= 0);
        REQUIRE(perm[i] < d.dimension());
        CHECK_MESSAGE(perm[i] != static_cast<Eigen::Index>(i),
                      "contrast_permutation() keeps element "
                          << i
                          << " in place: inverting the "
                             "contrast must move every element");
        CHECK_MESSAGE(perm[static_cast<std::size_t>(perm[i])] == static_cast<Eigen::Index>(i),
                      "contrast_permutation() is inconsistent: inverting twice is not the "
                      "identity (element "
                          << i << " -> " << perm[i] << " -> "
                          << perm[static_cast<std::size_t>(perm[i])] << ")");
      }
      const tacmap::image<T> img = tacmap::testing::conformance_image(36, 31, 6).template cast<T>();
      const tacmap::image<T> inverted = (img.maxCoeff() + img.minCoeff()) - img;
      const auto f = d.compute(img);
      const auto g = d.compute(inverted);
      double worst = 0.0;
      for (Eigen::Index k = 0; k < f.values.cols(); k += 11)
        for (Eigen::Index i = 0; i < d.dimension(); ++i)
          worst = std::max(
              worst, std::abs(static_cast<double>(g.values(i, k) -
                                                  f.values(perm[static_cast<std::size_t>(i)], k))));
      CHECK(worst <= 1e-4);
    }
  }

  if constexpr (tacmap::describes_windows<D>) {
    SUBCASE("H4: describe_windows() gives compute()'s columns of every cut window, row by row") {
      // Windows touching every border of the map, patches every 9 px down the paper's window.
      const tacmap::image<T> map = tacmap::testing::conformance_image(47, 25, 7).template cast<T>();
      const tacmap::pixel_size window{.width = 18, .height = 42};
      std::vector<tacmap::grid_cell> offsets;
      for (Eigen::Index oy = 0; oy + p <= window.height; oy += 9) offsets.push_back({oy, 0});
      const auto m_count = static_cast<Eigen::Index>(offsets.size());
      const Eigen::Index cols = map.cols() - window.width + 1;
      Eigen::Index next = 0;
      double worst = 0.0;
      d.describe_windows(
          map, window, std::span<const tacmap::grid_cell>(offsets),
          [&](Eigen::Index r, const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& block) {
            REQUIRE(r == next++);
            REQUIRE(block.rows() == d.dimension());
            REQUIRE(block.cols() == cols * m_count);
            for (Eigen::Index c = 0; c < cols; ++c) {
              const tacmap::image<T> cut = map.block(r, c, window.height, window.width);
              const auto f = d.compute(cut);
              for (Eigen::Index m = 0; m < m_count; ++m) {
                const tacmap::grid_cell o = offsets[static_cast<std::size_t>(m)];
                worst = std::max(
                    worst, static_cast<double>(
                               (block.col(c * m_count + m) - f.at(o.row, o.col)).abs().maxCoeff()));
              }
            }
          });
      CHECK(next == map.rows() - window.height + 1);
      CHECK(worst <= 1e-5);
    }
  }

  SUBCASE("distance is zero on itself, symmetric, finite and non-negative") {
    const tacmap::image<T> img = tacmap::testing::conformance_image(30, 30, 2).template cast<T>();
    const auto f = d.compute(img);
    const Eigen::Index n = f.values.cols();
    for (Eigen::Index i = 0; i < n; i += 17) {
      const Eigen::Index j = (i * 7 + 3) % n;
      const T self = d.distance(f.values.col(i), f.values.col(i));
      const T ab = d.distance(f.values.col(i), f.values.col(j));
      const T ba = d.distance(f.values.col(j), f.values.col(i));
      CHECK(self == doctest::Approx(0.0).epsilon(1e-6));
      CHECK(std::isfinite(static_cast<double>(ab)));
      CHECK(ab >= T(0));
      CHECK(static_cast<double>(ab) == doctest::Approx(static_cast<double>(ba)));
    }
  }

  SUBCASE("in the filter: a normalised posterior, and a cut from the map ranks near its window") {
    using grid_t = tacmap::planar_grid<T>;
    const tacmap::image<float> map = tacmap::testing::conformance_image(56, 40, 3);
    const grid_t grid({.width = 40, .height = 56}, 3.4 / 3.0, {.width = 18, .height = 42});
    const tacmap::grid_cell truth{9, 13};
    const tacmap::image<float> cut = map.block(truth.row, truth.col, 42, 18);
    // The paper's configuration (all pairs, eq. (2)): any touch leaves a proper posterior.
    tacmap::bayes_filter paper(
        grid, tacmap::odometry_gaussian{},
        tacmap::descriptor_likelihood<D>(D{}, map, grid.window_size(),
                                         tacmap::descriptor_likelihood_params::paper()));
    paper.update(cut);
    CHECK(static_cast<double>(paper.belief().sum()) == doctest::Approx(1.0).epsilon(1e-4));
    CHECK(paper.belief().allFinite());
    CHECK(paper.belief().minCoeff() >= T(0));
    // Aligned pairing makes the noiseless cut's own window the unique zero of eq. (1) (all
    // pairs keep the cross terms between different patches), so it must win within 5 mm, the
    // paper's "localized" radius.
    tacmap::bayes_filter aligned(
        grid, tacmap::odometry_gaussian{},
        tacmap::descriptor_likelihood<D>(D{}, map, grid.window_size(),
                                         {.pairs = tacmap::pairing::aligned}));
    aligned.update(cut);
    const auto e = aligned.estimate();
    CHECK((e.map_mm - grid.state_mm(grid.index(truth))).norm() < 5.0);
  }
}

namespace tacmap::testing {

/// Checks the tracking hook of a measurement model (measurement/concept.hpp) on `grid` and the
/// measurement `z`: `log_likelihood_bound()` is at least every value `log_likelihood` writes, and
/// `log_likelihood_on` writes exactly (bit for bit) those values at the states of several range
/// patterns — single states, a run across tiles, the grid's first and last states, every state.
/// Call it from a doctest test case with your model (any model satisfying `measures_on_states`).
template <class Model, class Grid>
void check_log_likelihood_on(const Model& model, const Grid& grid,
                             const typename Model::measurement_type& z) {
  static_assert(measures_on_states<Model, Grid>,
                "check_log_likelihood_on: the model has no tracking hook (log_likelihood_bound and "
                "log_likelihood_on, see tacmap/measurement/concept.hpp)");
  using scalar = typename Grid::scalar_type;
  const Eigen::Index n = grid.size();
  belief_array<Grid> full(n);
  model.log_likelihood(grid, z, full);
  const double bound = static_cast<double>(model.log_likelihood_bound());
  CHECK_MESSAGE(static_cast<double>(full.maxCoeff()) <= bound,
                "log_likelihood_bound() = " << bound << " is below a value of log_likelihood, "
                                            << full.maxCoeff());
  std::vector<std::vector<state_range>> patterns;
  patterns.push_back({{0, 1}});
  patterns.push_back({{n - 1, n}});
  patterns.push_back(
      {{0, std::min<Eigen::Index>(3, n)}, {std::min<Eigen::Index>(n / 2, n - 1), n}});
  if (n > 40) patterns.push_back({{5, 6}, {7, 29}, {30, 31}, {n - 9, n - 2}});
  patterns.push_back({{0, n}});
  for (const auto& states : patterns) {
    belief_array<Grid> out =
        belief_array<Grid>::Constant(n, std::numeric_limits<scalar>::quiet_NaN());
    model.log_likelihood_on(grid, z, out, std::span<const state_range>(states));
    for (const state_range& r : states)
      for (Eigen::Index i = r.begin; i < r.end; ++i) {
        // Bit for bit: the same value, or both NaN (which the filter rejects either way).
        const bool same = out(i) == full(i) || (std::isnan(out(i)) && std::isnan(full(i)));
        if (!same) {
          FAIL_CHECK("log_likelihood_on at state " << i << " wrote " << out(i)
                                                   << " where log_likelihood wrote " << full(i));
          return;
        }
      }
  }
}

}  // namespace tacmap::testing
