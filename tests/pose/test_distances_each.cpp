// detail::distances_each (one pass over the field, one output column per descriptor) against its
// scalar reference.
#include <doctest/doctest.h>

#include <random>

#include "tacmap/measurement/detail/distance_kernel.hpp"

TEST_CASE_TEMPLATE("distances_each matches distances_each_scalar", T, float, double) {
  using array = Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>;
  constexpr Eigen::Index width = tacmap::detail::descriptor_tiles<T>::width;
  std::mt19937 rng(6);
  // Position counts around the SIMD width and around multiples of 3 tiles (the kernel's block).
  for (const Eigen::Index positions :
       {Eigen::Index{1}, width - 1, width, width + 1, 2 * width, 3 * width, 3 * width + 1,
        4 * width - 1, 7 * width + 3, Eigen::Index{101}}) {
    if (positions < 1) continue;
    for (const Eigen::Index dim : {1, 5, 32, 128}) {
      // Descriptor counts that are and are not multiples of 3 (the kernel's column block).
      for (const Eigen::Index count : {1, 2, 3, 4, 5, 7, 108}) {
        if (count == 108 && dim > 32) continue;  // keeps the Debug build quick
        CAPTURE(positions);
        CAPTURE(dim);
        CAPTURE(count);
        array f(dim, positions);
        array g(dim, count);
        for (T& v : f.reshaped()) v = static_cast<T>(rng() % 1000) / T(1000);
        for (T& v : g.reshaped()) v = static_cast<T>(rng() % 1000) / T(1000);
        const Eigen::Index same = count / 2;
        const Eigen::Index at = positions - 1;  // last position: in the partial last tile
        g.col(same) = f.col(at);                // an exact match must give exactly 0
        const tacmap::detail::descriptor_tiles<T> tiles(f);
        // A stride larger than positions; the gaps must be left alone.
        const Eigen::Index stride = positions + 5;
        const T sentinel = T(-7);
        array fast = array::Constant(stride, count, sentinel);
        array ref = array::Constant(stride, count, sentinel);
        tacmap::detail::distances_each(tiles, g, fast.data(), stride);
        tacmap::detail::distances_each_scalar(tiles, g, ref.data(), stride);
        bool close = true;
        bool independent = true;
        for (Eigen::Index j = 0; j < count; ++j)
          for (Eigen::Index q = 0; q < positions; ++q) {
            const double a = static_cast<double>(fast(q, j));
            const double b = static_cast<double>(ref(q, j));
            close = close && std::abs(a - b) <= 1e-5 * (1.0 + std::abs(b));
            // Against the definition, not only the reference.
            const double d = static_cast<double>(((f.col(q) - g.col(j)).square().sum()));
            independent = independent && std::abs(a - std::sqrt(d)) <= 1e-5 * (1.0 + std::sqrt(d));
          }
        CHECK(close);
        CHECK(independent);
        CHECK(fast(at, same) == T(0));
        CHECK(ref(at, same) == T(0));
        CHECK((fast.bottomRows(stride - positions) == sentinel).all());
      }
    }
  }
}

TEST_CASE("distances_each with an output stride equal to the positions fills a dense matrix") {
  std::mt19937 rng(9);
  const Eigen::Index positions = 53;
  Eigen::ArrayXXf f(32, positions);
  Eigen::ArrayXXf g(32, 6);
  for (float& v : f.reshaped()) v = static_cast<float>(rng() % 1000) / 1000.0F;
  for (float& v : g.reshaped()) v = static_cast<float>(rng() % 1000) / 1000.0F;
  const tacmap::detail::descriptor_tiles<float> tiles(f);
  Eigen::ArrayXXf out = Eigen::ArrayXXf::Constant(positions, 6, -1.0F);
  tacmap::detail::distances_each(tiles, g, out.data(), positions);
  for (Eigen::Index j = 0; j < 6; ++j)
    for (Eigen::Index q = 0; q < positions; ++q)
      REQUIRE(out(q, j) == doctest::Approx(std::sqrt((f.col(q) - g.col(j)).square().sum())));
}
