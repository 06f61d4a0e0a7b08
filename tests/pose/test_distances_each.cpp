// detail::distances_each (one pass over the field, one output column per descriptor) against its
// scalar reference.
#include <doctest/doctest.h>

#include <random>
#include <vector>

#include "tacmap/measurement/detail/distance_kernel.hpp"

namespace test_distances_each {

namespace {
// The descriptors' squared norms, as distances_each takes them.
template <class T>
std::vector<T> norms_of(const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& g) {
  std::vector<T> n;
  tacmap::detail::squared_norms(g, n);
  return n;
}
}  // namespace

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
        tacmap::detail::distances_each(tiles, g, norms_of(g).data(), fast.data(), stride);
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
  tacmap::detail::distances_each(tiles, g, norms_of(g).data(), out.data(), positions);
  for (Eigen::Index j = 0; j < 6; ++j)
    for (Eigen::Index q = 0; q < positions; ++q)
      REQUIRE(out(q, j) == doctest::Approx(std::sqrt((f.col(q) - g.col(j)).square().sum())));
}

TEST_CASE("distances_each with position ranges computes what each descriptor needs") {
  // 7 descriptors (two groups of 3 and a single one) over 100 positions; each group needs a
  // different range. Within a range the outputs equal the full computation; whole tile blocks
  // that no descriptor of a group needs stay untouched (the sentinel).
  std::mt19937 rng(5);
  const Eigen::Index positions = 100;
  Eigen::ArrayXXf f(32, positions);
  Eigen::ArrayXXf g(32, 7);
  for (float& v : f.reshaped()) v = static_cast<float>(rng() % 1000) / 1000.0F;
  for (float& v : g.reshaped()) v = static_cast<float>(rng() % 1000) / 1000.0F;
  const tacmap::detail::descriptor_tiles<float> tiles(f);
  Eigen::ArrayXXf full(positions, 7);
  tacmap::detail::distances_each(tiles, g, norms_of(g).data(), full.data(), positions);
  const std::vector<tacmap::detail::position_range> ranges{{0, 10},   {5, 20},   {0, 0}, {60, 100},
                                                           {60, 100}, {60, 100}, {0, 0}};
  Eigen::ArrayXXf part = Eigen::ArrayXXf::Constant(positions, 7, -1.0F);
  tacmap::detail::distances_each(tiles, g, norms_of(g).data(), part.data(), positions,
                                 ranges.data());
  for (Eigen::Index j = 0; j < 7; ++j)
    for (Eigen::Index q = ranges[static_cast<std::size_t>(j)].begin;
         q < ranges[static_cast<std::size_t>(j)].end; ++q) {
      CAPTURE(j);
      CAPTURE(q);
      CHECK(part(q, j) == full(q, j));
    }
  // Group 0 needs positions 0..19 only: the last tiles (beyond the first block of 3 x 8) untouched.
  const Eigen::Index block = 3 * tacmap::detail::descriptor_tiles<float>::width;
  if (block < positions) CHECK(part(positions - 1, 0) == -1.0F);
  // The single descriptor 6 needs nothing: never computed.
  CHECK((part.col(6) == -1.0F).all());
  // Group 1 (needs 60..99): the first positions untouched.
  CHECK(part(0, 3) == -1.0F);
}

TEST_CASE("distances_each: near matches are as exact as from differences; a band of tiles") {
  // The kernel expands ||F - g||^2 = ||F||^2 + ||g||^2 - 2 F.g, which cancels near a match:
  // there it must fall back to differences (a 1e-4 perturbation would otherwise come out as
  // float noise of about 1e-3 or as 0).
  std::mt19937 rng(4);
  const Eigen::Index positions = 100;
  Eigen::ArrayXXf f(32, positions);
  for (float& v : f.reshaped()) v = static_cast<float>(rng() % 1000) / 1000.0F;
  Eigen::ArrayXXf g(32, 4);
  for (Eigen::Index j = 0; j < 4; ++j) {
    g.col(j) = f.col(10 + 17 * j);
    g(static_cast<Eigen::Index>(j * 5), j) += 1e-4F * static_cast<float>(j + 1);
  }
  const tacmap::detail::descriptor_tiles<float> tiles(f);
  Eigen::ArrayXXf out(positions, 4);
  tacmap::detail::distances_each(tiles, g, norms_of(g).data(), out.data(), positions);
  for (Eigen::Index j = 0; j < 4; ++j) {
    CAPTURE(j);
    CHECK(out(10 + 17 * j, j) == doctest::Approx(1e-4 * static_cast<double>(j + 1)).epsilon(1e-2));
  }
  // Tiles [3, 7) only, written from out[0]: the same numbers as the whole pass.
  constexpr Eigen::Index width = tacmap::detail::descriptor_tiles<float>::width;
  Eigen::ArrayXXf band = Eigen::ArrayXXf::Constant(4 * width, 4, -1.0F);
  tacmap::detail::distances_each(tiles, g, norms_of(g).data(), band.data(), band.rows(), nullptr,
                                 {3, 7});
  for (Eigen::Index j = 0; j < 4; ++j)
    CHECK((band.col(j) == out.col(j).segment(3 * width, 4 * width)).all());
}

