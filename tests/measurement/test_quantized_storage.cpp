// descriptor_likelihood with descriptor_storage::int8 (issue 14): the same model as with floats
// up to the quantisation, every per-window path (summed, each, both signs, tracking ranges)
// through the 7-bit tiles, and what quantisation refuses or clamps.
#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <span>
#include <stdexcept>
#include <vector>

#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/measurement/descriptor_likelihood.hpp"
#include "tacmap/measurement/detail/state_ranges.hpp"

namespace test_quantized_storage {

using tacmap::descriptor_likelihood;
using tacmap::descriptor_likelihood_params;
using tacmap::descriptor_storage;
using tacmap::pairing;
using grid_t = tacmap::planar_grid<float>;

namespace {

// A smooth random relief, so that SIFT sees structure at its scale.
tacmap::image<float> relief(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0F, 6.28F);
  const float a = u(rng), b = u(rng), c = u(rng);
  tacmap::image<float> m(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index k = 0; k < cols; ++k) {
      const auto y = static_cast<float>(r), x = static_cast<float>(k);
      m(r, k) = 0.5F + 0.2F * std::sin(0.31F * x + a) * std::cos(0.23F * y + b) +
                0.15F * std::sin(0.17F * (x + y) + c) + 0.05F * std::sin(0.9F * x - 0.7F * y);
    }
  return m;
}

descriptor_likelihood_params with(descriptor_storage storage, pairing pairs = pairing::aligned) {
  descriptor_likelihood_params p;
  p.storage = storage;
  p.pairs = pairs;
  return p;
}

// A descriptor with signed elements. Declaring them quantisable (H5) is a lie the 7-bit map
// storage refuses; without the declaration the model keeps floats.
template <bool Quantizable>
struct signed_patch {
  using scalar_type = float;
  static constexpr bool euclidean_distance = true;
  static constexpr bool byte_quantizable = Quantizable;
  [[nodiscard]] Eigen::Index dimension() const { return 4; }
  [[nodiscard]] Eigen::Index patch_size() const { return 2; }
  [[nodiscard]] tacmap::descriptor_field<float> compute(const tacmap::image<float>& img) const {
    tacmap::descriptor_field<float> f;
    f.rows = img.rows() - 1;
    f.cols = img.cols() - 1;
    f.values.resize(4, f.rows * f.cols);
    for (Eigen::Index r = 0; r < f.rows; ++r)
      for (Eigen::Index c = 0; c < f.cols; ++c)
        f.values.col(r * f.cols + c) << img(r, c) - 0.5F, img(r, c + 1) - 0.5F,
            img(r + 1, c) - 0.5F, img(r + 1, c + 1) - 0.5F;
    return f;
  }
  [[nodiscard]] float distance(const Eigen::Ref<const Eigen::ArrayXf>& a,
                               const Eigen::Ref<const Eigen::ArrayXf>& b) const {
    return std::sqrt((a - b).square().sum());
  }
};

}  // namespace

TEST_CASE("int8 storage: the float model's distances up to quantisation, same best window") {
  const auto map = relief(70, 60, 3);
  const grid_t grid({.width = 60, .height = 70}, 1.0, {.width = 18, .height = 42});
  for (const pairing pairs : {pairing::aligned, pairing::all_pairs}) {
    CAPTURE(static_cast<int>(pairs));
    const descriptor_likelihood exact(tacmap::classic_sift{}, map, grid.window_size(),
                                      with(descriptor_storage::float32, pairs));
    const descriptor_likelihood bytes(tacmap::classic_sift{}, map, grid.window_size(),
                                      with(descriptor_storage::int8, pairs));
    CHECK_FALSE(exact.stores_quantized());
    REQUIRE(bytes.stores_quantized());
    const tacmap::image<float> z = map.block(11, 23, 42, 18);
    Eigen::ArrayXf de(grid.size()), dq(grid.size());
    exact.distances(grid, z, de);
    bytes.distances(grid, z, dq);
    // Each element is off by at most half a step, 1/508, on each side: a distance of 128
    // elements by at most sqrt(128) / 254 per patch pair.
    const double bound =
        static_cast<double>(pairs == pairing::aligned ? 3 : 9) * std::sqrt(128.0) / 254.0;
    CHECK((de - dq).abs().maxCoeff() <= bound);
    CHECK((de - dq).abs().mean() < 0.1 * bound);
    Eigen::Index best_e = 0, best_q = 0;
    de.minCoeff(&best_e);
    dq.minCoeff(&best_q);
    CHECK(best_q == best_e);
    CHECK(best_q == grid.index({11, 23}));
    // Aligned: a touch cut from its own window is exactly 0, in integers.
    if (pairs == pairing::aligned) CHECK(dq(best_q) == 0.0F);
  }
}

