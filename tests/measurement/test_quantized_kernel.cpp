// The 7-bit descriptor storage and its distance kernel (issue 14) against the scalar reference,
// at the extremes of the integer range, and the quantisation's clamps.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "tacmap/measurement/detail/quantized_kernel.hpp"
#include "tacmap/simd.hpp"

namespace test_quantized_kernel {

namespace {

using tacmap::detail::quantized_query;
using tacmap::detail::quantized_tiles;

// Every kernel the build has, against the reference, summed and each, added and stored, on the
// whole map and on a range of tiles: the same bits (see quantized_kernel.hpp).
void check_against_reference(const quantized_tiles& f, const quantized_query& g) {
  const Eigen::Index n = f.positions();
  const Eigen::Index count = g.count();
  for (const bool sum : {true, false}) {
    for (const bool add : {true, false}) {
      CAPTURE(sum);
      CAPTURE(add);
      const Eigen::Index columns = sum ? 1 : count;
      Eigen::ArrayXXf ref = Eigen::ArrayXXf::Constant(n, columns, 0.25F);
      std::vector<float*> ref_out;
      for (Eigen::Index j = 0; j < columns; ++j) ref_out.push_back(&ref(0, j));
      tacmap::detail::quantized_distances_scalar(f, g, ref_out.data(), sum, add);

      const auto run = [&](auto&& kernel) {
        Eigen::ArrayXXf out = Eigen::ArrayXXf::Constant(n, columns, 0.25F);
        std::vector<float*> o;
        for (Eigen::Index j = 0; j < columns; ++j) o.push_back(&out(0, j));
        kernel(o.data(), tacmap::detail::tile_range{});
        for (Eigen::Index j = 0; j < columns; ++j)
          for (Eigen::Index q = 0; q < n; ++q) REQUIRE(out(q, j) == ref(q, j));
        // A range of tiles: the whole pass's values, relative to its first position.
        const Eigen::Index tiles = f.tiles();
        if (tiles >= 3) {
          const tacmap::detail::tile_range range{1, tiles - 1};
          Eigen::ArrayXXf part = Eigen::ArrayXXf::Constant(n, columns, 0.25F);
          std::vector<float*> p;
          for (Eigen::Index j = 0; j < columns; ++j) p.push_back(&part(0, j));
          kernel(p.data(), range);
          const Eigen::Index first = range.begin * quantized_tiles::width;
          const Eigen::Index last = std::min(n, range.end * quantized_tiles::width);
          for (Eigen::Index j = 0; j < columns; ++j)
            for (Eigen::Index q = first; q < last; ++q) REQUIRE(part(q - first, j) == ref(q, j));
        }
      };
      run([&](float* const* o, tacmap::detail::tile_range r) {
        tacmap::detail::quantized_distances(f, g, o, sum, add, r);
      });
      run([&](float* const* o, tacmap::detail::tile_range r) {
        tacmap::detail::quantized_distances_simd<xsimd::generic>(f, g, o, sum, add, r);
      });
      run([&](float* const* o, tacmap::detail::tile_range r) {
        tacmap::detail::quantized_distances_simd<tacmap::detail::kernel_arch<float>>(f, g, o, sum,
                                                                                     add, r);
      });
#if defined(TACMAP_PRECOMPILED) && TACMAP_PRECOMPILED
      for (const auto level : {tacmap::simd_level::sse2, tacmap::simd_level::avx2_fma})
        if (const auto* k = tacmap::detail::kernels_for(level))
          run([&](float* const* o, tacmap::detail::tile_range r) {
            k->quantized_distances(f, g, o, sum, add, r);
          });
#endif
    }
  }
}

}  // namespace

TEST_CASE("quantized_distances matches its scalar reference bit for bit") {
  std::mt19937 rng(14);
  // Up to 0.5: bytes up to 127, one row per widening; up to 0.25: bytes up to 64, two rows per
  // widening in the AVX2 kernel (64 x 64 <= paired_rows_bound). Dimensions with an odd number
  // of rows (5: 2 rows; 12: 3; 20: 5) end with a single row after the pairs.
  for (const float top : {0.5F, 0.25F})
    for (const Eigen::Index positions : {1, 7, 8, 9, 31, 1000}) {
      for (const Eigen::Index dim : {1, 5, 12, 20, 32, 128}) {
        std::uniform_real_distribution<float> value(0.0F, top);
        CAPTURE(top);
        CAPTURE(positions);
        CAPTURE(dim);
        Eigen::ArrayXXf f(dim, positions);
        for (float& v : f.reshaped()) v = value(rng);
        quantized_tiles tiles(positions, dim);
        REQUIRE(tiles.set_columns(0, f));
        CHECK(tiles.clamped() == 0);
        for (Eigen::Index q = 0; q < positions; q += 3)
          for (Eigen::Index k = 0; k < dim; ++k)
            REQUIRE(tiles.at(q, k) == static_cast<std::int32_t>(std::lround(f(k, q) * 254.0F)));
        for (const Eigen::Index count : {1, 2, 3, 5}) {
          CAPTURE(count);
          Eigen::ArrayXXf g(dim, count);
          for (float& v : g.reshaped()) v = value(rng);
          g.col(0) = f.col(positions / 2);  // an exact match
          quantized_query q;
          q.assign(g);
          check_against_reference(tiles, q);
          // The exact match is exactly 0: integer arithmetic has no cancellation.
          Eigen::ArrayXf d(positions);
          float* o = d.data();
          quantized_query one;
          one.assign(g.leftCols(1));
          tacmap::detail::quantized_distances(tiles, one, &o, true, false);
          CHECK(d(positions / 2) == 0.0F);
        }
      }
    }
}

TEST_CASE("quantized_distances: the extremes of the 7-bit range do not saturate") {
  // vpmaddubsw sums two u8 x s8 products in int16 with saturation: 127 x 127 + 127 x 127 =
  // 32,258 and 127 x (-127) twice = -32,258 must both come out exact. Every map element 127
  // against every touch element 127 (distance 0), -127 (the farthest) and 0.
  for (const Eigen::Index dim : {4, 128}) {
    CAPTURE(dim);
    const Eigen::Index positions = 17;
    const Eigen::ArrayXXf f = Eigen::ArrayXXf::Constant(dim, positions, 0.5F);
    quantized_tiles tiles(positions, dim);
    REQUIRE(tiles.set_columns(0, f));
    CHECK(tiles.at(3, dim - 1) == 127);
    Eigen::ArrayXXf g(dim, 3);
    g.col(0).setConstant(0.5F);
    g.col(1).setConstant(-0.5F);
    g.col(2).setZero();
    quantized_query q;
    q.assign(g);
    CHECK(q.clamped == 0);
    check_against_reference(tiles, q);
    Eigen::ArrayXXf d(positions, 3);
    float* o[3] = {&d(0, 0), &d(0, 1), &d(0, 2)};
    tacmap::detail::quantized_distances(tiles, q, o, false, false);
    const auto expect = [&](double per_element) {
      return doctest::Approx(std::sqrt(static_cast<double>(dim)) * per_element / 254.0)
          .epsilon(1e-6);
    };
    for (Eigen::Index p = 0; p < positions; ++p) {
      CHECK(d(p, 0) == 0.0F);
      CHECK(d(p, 1) == expect(254.0));
      CHECK(d(p, 2) == expect(127.0));
    }
  }
}

TEST_CASE("quantized_distances: two rows per widening only where int16 holds them") {
  // The AVX2 kernel adds two rows' vpmaddubsw pair sums in int16 (4 products per lane) when
  // map peak x touch peak <= 8,191. At 127 x 64 = 8,128 a lane reaches +-32,512: exact. At
  // 127 x 65 = 8,255 it would reach +-33,020 and wrap, so those tiles must widen one row at a
  // time: the reference (int32 throughout) would tell. Every map byte 127.
  using tacmap::detail::paired_rows_bound;
  CHECK(4 * paired_rows_bound <= 32767);
  CHECK(4 * (paired_rows_bound + 1) > 32767);
  const Eigen::Index positions = 40;  // 5 tiles: blocks of 2 (two columns) and a single one
  for (const Eigen::Index dim : {8, 12, 128}) {
    CAPTURE(dim);
    quantized_tiles tiles(positions, dim);
    REQUIRE(tiles.set_columns(0, Eigen::ArrayXXf::Constant(dim, positions, 0.5F)));
    for (Eigen::Index t = 0; t < tiles.tiles(); ++t) CHECK(tiles.peak(t) == 127);
    for (const std::int32_t b : {64, 65, 127}) {
      CAPTURE(b);
      Eigen::ArrayXXf g(dim, 2);
      g.col(0).setConstant(static_cast<float>(b) / 254.0F);
      g.col(1).setConstant(-static_cast<float>(b) / 254.0F);
      quantized_query q;
      q.assign(g);
      CHECK(q.peak(0) == b);
      CHECK(q.peak(1) == b);
      check_against_reference(tiles, q);
      for (Eigen::Index j = 0; j < 2; ++j) {  // one column: a block of 4 tiles, then one
        quantized_query one;
        one.assign(g.col(j));
        check_against_reference(tiles, one);
      }
      Eigen::ArrayXXf d(positions, 2);
      float* o[2] = {&d(0, 0), &d(0, 1)};
      tacmap::detail::quantized_distances(tiles, q, o, false, false);
      const auto expect = [&](std::int32_t per_element) {
        return doctest::Approx(std::sqrt(static_cast<double>(dim)) * per_element / 254.0)
            .epsilon(1e-6);
      };
      for (Eigen::Index p = 0; p < positions; ++p) {
        REQUIRE(d(p, 0) == expect(127 - b));
        REQUIRE(d(p, 1) == expect(127 + b));
      }
    }
  }
  // Peaks differ inside a block: a tile of 127s among tiles of small bytes (<= 77) decides its
  // whole block against touches of +-100 (4 x 127 x 100 = 50,800 would wrap), the blocks
  // without one pair (77 x 100 <= 8,191). Tile 2 is the third of a 4-tile block (one-column
  // queries) and the first of a 2-tile block (two or three columns); tile 5 the second of
  // either: a kernel that looked at one tile's peak, or at one column's, would wrap.
  std::mt19937 rng(141);
  std::uniform_real_distribution<float> small(0.0F, 0.3F);
  Eigen::ArrayXXf f(128, 80);
  for (float& v : f.reshaped()) v = small(rng);
  f.middleCols(16, 8).setConstant(0.5F);  // tile 2
  f.middleCols(40, 8).setConstant(0.5F);  // tile 5
  quantized_tiles mixed(80, 128);
  REQUIRE(mixed.set_columns(0, f.leftCols(37)));  // tiles written in two parts
  REQUIRE(mixed.set_columns(37, f.rightCols(43)));
  for (Eigen::Index t = 0; t < mixed.tiles(); ++t) {
    std::int32_t top = 0;
    for (Eigen::Index q = t * 8; q < t * 8 + 8; ++q)
      for (Eigen::Index k = 0; k < 128; ++k) top = std::max(top, mixed.at(q, k));
    CAPTURE(t);
    CHECK(mixed.peak(t) == top);
    CHECK(mixed.peak(t) == (t == 2 || t == 5 ? 127 : top));
    if (t != 2 && t != 5) CHECK(top <= 77);
  }
  Eigen::ArrayXXf g(128, 3);
  for (float& v : g.reshaped()) v = small(rng) * 0.1F;  // column 0: small bytes
  g.col(1).setConstant(100.0F / 254.0F);
  g.col(2).setConstant(-100.0F / 254.0F);
  quantized_query q;
  q.assign(g);
  CHECK(q.peak(0) <= 8);
  CHECK(q.peak(1) == 100);
  CHECK(q.peak(2) == 100);
  check_against_reference(mixed, q);
  for (Eigen::Index j = 1; j < 3; ++j) {
    CAPTURE(j);
    quantized_query one;
    one.assign(g.col(j));
    check_against_reference(mixed, one);
    quantized_query two;  // a small column first: the block's touch peak is both columns'
    Eigen::ArrayXXf pair(128, 2);
    pair << g.col(0), g.col(j);
    two.assign(pair);
    check_against_reference(mixed, two);
  }
  // Bytes written through store() may be anything: the peaks become 127 (one row per widening).
  (void)mixed.store();
  for (Eigen::Index t = 0; t < mixed.tiles(); ++t) CHECK(mixed.peak(t) == 127);
  check_against_reference(mixed, q);
  // A query whose peaks were not filled is taken as 127.
  quantized_query bare = q;
  bare.peaks.clear();
  CHECK(bare.peak(0) == 127);
  check_against_reference(mixed, bare);
}

TEST_CASE("quantize: clamps are counted, never NaN or an out-of-range byte") {
  using tacmap::detail::quantize;
  CHECK(quantize(0.25F, 0).value == 64);  // 63.5 rounds away from zero
  CHECK_FALSE(quantize(0.25F, 0).clamped);
  CHECK(quantize(0.5F, 0).value == 127);
  CHECK_FALSE(quantize(0.5F, 0).clamped);
  CHECK(quantize(0.501F, 0).value == 127);  // 127.25 rounds to 127: not a clamp
  CHECK_FALSE(quantize(0.501F, 0).clamped);
  CHECK(quantize(0.51F, 0).value == 127);  // 129.5: clamped
  CHECK(quantize(0.51F, 0).clamped);
  CHECK(quantize(1.0F, 0).value == 127);
  CHECK(quantize(std::numeric_limits<float>::max(), 0).value == 127);
  CHECK(quantize(std::numeric_limits<float>::infinity(), 0).clamped);
  CHECK(quantize(std::numeric_limits<float>::infinity(), -127).value == 127);
  CHECK(quantize(-std::numeric_limits<float>::infinity(), -127).value == -127);
  CHECK(quantize(-1.0F, -127).value == -127);
  CHECK(quantize(-1.0F, -127).clamped);
  CHECK(quantize(-1.0F, 0).value == 0);
  CHECK(quantize(std::numeric_limits<float>::quiet_NaN(), -127).value == 0);
  CHECK(quantize(std::numeric_limits<float>::quiet_NaN(), -127).clamped);
  CHECK(quantize(std::numeric_limits<float>::denorm_min(), 0).value == 0);

  // The map side: elements above the range clamped and counted; a negative one refused.
  Eigen::ArrayXXf f = Eigen::ArrayXXf::Constant(8, 3, 0.1F);
  f(2, 1) = 1.0F;
  f(5, 2) = std::numeric_limits<float>::max();
  quantized_tiles tiles(3, 8);
  REQUIRE(tiles.set_columns(0, f));
  CHECK(tiles.clamped() == 2);
  CHECK(tiles.at(1, 2) == 127);
  CHECK(tiles.at(2, 5) == 127);
  f(0, 0) = -1e-3F;
  quantized_tiles refused(3, 8);
  CHECK_FALSE(refused.set_columns(0, f));

  // The touch side: a finite descriptor always gives finite distances.
  Eigen::ArrayXXf g(8, 1);
  g << 1e30F, -1e30F, 0.0F, 0.5F, 0.2F, 0.7F, 0.0F, 0.1F;
  quantized_query q;
  q.assign(g);
  CHECK(q.clamped == 3);
  Eigen::ArrayXf d(3);
  float* o = d.data();
  tacmap::detail::quantized_distances(tiles, q, &o, true, false);
  for (Eigen::Index p = 0; p < 3; ++p) CHECK(std::isfinite(d(p)));
}

TEST_CASE("quantize rounds as std::lround inside the range, ties and their neighbours too") {
  // quantize rounds without the library call; std::lround (halves away from zero) is the
  // definition. Both signs (the touch side is signed), every tie k + 0.5 and one ulp either side.
  using tacmap::detail::quantization_scale;
  using tacmap::detail::quantize;
  for (int k = -128; k <= 127; ++k) {
    const float tie = static_cast<float>(k) + 0.5F;
    for (const float x : {tie, std::nextafter(tie, -1e3F), std::nextafter(tie, 1e3F),
                          static_cast<float>(k), std::nextafter(static_cast<float>(k), 1e3F)}) {
      if (!(x >= -127.0F && x <= 127.0F)) continue;
      const float v = x / quantization_scale;
      const float scaled = v * quantization_scale;  // what quantize rounds
      CAPTURE(x);
      CHECK(quantize(v, -127).value == static_cast<std::int32_t>(std::lround(scaled)));
      CHECK_FALSE(quantize(v, -127).clamped);
    }
  }
}

TEST_CASE("quantized_tiles::set_columns stores what quantize gives, element for element") {
  // set_columns quantises whole batches in registers (quantize_columns_simd); quantize is the
  // scalar definition. Every rounding tie k + 0.5, its neighbours one ulp away, the clamp's
  // edges, NaN, infinity, zero and denormals; dimensions with and without a remainder past the
  // batches and the 4-byte groups; every kernel the build has; float columns in place (with an
  // outer stride) and double columns through the copy.
  using tacmap::detail::quantization_scale;
  using tacmap::detail::quantize;
  using tacmap::detail::quantize_report;
  using tacmap::detail::quantized_store;
  std::vector<float> base;
  for (int k = 0; k <= 130; ++k) {
    const float tie = (static_cast<float>(k) + 0.5F) / quantization_scale;
    base.insert(base.end(), {tie, std::nextafter(tie, 0.0F), std::nextafter(tie, 2.0F),
                             static_cast<float>(k) / quantization_scale});
  }
  base.insert(base.end(),
              {0.0F, -0.0F, std::numeric_limits<float>::denorm_min(), 0.5F, 0.501F, 0.51F, 1.0F,
               std::numeric_limits<float>::max(), std::numeric_limits<float>::infinity(),
               std::numeric_limits<float>::quiet_NaN()});
  using kernel = quantize_report (*)(const float*, Eigen::Index, Eigen::Index, Eigen::Index,
                                     quantized_store, Eigen::Index);
  std::vector<std::pair<const char*, kernel>> kernels = {
      {"scalar", &tacmap::detail::quantize_columns_scalar},
      {"compile-time arch",
       &tacmap::detail::quantize_columns_simd<tacmap::detail::kernel_arch<float>>}};
#if defined(__SSE2__)
  kernels.emplace_back("sse2", &tacmap::detail::quantize_columns_simd<xsimd::sse2>);
#endif
#if defined(TACMAP_PRECOMPILED) && TACMAP_PRECOMPILED
  for (const auto level : {tacmap::simd_level::sse2, tacmap::simd_level::avx2_fma})
    if (const auto* k = tacmap::detail::kernels_for(level))
      kernels.emplace_back("precompiled", k->quantize_columns);
#endif
  for (const Eigen::Index dim : {1, 7, 8, 12, 13, 32, 128}) {
    CAPTURE(dim);
    const auto size = static_cast<Eigen::Index>(base.size());
    const Eigen::Index n = (size + dim - 1) / dim;
    std::vector<float> values = base;
    values.resize(static_cast<std::size_t>(n * dim), 0.25F);
    // Columns stored dim + 3 apart (an outer stride), the gaps filled with values that would
    // be refused (negative) if they were read.
    const Eigen::Index stride = dim + 3;
    std::vector<float> strided(static_cast<std::size_t>(n * stride), -1.0F);
    for (Eigen::Index q = 0; q < n; ++q)
      for (Eigen::Index k = 0; k < dim; ++k)
        strided[static_cast<std::size_t>(q * stride + k)] =
            values[static_cast<std::size_t>(q * dim + k)];
    const Eigen::Map<const Eigen::ArrayXXf, 0, Eigen::OuterStride<>> columns(
        strided.data(), dim, n, Eigen::OuterStride<>(stride));
    const auto check = [&](const quantized_tiles& tiles, std::uint64_t clamped_seen) {
      std::uint64_t clamped = 0;
      for (Eigen::Index q = 0; q < n; ++q) {
        std::int32_t norm = 0;
        for (Eigen::Index k = 0; k < dim; ++k) {
          const auto expected = quantize(columns(k, q), 0);
          CAPTURE(columns(k, q));
          REQUIRE(tiles.at(3 + q, k) == expected.value);
          clamped += expected.clamped ? 1U : 0U;
          norm += expected.value * expected.value;
        }
        for (Eigen::Index k = dim; k < tiles.rows() * quantized_tiles::group; ++k)
          REQUIRE(tiles.at(3 + q, k) == 0);  // the last group's padding
        REQUIRE(*tiles.squared_norms_from(3 + q) == norm);
      }
      CHECK(clamped_seen == clamped);
    };
    {
      quantized_tiles tiles(n + 3, dim);
      REQUIRE(tiles.set_columns(3, columns));
      check(tiles, tiles.clamped());
      quantized_tiles from_double(n + 3, dim);  // the copy path
      REQUIRE(from_double.set_columns(3, columns.cast<double>()));
      check(from_double, from_double.clamped());
    }
    for (const auto& [name, k] : kernels) {
      CAPTURE(name);
      // Tiles filled with garbage first: every byte of the positions set must be written.
      quantized_tiles tiles(n + 3, dim);
      REQUIRE(tiles.set_columns(0, Eigen::ArrayXXf::Constant(dim, n + 3, 0.3F)));
      const quantize_report report = k(strided.data(), stride, n, dim, tiles.store(), 3);
      CHECK_FALSE(report.negative);
      check(tiles, report.clamped);
    }
  }
  // A negative element anywhere in a column is refused, by every kernel.
  for (const Eigen::Index dim : {7, 8, 128}) {
    for (const Eigen::Index at : {Eigen::Index{0}, dim - 1}) {
      Eigen::ArrayXXf negative = Eigen::ArrayXXf::Constant(dim, 2, 0.1F);
      negative(at, 1) = -1e-30F;
      quantized_tiles refused(2, dim);
      CHECK_FALSE(refused.set_columns(0, negative));
      for (const auto& [name, k] : kernels) {
        CAPTURE(name);
        quantized_tiles tiles(2, dim);
        CHECK(k(negative.data(), dim, 2, dim, tiles.store(), 0).negative);
      }
    }
  }
}

}  // namespace test_quantized_kernel
