// The xsimd distance kernel of descriptor_likelihood against its scalar reference.
#include <doctest/doctest.h>

#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "tacmap/measurement/detail/distance_kernel.hpp"

namespace test_distance_kernel {

TEST_CASE_TEMPLATE("accumulate_distances matches its scalar reference", T, float, double) {
  std::mt19937 rng(21);
  for (const Eigen::Index positions : {1, 7, 8, 9, 31, 1000}) {
    for (const Eigen::Index dim : {1, 5, 32, 128}) {
      CAPTURE(positions);
      CAPTURE(dim);
      Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic> f(dim, positions);
      Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic> g(dim, 5);
      for (T& v : f.reshaped()) v = static_cast<T>(rng() % 1000) / T(1000);
      for (T& v : g.reshaped()) v = static_cast<T>(rng() % 1000) / T(1000);
      g.col(2) = f.col(0);  // an exact match: distance 0 must come out as 0, not noise
      const tacmap::detail::descriptor_tiles<T> tiles(f);
      for (Eigen::Index q = 0; q < positions; q += 3)
        for (Eigen::Index k = 0; k < dim; ++k) REQUIRE(tiles.at(q, k) == f(k, q));
      for (const auto& [first, count] :
           {std::pair<Eigen::Index, Eigen::Index>{0, 5}, {2, 1}, {1, 3}, {3, 2}}) {
        Eigen::Array<T, Eigen::Dynamic, 1> fast =
            Eigen::Array<T, Eigen::Dynamic, 1>::Constant(positions, T(0.5));
        Eigen::Array<T, Eigen::Dynamic, 1> ref = fast;
        tacmap::detail::accumulate_distances(tiles, g, first, count, fast.data());
        tacmap::detail::accumulate_distances_scalar(tiles, g, first, count, ref.data());
        for (Eigen::Index q = 0; q < positions; ++q)
          CHECK(static_cast<double>(fast(q)) ==
                doctest::Approx(static_cast<double>(ref(q))).epsilon(1e-5));
        if (first == 2 && count == 1) CHECK(fast(0) == T(0.5));  // + exactly 0
        // Stored instead of added: the same sums without the 0.5 already in the buffer.
        Eigen::Array<T, Eigen::Dynamic, 1> stored =
            Eigen::Array<T, Eigen::Dynamic, 1>::Constant(positions, T(7));
        Eigen::Array<T, Eigen::Dynamic, 1> stored_ref = stored;
        tacmap::detail::accumulate_distances(tiles, g, first, count, stored.data(), false);
        tacmap::detail::accumulate_distances_scalar(tiles, g, first, count, stored_ref.data(),
                                                    false);
        for (Eigen::Index q = 0; q < positions; ++q)
          CHECK(static_cast<double>(stored(q)) ==
                doctest::Approx(static_cast<double>(stored_ref(q))).epsilon(1e-5));
        if (first == 2 && count == 1) CHECK(stored(0) == T(0));
      }
    }
  }
}

TEST_CASE("accumulate_distances: a near match is as exact as from differences") {
  // ||F||^2 + ||g||^2 - 2 F.g cancels near a match; the kernel recomputes such lanes.
  std::mt19937 rng(5);
  Eigen::ArrayXXf f(32, 40);
  for (float& v : f.reshaped()) v = static_cast<float>(rng() % 1000) / 1000.0F;
  Eigen::ArrayXXf g(32, 3);
  for (Eigen::Index j = 0; j < 3; ++j) {
    g.col(j) = f.col(20);
    g(j, j) += 2e-4F;
  }
  const tacmap::detail::descriptor_tiles<float> tiles(f);
  Eigen::ArrayXf out(40);
  tacmap::detail::accumulate_distances(tiles, g, 0, 3, out.data(), false);
  CHECK(out(20) == doctest::Approx(6e-4).epsilon(1e-2));
}

TEST_CASE_TEMPLATE("accumulate_sign_pair matches its scalar reference, both signs", T, float,
                   double) {
  std::mt19937 rng(8);
  for (const Eigen::Index positions : {1, 7, 8, 9, 33, 40, 1000}) {
    for (const Eigen::Index half : {1, 16, 64}) {
      CAPTURE(positions);
      CAPTURE(half);
      const Eigen::Index dim = 2 * half;
      Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic> f(dim, positions);
      for (T& v : f.reshaped()) v = static_cast<T>(rng() % 1000) / T(1000) - T(0.5);
      Eigen::Array<T, Eigen::Dynamic, 1> g = f.col(positions / 2);  // exact match for "plus"
      Eigen::Array<T, Eigen::Dynamic, 1> g_minus = g;
      g_minus.tail(half) = -g.tail(half);
      const Eigen::Index other = positions - 1;  // an exact match for "minus" (positions > 2)
      if (positions > 2) f.col(other) = g_minus;
      const tacmap::detail::descriptor_tiles<T> tiles(f);
      for (const bool add : {false, true}) {
        Eigen::Array<T, Eigen::Dynamic, 1> plus = Eigen::Array<T, Eigen::Dynamic, 1>::Constant(
                                               positions, T(0.25)),
                                           minus = plus, plus_ref = plus, minus_ref = plus;
        tacmap::detail::accumulate_sign_pair(tiles, g.data(), half, plus.data(), minus.data(), add);
        tacmap::detail::accumulate_sign_pair_scalar(tiles, g.data(), half, plus_ref.data(),
                                                    minus_ref.data(), add);
        for (Eigen::Index q = 0; q < positions; ++q) {
          CHECK(static_cast<double>(plus(q)) ==
                doctest::Approx(static_cast<double>(plus_ref(q))).epsilon(1e-5));
          CHECK(static_cast<double>(minus(q)) ==
                doctest::Approx(static_cast<double>(minus_ref(q))).epsilon(1e-5));
        }
        const T base = add ? T(0.25) : T(0);
        CHECK(plus(positions / 2) == base);  // exact matches come out exactly
        if (positions > 2) CHECK(minus(other) == base);
      }
    }
  }
}

TEST_CASE("contrast_basis: distances kept, the permutation becomes a sign flip") {
  // A permutation swapping 0 <-> 3, 1 <-> 2, 4 <-> 5.
  const std::vector<Eigen::Index> perm{3, 2, 1, 0, 5, 4};
  const tacmap::detail::contrast_basis basis(perm);
  CHECK(basis.half() == 3);
  std::mt19937 rng(2);
  Eigen::ArrayXd a(6), b(6), pb(6), ta(6), tb(6), tpb(6);
  for (double& v : a) v = static_cast<double>(rng() % 100) / 100.0;
  for (double& v : b) v = static_cast<double>(rng() % 100) / 100.0;
  for (Eigen::Index k = 0; k < 6; ++k) pb(k) = b(perm[static_cast<std::size_t>(k)]);
  basis.apply(a, ta);
  basis.apply(b, tb);
  basis.apply(pb, tpb);
  CHECK(std::sqrt((ta - tb).square().sum()) == doctest::Approx(std::sqrt((a - b).square().sum())));
  CHECK((tpb.head(3) - tb.head(3)).abs().maxCoeff() < 1e-12);
  CHECK((tpb.tail(3) + tb.tail(3)).abs().maxCoeff() < 1e-12);
  // Not an involution without fixed points: refused, naming the element.
  const auto bad = [](std::vector<Eigen::Index> p) {
    try {
      tacmap::detail::contrast_basis{p};
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  CHECK(bad({0, 1}).find("element 0 maps to 0") != std::string::npos);
  CHECK(bad({1, 2, 0}).find("expected an involution") != std::string::npos);
}

}  // namespace test_distance_kernel
