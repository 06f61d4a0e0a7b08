// tacmap::precompiled's run-time dispatch (tacmap/simd.hpp): the float kernels of every level
// this CPU has equal their scalar references, the SSE2 level equals the header-only SSE2 kernels
// bit for bit, and whole models routed through the dispatch equal the same models computed
// through `distance()`. CTest runs this executable twice: as the CPU chooses, and with
// TACMAP_SIMD=sse2 (the baseline forced).
#include <doctest/doctest.h>

#include <cstdlib>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/filter/detail/posterior_kernel.hpp"
#include "tacmap/measurement/descriptor_likelihood.hpp"
#include "tacmap/measurement/detail/distance_kernel.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"
#include "tacmap/simd.hpp"

namespace test_simd_dispatch {

static_assert(TACMAP_PRECOMPILED, "this test links tacmap::precompiled");

namespace {

using tacmap::simd_level;
using tacmap::detail::precompiled_kernels;
using matrix = Eigen::ArrayXXf;

std::vector<const precompiled_kernels*> levels_here() {
  std::vector<const precompiled_kernels*> out;
  for (const simd_level level : {simd_level::sse2, simd_level::avx2_fma})
    if (const auto* k = tacmap::detail::kernels_for(level)) out.push_back(k);
  return out;
}

matrix random_matrix(Eigen::Index rows, Eigen::Index cols, std::mt19937& rng) {
  matrix m(rows, cols);
  for (float& v : m.reshaped()) v = static_cast<float>(rng() % 1000) / 1000.0F;
  return m;
}

void check_close(const float* got, const float* want, Eigen::Index n) {
  for (Eigen::Index i = 0; i < n; ++i)
    CHECK(static_cast<double>(got[i]) ==
          doctest::Approx(static_cast<double>(want[i])).epsilon(1e-5));
}

}  // namespace

TEST_CASE("the baseline is always there, and the chosen level is reported") {
  REQUIRE(tacmap::detail::kernels_for(simd_level::sse2) != nullptr);
  const tacmap::simd_report info = tacmap::simd_info();
  CHECK(info.precompiled);
  CHECK(!info.compiled.empty());
  const char* forced = std::getenv("TACMAP_SIMD");
  if (forced != nullptr && std::string(forced) == "sse2") {
    CHECK(info.dispatched == "sse2");
  } else {
    // The best level the CPU has.
    const bool avx2 = tacmap::detail::kernels_for(simd_level::avx2_fma) != nullptr;
    CHECK(info.dispatched == (avx2 ? "avx2+fma" : "sse2"));
  }
}

TEST_CASE("each level's distance kernels equal their scalar references") {
  std::mt19937 rng(5);
  for (const precompiled_kernels* k : levels_here()) {
    CAPTURE(tacmap::detail::simd_level_name(k->level));
    for (const Eigen::Index positions : {1, 3, 4, 9, 17, 100, 1001}) {
      for (const Eigen::Index dim : {5, 32, 128}) {
        CAPTURE(positions);
        CAPTURE(dim);
        const matrix f = random_matrix(dim, positions, rng);
        matrix g = random_matrix(dim, 5, rng);
        g.col(1) = f.col(0);  // an exact match stays exactly 0
        const tacmap::detail::descriptor_tiles<float> tiles(f);
        // accumulate_distances: all, one, two; added and stored.
        for (const bool add : {true, false}) {
          for (const auto& [first, count] :
               {std::pair<Eigen::Index, Eigen::Index>{0, 5}, {1, 1}, {3, 2}}) {
            std::vector<float> got(static_cast<std::size_t>(positions), 0.25F);
            std::vector<float> want = got;
            k->accumulate_distances(tiles, g, first, count, got.data(), add);
            tacmap::detail::accumulate_distances_scalar(tiles, g, first, count, want.data(), add);
            check_close(got.data(), want.data(), positions);
            if (first == 1 && count == 1) CHECK(got[0] == (add ? 0.25F : 0.0F));
          }
        }
        // accumulate_sign_pair (any split of the elements).
        const Eigen::Index half = dim / 2;
        std::vector<float> plus(static_cast<std::size_t>(positions), 1.0F), minus = plus;
        std::vector<float> plus_ref = plus, minus_ref = plus;
        k->accumulate_sign_pair(tiles, g.col(2).data(), half, plus.data(), minus.data(), true);
        tacmap::detail::accumulate_sign_pair_scalar(tiles, g.col(2).data(), half, plus_ref.data(),
                                                    minus_ref.data(), true);
        check_close(plus.data(), plus_ref.data(), positions);
        check_close(minus.data(), minus_ref.data(), positions);
        // distances_each: one column per descriptor, and groups summed into one column.
        std::vector<float> norms;
        tacmap::detail::squared_norms(g, norms);
        std::vector<float> each(static_cast<std::size_t>(positions * g.cols()), -1.0F);
        std::vector<float> each_ref = each;
        k->distances_each(tiles, g, norms.data(), each.data(), positions, nullptr, {}, 1);
        tacmap::detail::distances_each_scalar(tiles, g, each_ref.data(), positions);
        check_close(each.data(), each_ref.data(), positions * g.cols());
        const matrix g4 = g.leftCols(4);
        std::vector<float> norms4(norms.begin(), norms.begin() + 4);
        std::vector<float> groups(static_cast<std::size_t>(positions * 2));
        k->distances_each(tiles, g4, norms4.data(), groups.data(), positions, nullptr, {}, 2);
        for (Eigen::Index c = 0; c < 2; ++c)
          for (Eigen::Index q = 0; q < positions; ++q) {
            const auto at = [&](Eigen::Index j) {
              return static_cast<double>(each_ref[static_cast<std::size_t>(j * positions + q)]);
            };
            CHECK(static_cast<double>(groups[static_cast<std::size_t>(c * positions + q)]) ==
                  doctest::Approx(at(2 * c) + at(2 * c + 1)).epsilon(1e-5));
          }
      }
    }
  }
}

TEST_CASE("distances_each through the dispatch: a band of whole tiles, positions from its start") {
  std::mt19937 rng(8);
  const Eigen::Index positions = 200, dim = 32;
  const matrix f = random_matrix(dim, positions, rng);
  const matrix g = random_matrix(dim, 3, rng);
  const tacmap::detail::descriptor_tiles<float> tiles(f);
  std::vector<float> norms;
  tacmap::detail::squared_norms(g, norms);
  std::vector<float> all(static_cast<std::size_t>(positions * 3));
  tacmap::detail::distances_each_scalar(tiles, g, all.data(), positions);
  constexpr Eigen::Index width = tacmap::detail::descriptor_tiles<float>::width;
  const Eigen::Index t0 = 5, t1 = 11, rows = (t1 - t0) * width;
  for (const precompiled_kernels* k : levels_here()) {
    CAPTURE(tacmap::detail::simd_level_name(k->level));
    std::vector<float> band(static_cast<std::size_t>(rows * 3));
    k->distances_each(tiles, g, norms.data(), band.data(), rows, nullptr, {t0, t1}, 1);
    for (Eigen::Index j = 0; j < 3; ++j)
      check_close(band.data() + j * rows, all.data() + j * positions + t0 * width, rows);
  }
}

TEST_CASE("the SSE2 level equals the header-only SSE2 kernels bit for bit") {
  std::mt19937 rng(6);
  const matrix f = random_matrix(128, 333, rng);
  const matrix g = random_matrix(128, 3, rng);
  const tacmap::detail::descriptor_tiles<float> tiles(f);
  std::vector<float> got(333), want(333);
  tacmap::detail::kernels_for(simd_level::sse2)
      ->accumulate_distances(tiles, g, 0, 3, got.data(), false);
  tacmap::detail::accumulate_distances_simd<xsimd::sse2>(tiles, g, 0, 3, want.data(), false);
  CHECK(got == want);
}

TEST_CASE("each level's posterior kernels equal their scalar references") {
  std::mt19937 rng(7);
  for (const precompiled_kernels* k : levels_here()) {
    CAPTURE(tacmap::detail::simd_level_name(k->level));
    for (const Eigen::Index n : {1, 5, 8, 13, 8137}) {
      CAPTURE(n);
      std::vector<float> ll(static_cast<std::size_t>(n)), prior(ll.size());
      for (float& v : ll) v = -static_cast<float>(rng() % 4000) / 100.0F;
      if (n > 1) ll[0] = -std::numeric_limits<float>::infinity();  // an excluded state
      for (float& p : prior) p = static_cast<float>(rng() % 1000 + 1) / 1000.0F;
      const auto scan = k->scan_log_likelihood(ll.data(), n);
      const auto scan_ref = tacmap::detail::scan_log_likelihood_scalar(ll.data(), n);
      CHECK(scan.first_nan == scan_ref.first_nan);
      CHECK(scan.max == scan_ref.max);
      std::vector<float> out(ll.size()), ref(ll.size());
      const auto sums = k->weight_by_likelihood(prior.data(), ll.data(), scan.max, out.data(), n);
      const auto sums_ref = tacmap::detail::weight_by_likelihood_scalar(prior.data(), ll.data(),
                                                                        scan.max, ref.data(), n);
      CHECK(sums.posterior == doctest::Approx(sums_ref.posterior).epsilon(1e-5));
      CHECK(sums.likelihood == doctest::Approx(sums_ref.likelihood).epsilon(1e-5));
      check_close(out.data(), ref.data(), n);
      if (n > 1) CHECK(out[0] == 0.0F);
      ll[static_cast<std::size_t>(n - 1)] = std::numeric_limits<float>::quiet_NaN();
      CHECK(k->scan_log_likelihood(ll.data(), n).first_nan == n - 1);
    }
  }
}

TEST_CASE("each level's weighted_sum equals the plain sum of its taps") {
  std::mt19937 rng(10);
  for (const precompiled_kernels* k : levels_here()) {
    CAPTURE(tacmap::detail::simd_level_name(k->level));
    for (const Eigen::Index n : {1, 7, 8, 9, 31, 32, 33, 100, 257}) {
      CAPTURE(n);
      const matrix src = random_matrix(n, 5, rng);
      const float* sources[5];
      float weights[5];
      for (Eigen::Index t = 0; t < 5; ++t) {
        sources[t] = src.col(t).data();
        weights[t] = static_cast<float>(t + 1) / 7.0F;
      }
      std::vector<float> out(static_cast<std::size_t>(n)), want(out.size());
      k->weighted_sum(sources, weights, 5, out.data(), n);
      for (Eigen::Index i = 0; i < n; ++i) {
        float acc = 0.0F;
        for (std::size_t t = 0; t < 5; ++t) acc += weights[t] * sources[t][i];
        want[static_cast<std::size_t>(i)] = acc;
      }
      check_close(out.data(), want.data(), n);
    }
  }
}

namespace {

// SIFT-lite measured through distance() (no euclidean_distance hook): the models never reach
// the SIMD kernels with it — the reference for the dispatched models.
struct sift_lite_through_distance : tacmap::sift_lite {
  static constexpr bool euclidean_distance = false;
};

}  // namespace

TEST_CASE("models through the dispatched kernels equal the same models through distance()") {
  static_assert(!tacmap::euclidean_descriptor<sift_lite_through_distance>);
  std::mt19937 rng(9);
  tacmap::image<float> map(60, 40);
  for (float& v : map.reshaped()) v = static_cast<float>(rng() % 1000) / 1000.0F;
  const tacmap::planar_grid<float> grid({.width = 40, .height = 60}, 1.0,
                                        {.width = 18, .height = 42});
  const tacmap::image<float> z = map.block(7, 11, 42, 18);
  using tacmap::pairing;
  using tacmap::window_features;
  for (const window_features features :
       {window_features::per_window, window_features::shared_dense})
    for (const pairing pairs : {pairing::aligned, pairing::all_pairs}) {
      CAPTURE(static_cast<int>(features));
      CAPTURE(static_cast<int>(pairs));
      // The float kernels (7-bit storage, the default for sift_lite per window, has its own
      // tests against distances from the same integers: test_quantized_kernel.cpp).
      const tacmap::descriptor_likelihood_params p{
          .features = features, .pairs = pairs, .storage = tacmap::descriptor_storage::float32};
      const tacmap::descriptor_likelihood fast(tacmap::sift_lite{}, map, grid.window_size(), p);
      const tacmap::descriptor_likelihood slow(sift_lite_through_distance{}, map,
                                               grid.window_size(), p);
      Eigen::ArrayXf a(grid.size()), b(grid.size());
      fast.distances(grid, z, a);
      slow.distances(grid, z, b);
      check_close(a.data(), b.data(), grid.size());
    }
}

TEST_CASE("a precompiled SIFT-lite planar filter (extern template) localizes a touch of its map") {
  // bayes_filter<planar_grid<float>, odometry_gaussian, descriptor_likelihood<sift_lite>> is
  // declared extern here (TACMAP_PRECOMPILED): this links tacmap::precompiled's copy.
  std::mt19937 rng(12);
  tacmap::image<float> map(70, 50);
  for (float& v : map.reshaped()) v = static_cast<float>(rng() % 1000) / 1000.0F;
  const tacmap::planar_grid<float> grid({.width = 50, .height = 70}, 1.0,
                                        {.width = 18, .height = 42});
  tacmap::bayes_filter filter(
      grid, tacmap::odometry_gaussian{},
      tacmap::descriptor_likelihood<tacmap::sift_lite>({}, map, grid.window_size()));
  filter.update(map.block(9, 21, 42, 18));
  filter.predict({.dx_mm = 2.0, .dy_mm = 0.0});
  filter.update(map.block(9, 23, 42, 18));
  const auto e = filter.estimate();
  CHECK(filter.belief().sum() == doctest::Approx(1.0).epsilon(1e-4));
  CHECK(grid.cell(e.map_index).row == 9);
  CHECK(grid.cell(e.map_index).col == 23);
}

}  // namespace test_simd_dispatch