TEST_CASE("int8 storage: each image, both signs and tracking ranges use the same tiles") {
  const auto map = relief(64, 50, 7);
  const grid_t grid({.width = 50, .height = 64}, 1.0, {.width = 18, .height = 42});
  auto p = with(descriptor_storage::int8);
  p.both_signs = true;
  const descriptor_likelihood both(tacmap::classic_sift{}, map, grid.window_size(), p);
  const descriptor_likelihood plain(tacmap::classic_sift{}, map, grid.window_size(),
                                    with(descriptor_storage::int8));
  REQUIRE(both.stores_quantized());
  const tacmap::image<float> z = map.block(5, 20, 42, 18);
  const Eigen::Index n = grid.size();

  // Both signs in one pass against each sign on its own: the inverted touch's descriptors are
  // the permuted ones up to the last bits of the descriptor's arithmetic.
  Eigen::ArrayXf two(2 * n), inverted(n), as_is(n);
  both.log_likelihood_both_signs(grid, z, two.data());
  plain.log_likelihood(grid, z, as_is);
  const tacmap::image<float> zi = tacmap::detail::inverted_contrast(z);
  plain.log_likelihood(grid, zi, inverted);
  CHECK((two.head(n) - as_is).abs().maxCoeff() < 0.2F);
  CHECK((two.tail(n) - inverted).abs().maxCoeff() < 0.2F);
  CHECK(two.head(n).maxCoeff() == as_is.maxCoeff());

  // log_likelihood_each: the same values as one image at a time, bit for bit.
  const tacmap::image<float> images[2] = {z, map.block(12, 3, 42, 18)};
  Eigen::ArrayXf each(2 * n), one(n);
  plain.log_likelihood_each(grid, std::span<const tacmap::image<float>>(images), each.data());
  for (Eigen::Index k = 0; k < 2; ++k) {
    plain.log_likelihood(grid, images[k], one);
    CHECK((each.segment(k * n, n) == one).all());
  }

  // Tracking ranges: the whole pass's values bit for bit, plain and both signs.
  const std::vector<tacmap::state_range> states = {{17, 40}, {300, 301}, {n - 9, n}};
  Eigen::ArrayXf on(n);
  plain.log_likelihood_on(grid, z, on, states);
  Eigen::ArrayXf two_on(2 * n);
  both.log_likelihood_both_signs_on(grid, z, two_on.data(), states);
  for (const auto& s : states)
    for (Eigen::Index i = s.begin; i < s.end; ++i) {
      CHECK(on(i) == as_is(i));
      CHECK(two_on(i) == two(i));
      CHECK(two_on(n + i) == two(n + i));
    }
}

TEST_CASE("int8 storage: where it does not apply, and what it refuses or clamps") {
  const auto map = relief(60, 40, 11);
  const grid_t grid({.width = 40, .height = 60}, 1.0, {.width = 18, .height = 42});
  auto shared = with(descriptor_storage::int8);
  shared.features = tacmap::window_features::shared_dense;
  CHECK_FALSE(descriptor_likelihood(tacmap::classic_sift{}, map, grid.window_size(), shared)
                  .stores_quantized());
  CHECK(descriptor_likelihood_params::paper().storage == descriptor_storage::float32);

  // SIFT on a smooth map stays below 0.5: nothing clamped, on the map or a touch.
  const descriptor_likelihood model(tacmap::classic_sift{}, map, grid.window_size(),
                                    with(descriptor_storage::int8));
  CHECK(model.quantization_clamped() == 0);
  CHECK(model.quantization_clamped(map.block(3, 4, 42, 18)) == 0);
  // A touch of one sharp edge: few strong bins, some elements above 0.5 (clamped, counted),
  // and finite distances all the same.
  tacmap::image<float> edge = tacmap::image<float>::Zero(42, 18);
  edge.rightCols(9).setOnes();
  const auto g = model.tactile_descriptors(edge);
  const auto above = static_cast<std::uint64_t>((g * 254.0F >= 127.5F).count());
  CHECK(model.quantization_clamped(edge) == above);
  Eigen::ArrayXf ll(grid.size());
  model.log_likelihood(grid, edge, ll);
  CHECK(ll.allFinite());

  // Signed descriptor elements: refused at preparation, naming the remedy.
  const tacmap::pixel_size window{.width = 4, .height = 6};
  static_assert(tacmap::byte_quantizable_descriptor<tacmap::classic_sift>);
  static_assert(tacmap::byte_quantizable_descriptor<signed_patch<true>>);
  static_assert(!tacmap::byte_quantizable_descriptor<signed_patch<false>>);
  CHECK_THROWS_WITH_AS(descriptor_likelihood(signed_patch<true>{}, map, window,
                                             {.spacing = 2, .storage = descriptor_storage::int8}),
                       doctest::Contains("descriptor_storage::float32"), std::invalid_argument);
  CHECK_NOTHROW(descriptor_likelihood(signed_patch<true>{}, map, window,
                                      {.spacing = 2, .storage = descriptor_storage::float32}));
  CHECK_FALSE(descriptor_likelihood(signed_patch<false>{}, map, window,
                                    {.spacing = 2, .storage = descriptor_storage::int8})
                  .stores_quantized());
}

}  // namespace test_quantized_storage
