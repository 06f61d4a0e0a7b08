#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>

#include "raw_patch_descriptor.hpp"
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/measurement/descriptor_likelihood.hpp"
#include "test_support.hpp"

namespace test_descriptor_likelihood {

using tacmap::descriptor_likelihood;
using tacmap::descriptor_likelihood_params;
using tacmap::likelihood_shape;
using tacmap::pairing;
using tacmap_test::raw_patch;
using tacmap_test::raw_patch_generic;
using grid_t = tacmap::planar_grid<float>;

namespace {

tacmap::image<float> random_image(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::mt19937 rng(seed);
  tacmap::image<float> m(rows, cols);
  for (float& v : m.reshaped()) v = static_cast<float>(rng() % 1000) / 1000.0F;
  return m;
}

// Brute force, one window at a time: gather the window's M descriptors from the dense field and
// sum the distances of eq. (1) directly.
template <class D>
Eigen::ArrayXd brute_force(const descriptor_likelihood<D>& model, const grid_t& grid,
                           const tacmap::image<float>& z, pairing pairs) {
  const auto g = model.tactile_descriptors(z);
  const auto& field = model.map_descriptors();
  Eigen::ArrayXd d(grid.size());
  for (Eigen::Index i = 0; i < grid.size(); ++i) {
    const auto cell = grid.cell(i);
    double sum = 0.0;
    for (Eigen::Index m = 0; m < model.patches_per_window(); ++m) {
      const auto o = model.patch_offset(m);
      const auto f = field.at(cell.row + o.row, cell.col + o.col).template cast<double>();
      for (Eigen::Index n = 0; n < model.patches_per_window(); ++n)
        if (pairs == pairing::all_pairs || m == n)
          sum += std::sqrt((f - g.col(n).template cast<double>()).square().sum());
    }
    d(i) = sum;
  }
  return d;
}

}  // namespace

static_assert(tacmap::measurement_model<descriptor_likelihood<raw_patch>, grid_t>);
static_assert(tacmap::euclidean_descriptor<raw_patch>);
static_assert(!tacmap::euclidean_descriptor<raw_patch_generic>);

TEST_CASE("the window-sharing fast path equals the per-window brute force") {
  const auto map = random_image(40, 30, 1);
  const grid_t grid({.width = 30, .height = 40}, 1.0, {.width = 6, .height = 14});
  const auto z = random_image(14, 6, 2);
  for (const pairing pairs : {pairing::all_pairs, pairing::aligned}) {
    const descriptor_likelihood model(
        raw_patch{}, map, grid.window_size(),
        {.spacing = 4, .features = tacmap::window_features::shared_dense, .pairs = pairs});
    REQUIRE(model.patches_per_window() == 3);  // offsets 0, 4, 8 down a 14-tall window
    const descriptor_likelihood generic(
        raw_patch_generic{}, map, grid.window_size(),
        {.spacing = 4, .features = tacmap::window_features::shared_dense, .pairs = pairs});
    Eigen::ArrayXf fast(grid.size());
    Eigen::ArrayXf slow(grid.size());
    model.distances(grid, z, fast);
    generic.distances(grid, z, slow);
    const Eigen::ArrayXd expected = brute_force(model, grid, z, pairs);
    CHECK((fast.cast<double>() - expected).abs().maxCoeff() < 1e-3 * expected.maxCoeff());
    CHECK((slow.cast<double>() - expected).abs().maxCoeff() < 1e-4 * expected.maxCoeff());
  }
}

TEST_CASE("per-window features equal describing every window cut from the map on its own") {
  // A descriptor whose value depends on the image it is computed on (normalised by that image's
  // maximum), so per-window and shared features really differ.
  struct max_normalised : raw_patch {
    tacmap::descriptor_field<float> compute(const tacmap::image<float>& img) const {
      return raw_patch::compute(img / img.maxCoeff());
    }
  };
  const auto map = random_image(30, 26, 11);
  const grid_t grid({.width = 26, .height = 30}, 1.0, {.width = 6, .height = 14});
  const auto z = random_image(14, 6, 12);
  for (const pairing pairs : {pairing::all_pairs, pairing::aligned}) {
    const descriptor_likelihood model(max_normalised{}, map, grid.window_size(),
                                      {.spacing = 4, .pairs = pairs});
    Eigen::ArrayXf fast(grid.size());
    model.distances(grid, z, fast);
    const auto g = model.tactile_descriptors(z);
    for (Eigen::Index i = 0; i < grid.size(); ++i) {
      const auto cell = grid.cell(i);
      const auto f = max_normalised{}.compute(map.block(cell.row, cell.col, 14, 6));
      double sum = 0.0;
      for (Eigen::Index m = 0; m < 3; ++m)
        for (Eigen::Index n = 0; n < 3; ++n)
          if (pairs == pairing::all_pairs || m == n)
            sum += std::sqrt((f.at(4 * m, 0) - g.col(n)).square().sum());
      CHECK(static_cast<double>(fast(i)) == doctest::Approx(sum).epsilon(1e-4));
    }
  }
}

TEST_CASE("likelihood shapes: eq. (2) inverse and exponential, with tempering") {
  const auto map = random_image(30, 30, 3);
  const grid_t grid({.width = 30, .height = 30}, 1.0, {.width = 6, .height = 14});
  const auto z = random_image(14, 6, 4);
  const descriptor_likelihood inv(
      raw_patch{}, map, grid.window_size(),
      {.spacing = 4, .shape = likelihood_shape::inverse, .epsilon = 0.01, .tempering = 0.5});
  const descriptor_likelihood expo(
      raw_patch{}, map, grid.window_size(),
      {.spacing = 4, .shape = likelihood_shape::exponential, .tau = 2.0, .tempering = 3.0});
  Eigen::ArrayXf d(grid.size()), a(grid.size()), b(grid.size());
  inv.distances(grid, z, d);
  inv.log_likelihood(grid, z, a);
  expo.log_likelihood(grid, z, b);
  for (Eigen::Index i = 0; i < grid.size(); i += 13) {
    CHECK(a(i) == doctest::Approx(-0.5 * std::log(d(i) + 0.01)).epsilon(1e-5));
    CHECK(b(i) == doctest::Approx(-3.0 * d(i) / 2.0).epsilon(1e-5));
  }
}

TEST_CASE("on a noiseless tactile image cut from the map the true window ranks first") {
  const auto map = random_image(60, 50, 5);
  const grid_t grid({.width = 50, .height = 60}, 1.0, {.width = 18, .height = 42});
  const descriptor_likelihood model(raw_patch{}, map, grid.window_size(), {.spacing = 9});
  CHECK(model.patches_per_window() == 10);  // 6-px patches at spacing 9: 5 down x 2 across
  Eigen::ArrayXf ll(grid.size());
  model.log_likelihood(grid, map.block(7, 21, 42, 18), ll);
  Eigen::Index best = 0;
  ll.maxCoeff(&best);
  CHECK(best == grid.index({7, 21}));
  CHECK(ll.allFinite());  // d = 0 at the true window: eq. (2) is guarded by epsilon
}

TEST_CASE("descriptor_likelihood rejects bad input with messages naming the value") {
  const auto map = random_image(30, 30, 6);
  const grid_t grid({.width = 30, .height = 30}, 1.0, {.width = 6, .height = 14});
  const descriptor_likelihood model(raw_patch{}, map, grid.window_size());
  Eigen::ArrayXf ll(grid.size());
  CHECK(tacmap_test::message_of([&] {
          model.log_likelihood(grid, random_image(12, 6, 1), ll);
        }).find("tactile image is 12 x 6 px (rows x cols); expected 14 x 6") != std::string::npos);
  tacmap::image<float> nan = random_image(14, 6, 1);
  nan(1, 1) = NAN;
  CHECK(tacmap_test::message_of([&] { model.log_likelihood(grid, nan, ll); }).find("NaN") !=
        std::string::npos);
  CHECK(tacmap_test::message_of([&] {
          descriptor_likelihood(raw_patch{.patch = 8}, map, {.width = 6, .height = 14});
        }).find("patch of 8 px does not fit") != std::string::npos);
  CHECK(tacmap_test::message_of([&] {
          descriptor_likelihood(raw_patch{}, random_image(10, 10, 1), {.width = 6, .height = 14});
        }).find("no larger than the map") != std::string::npos);
  CHECK(tacmap_test::message_of([&] {
          descriptor_likelihood(raw_patch{}, map, {.width = 6, .height = 14}, {.spacing = 0});
        }).find("spacing = 0") != std::string::npos);
  CHECK(tacmap_test::message_of([&] {
          descriptor_likelihood(raw_patch{}, map, {.width = 6, .height = 14}, {.epsilon = 0.0});
        }).find("epsilon = 0") != std::string::npos);
  const grid_t other({.width = 31, .height = 30}, 1.0, {.width = 6, .height = 14});
  Eigen::ArrayXf ll_other(other.size());
  CHECK(tacmap_test::message_of([&] {
          model.log_likelihood(other, random_image(14, 6, 1), ll_other);
        }).find("same map and window") != std::string::npos);
}

// ---- contrast_sign::either_per_patch ----------------------------------------------------------

namespace {

using tacmap::contrast_sign;
using tacmap::window_features;

// Raw pixels minus the described image's mean: depends on the image it is computed on, so a
// window described on its own (per_window) differs from the map's dense field (shared_dense).
template <bool Euclidean>
struct image_centred_t : tacmap_test::raw_patch_t<Euclidean> {
  tacmap::descriptor_field<float> compute(const tacmap::image<float>& img) const {
    return tacmap_test::raw_patch_t<Euclidean>::compute(img - img.mean());
  }
};

// Raw pixels minus each patch's own mean: blind to intensity offsets, patch by patch, so the
// inversion of a touch cut from an inverted map is the window's own patches exactly.
struct patch_centred : raw_patch {
  tacmap::descriptor_field<float> compute(const tacmap::image<float>& img) const {
    auto f = raw_patch::compute(img);
    f.values.rowwise() -= f.values.colwise().mean();
    return f;
  }
};

tacmap::image<float> inverted(const tacmap::image<float>& img) {
  return (img.maxCoeff() + img.minCoeff()) - img;
}

// Brute force of d(x, z) = sum_m min(||f_{x,m} - g_m||, ||f_{x,m} - g'_m||): g and g' from the
// touch and its inversion through tactile_descriptors, f_{x,m} per window (the window cut and
// described on its own) or from the map's dense field. `picked_inverted` / `picked_as_is` count
// the patch pairs where each sign was strictly the nearer one.
template <class D>
Eigen::ArrayXd brute_force_either(const descriptor_likelihood<D>& model, const grid_t& grid,
                                  const tacmap::image<float>& map, const tacmap::image<float>& z,
                                  int& picked_as_is, int& picked_inverted) {
  const auto g = model.tactile_descriptors(z);
  const auto gi = model.tactile_descriptors(inverted(z));
  const auto& field = model.map_descriptors();
  const bool per_window = model.params().features == window_features::per_window;
  Eigen::ArrayXd d(grid.size());
  for (Eigen::Index i = 0; i < grid.size(); ++i) {
    const auto cell = grid.cell(i);
    tacmap::descriptor_field<float> own;
    if (per_window)
      own = model.descriptor().compute(map.block(cell.row, cell.col, z.rows(), z.cols()).eval());
    double sum = 0.0;
    for (Eigen::Index m = 0; m < model.patches_per_window(); ++m) {
      const auto o = model.patch_offset(m);
      const Eigen::ArrayXd f =
          per_window ? own.at(o.row, o.col).template cast<double>().eval()
                     : field.at(cell.row + o.row, cell.col + o.col).template cast<double>().eval();
      const double a = std::sqrt((f - g.col(m).template cast<double>()).square().sum());
      const double b = std::sqrt((f - gi.col(m).template cast<double>()).square().sum());
      picked_as_is += a < b ? 1 : 0;
      picked_inverted += b < a ? 1 : 0;
      sum += std::min(a, b);
    }
    d(i) = sum;
  }
  return d;
}

}  // namespace

TEST_CASE("either_per_patch: the nearer sign per patch, as a brute force over windows") {
  const auto map = random_image(34, 28, 21);
  const grid_t grid({.width = 28, .height = 34}, 1.0, {.width = 6, .height = 14});
  const auto z = random_image(14, 6, 22);
  for (const window_features features :
       {window_features::per_window, window_features::shared_dense}) {
    CAPTURE(static_cast<int>(features));
    const descriptor_likelihood_params params{.spacing = 4,
                                              .features = features,
                                              .pairs = pairing::aligned,
                                              .contrast = contrast_sign::either_per_patch};
    const descriptor_likelihood fast_model(image_centred_t<true>{}, map, grid.window_size(),
                                           params);
    const descriptor_likelihood slow_model(image_centred_t<false>{}, map, grid.window_size(),
                                           params);
    REQUIRE(fast_model.patches_per_window() == 3);
    Eigen::ArrayXf fast(grid.size());
    Eigen::ArrayXf slow(grid.size());
    fast_model.distances(grid, z, fast);
    slow_model.distances(grid, z, slow);
    int as_is = 0;
    int inv = 0;
    const Eigen::ArrayXd expected = brute_force_either(fast_model, grid, map, z, as_is, inv);
    CHECK((fast.cast<double>() - expected).abs().maxCoeff() < 1e-3 * expected.maxCoeff());
    CHECK((slow.cast<double>() - expected).abs().maxCoeff() < 1e-4 * expected.maxCoeff());
    // Both signs won somewhere, so the minimum really chose.
    CHECK(as_is > 0);
    CHECK(inv > 0);
    // ... and the result is not the as_is distance.
    descriptor_likelihood_params plain = params;
    plain.contrast = contrast_sign::as_is;
    Eigen::ArrayXf one_sign(grid.size());
    descriptor_likelihood(image_centred_t<true>{}, map, grid.window_size(), plain)
        .distances(grid, z, one_sign);
    CHECK((one_sign - fast).maxCoeff() > 0.1F);
    CHECK((one_sign - fast).minCoeff() >= -1e-4F);  // a minimum never exceeds either term
  }
}

TEST_CASE("either_per_patch ranks a touch cut from the inverted map at its true window") {
  // The photo's raised parts are dark: the touch is cut from the inverted map. Its inversion is
  // the window up to an offset, which per-patch centring removes: distance 0 at the truth.
  const auto map = random_image(60, 50, 25);
  const tacmap::image<float> touch_map = inverted(map);
  const grid_t grid({.width = 50, .height = 60}, 1.0, {.width = 18, .height = 42});
  const tacmap::grid_cell truth{7, 21};
  const tacmap::image<float> touch = touch_map.block(truth.row, truth.col, 42, 18);
  for (const window_features features :
       {window_features::per_window, window_features::shared_dense}) {
    CAPTURE(static_cast<int>(features));
    Eigen::ArrayXf ll(grid.size());
    Eigen::Index best = 0;
    const descriptor_likelihood either(
        patch_centred{}, map, grid.window_size(),
        {.spacing = 9, .features = features, .contrast = contrast_sign::either_per_patch});
    either.log_likelihood(grid, touch, ll);
    ll.maxCoeff(&best);
    CHECK(best == grid.index(truth));
    // The same touch as it is does not find its window: the contrast reversal is the problem.
    const descriptor_likelihood as_is(patch_centred{}, map, grid.window_size(),
                                      {.spacing = 9, .features = features});
    as_is.log_likelihood(grid, touch, ll);
    ll.maxCoeff(&best);
    CHECK(best != grid.index(truth));
  }
}

TEST_CASE("either_per_patch is refused with all pairs, naming both settings") {
  const auto map = random_image(30, 30, 26);
  const descriptor_likelihood_params params{.pairs = pairing::all_pairs,
                                            .contrast = contrast_sign::either_per_patch};
  const std::string message = tacmap_test::message_of([&] { params.validate(); });
  CHECK(message.find("contrast = either_per_patch") != std::string::npos);
  CHECK(message.find("pairs = all_pairs") != std::string::npos);
  CHECK(tacmap_test::message_of([&] {
          descriptor_likelihood(raw_patch{}, map, {.width = 6, .height = 14}, params);
        }) == message);
  CHECK_NOTHROW(
      descriptor_likelihood_params{.contrast = contrast_sign::either_per_patch}.validate());
  CHECK(descriptor_likelihood_params{}.contrast == contrast_sign::as_is);
}

TEST_CASE("a map whose preparation cannot fit in memory is refused before allocating it") {
  // 6000 x 6000 px (144 MB as floats): per window, classic SIFT would keep 3 x 128 elements of
  // each of 36 million windows, as 7-bit integers (the default storage) with a 4-byte norm
  // each, about 14 GB, beside the dense field (18 GB; per window, no tiled copy of it).
  const tacmap::image<float> map = tacmap::image<float>::Constant(6000, 6000, 0.5F);
  const tacmap::pixel_size window{.width = 18, .height = 42};
  const std::uint64_t windows = (6000ULL - 42 + 1) * (6000ULL - 18 + 1);
  const std::uint64_t field = 1ULL * (6000 - 16 + 1) * (6000 - 16 + 1) * 128 * sizeof(float);
  const std::uint64_t needed = field + windows * 3 * (128 + 4);
  const auto available = tacmap::available_memory_bytes();
  if (!available || *available >= needed)
    return;  // a machine that could hold it: nothing to refuse
  try {
    const tacmap::descriptor_likelihood<tacmap::classic_sift> model({}, map, window);
    FAIL("expected insufficient_memory");
  } catch (const tacmap::insufficient_memory& e) {
    CHECK(e.needed_bytes == needed);
    CHECK(e.available_bytes < e.needed_bytes);
    const std::string m = e.what();
    CHECK(m.find("descriptor_likelihood") != std::string::npos);
    CHECK(m.find("per-window descriptors") != std::string::npos);
    CHECK(m.find("GB") != std::string::npos);
    CHECK(m.find("shared_dense") != std::string::npos);
  }
}

}  // namespace test_descriptor_likelihood