TEST_CASE("distances_each in groups: each column is the sum of its group's distances") {
  // Groups of 2..5 descriptors (blocks of 3 inside a group, and the rest one by one), with and
  // without position ranges and a band of tiles: column c must equal the sum over descriptors
  // [c g, (c + 1) g) of the per-descriptor distances.
  std::mt19937 rng(12);
  const Eigen::Index positions = 77;
  constexpr Eigen::Index width = tacmap::detail::descriptor_tiles<float>::width;
  Eigen::ArrayXXf f(32, positions);
  for (float& v : f.reshaped()) v = static_cast<float>(rng() % 1000) / 1000.0F;
  const tacmap::detail::descriptor_tiles<float> tiles(f);
  for (const Eigen::Index group : {2, 3, 4, 5}) {
    CAPTURE(group);
    const Eigen::Index groups = 3;
    Eigen::ArrayXXf g(32, group * groups);
    for (float& v : g.reshaped()) v = static_cast<float>(rng() % 1000) / 1000.0F;
    g.col(1) = f.col(40);  // an exact match inside a group still contributes exactly 0
    Eigen::ArrayXXf each(positions, g.cols());
    tacmap::detail::distances_each_scalar(tiles, g, each.data(), positions);
    Eigen::ArrayXXf want = Eigen::ArrayXXf::Zero(positions, groups);
    for (Eigen::Index j = 0; j < g.cols(); ++j) want.col(j / group) += each.col(j);

    Eigen::ArrayXXf got = Eigen::ArrayXXf::Constant(positions, groups, -1.0F);
    tacmap::detail::distances_each(tiles, g, norms_of(g).data(), got.data(), positions, nullptr, {},
                                   group);
    CHECK(((got - want).abs() <= 1e-5F * (1.0F + want.abs())).all());

    // Ranges: group 1 needs nothing (left untouched), group 2 only positions 50..76.
    std::vector<tacmap::detail::position_range> ranges(static_cast<std::size_t>(g.cols()),
                                                       {0, positions});
    for (Eigen::Index j = group; j < 2 * group; ++j) ranges[static_cast<std::size_t>(j)] = {0, 0};
    for (Eigen::Index j = 2 * group; j < 3 * group; ++j)
      ranges[static_cast<std::size_t>(j)] = {50, positions};
    Eigen::ArrayXXf part = Eigen::ArrayXXf::Constant(positions, groups, -1.0F);
    tacmap::detail::distances_each(tiles, g, norms_of(g).data(), part.data(), positions,
                                   ranges.data(), {}, group);
    CHECK((part.col(0) == got.col(0)).all());
    CHECK((part.col(1) == -1.0F).all());
    CHECK((part.col(2).tail(positions - 50) == got.col(2).tail(positions - 50)).all());
    CHECK(part(0, 2) == -1.0F);

    // A band of tiles [2, 5), written from row 0.
    Eigen::ArrayXXf band = Eigen::ArrayXXf::Constant(3 * width, groups, -1.0F);
    tacmap::detail::distances_each(tiles, g, norms_of(g).data(), band.data(), band.rows(), nullptr,
                                   {2, 5}, group);
    for (Eigen::Index c = 0; c < groups; ++c)
      CHECK((band.col(c) == got.col(c).segment(2 * width, 3 * width)).all());
    // Both: the band of tiles [5, 10) (positions 40..79 for float) with the ranges above.
    const Eigen::Index t1 = (positions + width - 1) / width;
    Eigen::ArrayXXf both = Eigen::ArrayXXf::Constant((t1 - 5) * width, groups, -1.0F);
    tacmap::detail::distances_each(tiles, g, norms_of(g).data(), both.data(), both.rows(),
                                   ranges.data(), {5, t1}, group);
    const Eigen::Index real = positions - 5 * width;  // positions in the band
    CHECK((both.col(0).head(real) == got.col(0).tail(real)).all());
    CHECK((both.col(1) == -1.0F).all());
    for (Eigen::Index q = std::max<Eigen::Index>(50, 5 * width); q < positions; ++q)
      CHECK(both(q - 5 * width, 2) == got(q, 2));
  }
}

TEST_CASE_TEMPLATE("add_row matches add_row_scalar", T, float, double) {
  // Lengths around the SIMD width (a register's, not a tile row's); unaligned starts (src + 1,
  // dst + 3).
  constexpr auto width = static_cast<Eigen::Index>(xsimd::batch<T>::size);
  std::mt19937 rng(21);
  for (const Eigen::Index n : {Eigen::Index{0}, Eigen::Index{1}, width - 1, width, width + 1,
                               3 * width + 2, Eigen::Index{103}}) {
    if (n < 0) continue;
    CAPTURE(n);
    std::vector<T> src(static_cast<std::size_t>(n + 1));
    std::vector<T> dst(static_cast<std::size_t>(n + 4));
    for (T& v : src) v = static_cast<T>(rng() % 1000) / T(100);
    for (T& v : dst) v = static_cast<T>(rng() % 1000) / T(100);
    std::vector<T> want = dst;
    const T sum = tacmap::detail::add_row_scalar(src.data() + 1, want.data() + 3, n);
    xsimd::batch<T> acc(T(5));  // accumulates on top of what it holds
    const T tail = tacmap::detail::add_row(src.data() + 1, dst.data() + 3, n, acc);
    CHECK(dst == want);  // the same single additions, bit for bit
    const double got = static_cast<double>(xsimd::hadd(acc)) - 5.0 * width + tail;
    CHECK(got == doctest::Approx(static_cast<double>(sum)).epsilon(1e-5));
    double direct = 0.0;
    for (Eigen::Index i = 0; i < n; ++i) direct += static_cast<double>(src[std::size_t(i + 1)]);
    CHECK(got == doctest::Approx(direct).epsilon(1e-5));
  }
}

}  // namespace test_distances_each
