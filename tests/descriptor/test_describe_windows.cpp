// Tests of tacmap::dense_sift::describe_windows (issue 14): the patches of every window of a map,
// computed from shared intermediates, must be what `compute` gives on each window cut from the
// map (the per-window reference path, called here directly) within 1e-5, for every window —
// those touching the map's borders included — on maps that exercise each border term: noise
// (every frame pixel's mirrored stencil matters), a ramp (the gradient is the same everywhere,
// so any stencil error shows as a constant offset), a constant map (zero descriptors), negative
// values (the peak is a magnitude), blobs on zero (weak, unnormalised descriptors), and a map
// whose windows' peaks span many orders of magnitude.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "blob_images.hpp"
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/descriptor/detail/dense_sift_windows.hpp"
#include "tacmap/measurement/descriptor_likelihood.hpp"
#include "tacmap/measurement/detail/distance_kernel.hpp"
#include "test_support.hpp"

namespace test_describe_windows {

namespace {

using tacmap::dense_sift;
using tacmap::dense_sift_params;
using tacmap::grid_cell;
using tacmap::image;
using tacmap::pixel_size;
using tacmap_test::message_of;

/// The patch offsets descriptor_likelihood uses: patches of `patch` px every `spacing` px,
/// row-major over the window.
std::vector<grid_cell> patch_offsets(pixel_size window, Eigen::Index patch, Eigen::Index spacing) {
  std::vector<grid_cell> offsets;
  for (Eigen::Index oy = 0; oy + patch <= window.height; oy += spacing)
    for (Eigen::Index ox = 0; ox + patch <= window.width; ox += spacing)
      offsets.push_back({oy, ox});
  return offsets;
}

/// describe_windows against compute(cut) for every window and patch; checks the rows arrive in
/// order with the documented shape. Returns the largest absolute difference.
template <class D>
double max_difference(const D& d, const image<typename D::scalar_type>& map, pixel_size window,
                      const std::vector<grid_cell>& offsets) {
  using T = typename D::scalar_type;
  const Eigen::Index rows = map.rows() - window.height + 1;
  const Eigen::Index cols = map.cols() - window.width + 1;
  const auto m_count = static_cast<Eigen::Index>(offsets.size());
  Eigen::Index next_row = 0;
  double worst = 0.0;
  d.describe_windows(map, window, std::span<const grid_cell>(offsets),
                     [&](Eigen::Index r, const Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic>& b) {
                       REQUIRE(r == next_row);
                       ++next_row;
                       REQUIRE(b.rows() == d.dimension());
                       REQUIRE(b.cols() == cols * m_count);
                       for (Eigen::Index c = 0; c < cols; ++c) {
                         const image<T> cut = map.block(r, c, window.height, window.width);
                         const auto f = d.compute(cut);
                         for (Eigen::Index m = 0; m < m_count; ++m) {
                           const grid_cell o = offsets[static_cast<std::size_t>(m)];
                           const double diff = static_cast<double>(
                               (b.col(c * m_count + m) - f.at(o.row, o.col)).abs().maxCoeff());
                           worst = std::max(worst, diff);
                         }
                       }
                     });
  CHECK(next_row == rows);
  return worst;
}

template <class T>
image<T> noise_map(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  image<T> img(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index c = 0; c < cols; ++c) img(r, c) = static_cast<T>(u(gen));
  return img;
}

template <class T>
image<T> ramp_map(Eigen::Index rows, Eigen::Index cols) {
  image<T> img(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index c = 0; c < cols; ++c)
      img(r, c) =
          static_cast<T>(0.1 + 0.013 * static_cast<double>(r) + 0.007 * static_cast<double>(c));
  return img;
}

template <class T>
image<T> blob_map(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::mt19937 gen(seed);
  image<T> img = image<T>::Zero(rows, cols);
  tacmap_test::add_blobs(img, gen, 6, 4.0);
  return img;
}

/// Every test map of one size: noise, ramp, constant, negative values, blobs on zero.
template <class T>
std::vector<std::pair<std::string, image<T>>> test_maps(Eigen::Index rows, Eigen::Index cols,
                                                        unsigned seed) {
  std::vector<std::pair<std::string, image<T>>> maps;
  maps.emplace_back("noise", noise_map<T>(rows, cols, seed));
  maps.emplace_back("ramp", ramp_map<T>(rows, cols));
  maps.emplace_back("constant", image<T>::Constant(rows, cols, T(0.6)));
  image<T> negative = noise_map<T>(rows, cols, seed + 1) - T(0.8);
  negative.block(0, 0, rows / 2, cols / 3) *= T(3);
  maps.emplace_back("negative", negative);
  maps.emplace_back("blobs", blob_map<T>(rows, cols, seed + 2));
  return maps;
}

/// One descriptor on every test map of each (map size, window) case, patches every 9 px.
template <class D>
void check_cases(const D& d, const std::vector<std::pair<pixel_size, pixel_size>>& cases,
                 Eigen::Index spacing = 9) {
  using T = typename D::scalar_type;
  unsigned seed = 1;
  for (const auto& [map_size, window] : cases) {
    const auto offsets = patch_offsets(window, d.patch_size(), spacing);
    REQUIRE_FALSE(offsets.empty());
    for (const auto& [name, map] : test_maps<T>(map_size.height, map_size.width, seed++)) {
      CAPTURE(name);
      CAPTURE(map_size.width);
      CAPTURE(map_size.height);
      CAPTURE(window.width);
      CAPTURE(window.height);
      CHECK(max_difference(d, map, window, offsets) <= 1e-5);
    }
  }
}

// The paper's window (42 x 18, patches down it) on a larger map, on a map the size of the window
// (one window), across (18 x 42: patches along a row), and a square window with a 2-D grid of
// patches; every map leaves windows touching each of its borders.
const std::vector<std::pair<pixel_size, pixel_size>> paper_cases = {
    {{24, 46}, {18, 42}},  // map width x height, window width x height
    {{18, 42}, {18, 42}},
    {{47, 23}, {42, 18}},
    {{38, 37}, {34, 34}},
};

/// D without H4: descriptor_likelihood prepares it the old way, one `compute` per cut window.
template <class D>
struct per_cut : D {
  template <class... A>
  void describe_windows(A&&...) const = delete;
};
static_assert(tacmap::describes_windows<tacmap::classic_sift>);
static_assert(!tacmap::describes_windows<per_cut<tacmap::classic_sift>>);

/// Per-window distances of a few touches through the model prepared with describe_windows and
/// through the old per-window loop; returns the largest difference relative to the distance.
template <class D>
double model_difference(tacmap::descriptor_likelihood_params params) {
  // The descriptors compared as floats: 7-bit storage (the default for dense_sift, not for the
  // per_cut wrapper) would round values 1e-6 apart to different steps now and then.
  params.storage = tacmap::descriptor_storage::float32;
  const image<float> map = blob_map<float>(48, 31, 11) + 0.2F * noise_map<float>(48, 31, 12);
  const pixel_size window{18, 42};
  const tacmap::planar_grid<float> grid({.width = 31, .height = 48}, 3.4 / 3.0, window);
  const tacmap::descriptor_likelihood<D> fast(D{}, map, window, params);
  const tacmap::descriptor_likelihood<per_cut<D>> reference(per_cut<D>{}, map, window, params);
  double worst = 0.0;
  for (const grid_cell at : {grid_cell{0, 0}, grid_cell{3, 7}, grid_cell{6, 13}}) {
    image<float> z = map.block(at.row, at.col, window.height, window.width);
    z += 0.05F * noise_map<float>(window.height, window.width, 20);
    Eigen::ArrayXf a(grid.size());
    Eigen::ArrayXf b(grid.size());
    fast.distances(grid, z, a);
    reference.distances(grid, z, b);
    worst = std::max(worst, static_cast<double>(((a - b).abs() / b.abs().max(1.0F)).maxCoeff()));
  }
  return worst;
}

}  // namespace

TEST_CASE(
    "describe_windows: descriptor_likelihood prepares the same model as the per-window loop") {
  using tacmap::pairing;
  for (const pairing pairs : {pairing::aligned, pairing::all_pairs}) {
    CAPTURE(static_cast<int>(pairs));
    CHECK(model_difference<tacmap::classic_sift>({.pairs = pairs}) <= 1e-5);
    CHECK(model_difference<tacmap::sift_lite>({.pairs = pairs}) <= 1e-5);
  }
  // Stored in the contrast basis (the default localizer's appearance hypotheses).
  CHECK(model_difference<tacmap::classic_sift>({.both_signs = true}) <= 1e-5);
}

TEST_CASE("describe_windows: sift_lite equals compute on each cut window") {
  check_cases(tacmap::sift_lite{}, paper_cases);
}

TEST_CASE("describe_windows: classic_sift equals compute on each cut window") {
  check_cases(tacmap::classic_sift{}, paper_cases);
}

TEST_CASE("describe_windows: double, other parameters and layouts") {
  check_cases(dense_sift<2, 8, double>{}, {{{22, 45}, {18, 42}}});
  // No normalisation (raw pooled energy: every unnormalised value, including the window-peak
  // factor, shows), a different alpha (pow path) and threshold, a smaller sigma (same 5 taps).
  dense_sift_params p = tacmap::sift_lite::default_params();
  p.norm_threshold = std::numeric_limits<double>::infinity();
  check_cases(tacmap::sift_lite(p), {{{22, 45}, {18, 42}}});
  p = tacmap::sift_lite::default_params();
  p.alpha = 4.5;
  p.norm_threshold = 0.3;
  p.sigma_edge = 0.6;
  check_cases(tacmap::sift_lite(p), {{{22, 45}, {18, 42}}});
  // Three spatial bins (odd; patch 18, bins of 6 px), 4 orientations, patches every 5 px.
  check_cases(dense_sift<3, 4>{}, {{{21, 30}, {18, 26}}, {{18, 26}, {18, 26}}}, 5);
}

TEST_CASE("describe_windows: small windows, where frame classes meet or leave no inner pixels") {
  // Patch 4 with one bin: windows of 4 px (no inner row: every pixel is in the 2 px frame),
  // 5 and 6 px, and a window the size of the map.
  dense_sift_params p;
  p.patch_size = 4;
  const dense_sift<1, 8> d(p);
  check_cases(d, {{{9, 8}, {4, 4}}, {{9, 8}, {5, 6}}, {{6, 5}, {6, 5}}, {{12, 10}, {4, 7}}}, 1);
  // Below 4 px the stencils of the first and last pixels overlap: the reference path.
  p.patch_size = 2;
  const dense_sift<2, 8> tiny(p);
  check_cases(tiny, {{{7, 6}, {2, 3}}, {{7, 6}, {3, 3}}}, 1);
}

TEST_CASE("describe_windows: sigma_edge > 1 (filters wider than the padding) takes the reference") {
  dense_sift_params p = tacmap::sift_lite::default_params();
  p.sigma_edge = 1.5;
  check_cases(tacmap::sift_lite(p), {{{22, 45}, {18, 42}}});
}

TEST_CASE("describe_windows: windows whose peaks span many orders of magnitude") {
  // A bright spot 1e9 x the rest: windows away from it are described from the map's channels
  // scaled by 1e-9 — beyond 2^24 they are cut and described on their own, below from the shared
  // intermediates; both must match.
  const tacmap::sift_lite d;
  image<float> map = noise_map<float>(48, 24, 7);
  map(45, 21) = 1e9F;
  map.block(0, 0, 20, 24) *= 1e-3F;
  const pixel_size window{18, 42};
  CHECK(max_difference(d, map, window, patch_offsets(window, 18, 9)) <= 1e-5);
  image<float> moderate = noise_map<float>(48, 24, 8);
  moderate(45, 21) = 1e5F;
  CHECK(max_difference(d, moderate, window, patch_offsets(window, 18, 9)) <= 1e-5);
}

namespace {
/// sift_lite whose describe_windows puts `value` into one element of one row of windows.
struct poisoned_rows : tacmap::sift_lite {
  float value = 0.0F;
  template <class Sink>
  void describe_windows(const tacmap::image_view<float>& map, pixel_size window,
                        std::span<const grid_cell> offsets, Sink&& sink) const {
    tacmap::sift_lite::describe_windows(map, window, offsets,
                                        [&](Eigen::Index r, const auto& block) {
                                          if (r != 2) return sink(r, block);
                                          auto poisoned = block.eval();
                                          poisoned(5, 7) = value;
                                          sink(r, poisoned);
                                        });
  }
};
static_assert(tacmap::describes_windows<poisoned_rows>);
}  // namespace

TEST_CASE("describe_windows: a non-finite descriptor value is refused in either storage") {
  // int8 storage finds them among the quantiser's clamped elements instead of reading every
  // row's values twice: it must name them as the float check does.
  const image<float> map = noise_map<float>(48, 31, 13);
  const pixel_size window{18, 42};
  using tacmap::descriptor_storage;
  for (const descriptor_storage storage : {descriptor_storage::int8, descriptor_storage::float32})
    for (const float bad :
         {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
          -std::numeric_limits<float>::infinity()}) {
      CAPTURE(static_cast<int>(storage));
      CAPTURE(bad);
      poisoned_rows d;
      d.value = bad;
      const std::string m = message_of([&] {
        const tacmap::descriptor_likelihood<poisoned_rows> model(d, map, window,
                                                                 {.storage = storage});
      });
      CHECK(m.find("poisoned_rows") != std::string::npos);
      CHECK(m.find("expected finite values") != std::string::npos);
      CHECK(m.find("element 5 of descriptor") != std::string::npos);
    }
  // A finite value above int8's range is clamped and counted, not refused.
  poisoned_rows big;
  big.value = 1e6F;
  const tacmap::descriptor_likelihood<poisoned_rows> model(big, map, window,
                                                           {.storage = descriptor_storage::int8});
  CHECK(model.stores_quantized());
  CHECK(model.quantization_clamped() >= 1U);
}

TEST_CASE("describe_windows: bad input is refused with what was expected") {
  const tacmap::sift_lite d;
  const image<float> map = noise_map<float>(50, 30, 3);
  const auto sink = [](Eigen::Index, const Eigen::ArrayXXf&) {};
  const std::vector<grid_cell> ok = {{0, 0}, {9, 0}, {18, 0}};
  const auto msg = [&](pixel_size window, std::vector<grid_cell> offsets, const image<float>& m) {
    return message_of(
        [&] { d.describe_windows(m, window, std::span<const grid_cell>(offsets), sink); });
  };
  CHECK(msg({18, 51}, ok, map).find("no larger than the map") != std::string::npos);
  CHECK(msg({0, 42}, ok, map).find("positive window") != std::string::npos);
  const std::string outside = msg({18, 42}, {{0, 0}, {25, 0}}, map);
  CHECK(outside.find("offsets[1] = (row 25, col 0)") != std::string::npos);
  CHECK(outside.find("0 <= row <= 24") != std::string::npos);
  CHECK(msg({18, 42}, {{0, 1}}, map).find("0 <= col <= 0") != std::string::npos);
  image<float> with_nan = map;
  with_nan(3, 4) = std::numeric_limits<float>::quiet_NaN();
  CHECK(msg({18, 42}, ok, with_nan).find("NaN") != std::string::npos);
}

namespace {

/// The pooled rows of every window row of `map` from a window_pooler building its fields
/// `band` window rows at a time, rows asked in `order`; one array per row (all rows in order).
template <int NumBins, int NumAngles, class T>
std::vector<Eigen::Array<T, Eigen::Dynamic, 1>> pooled_rows(
    const image<T>& map, pixel_size window, const std::vector<grid_cell>& offsets,
    Eigen::Index patch, Eigen::Index band, const std::vector<Eigen::Index>& order) {
  namespace ds = tacmap::detail::dsift;
  const Eigen::Index bin = patch / NumBins;
  const auto gradient = ds::make_gradient_taps<T>(1.0);
  const auto pooling = ds::make_pooling_taps<T>(patch, bin);
  Eigen::Array<T, NumAngles, 1> cos_a, sin_a;
  for (int k = 0; k < NumAngles; ++k) {
    cos_a(k) = static_cast<T>(std::cos(2.0 * 3.141592653589793 * k / NumAngles));
    sin_a(k) = static_cast<T>(std::sin(2.0 * 3.141592653589793 * k / NumAngles));
  }
  const image<T> scaled = map / map.abs().maxCoeff();
  ds::window_pooler<NumBins, NumAngles, T> pool(scaled, window, std::span<const grid_cell>(offsets),
                                                bin, gradient, pooling, cos_a, sin_a, 9.0, band);
  const Eigen::Index n =
      NumBins * NumBins * NumAngles * pool.cols() * static_cast<Eigen::Index>(offsets.size());
  // Factors that differ by window (as window peaks do), so that a column mix-up shows.
  std::vector<T> factor(static_cast<std::size_t>(pool.cols()));
  for (std::size_t c = 0; c < factor.size(); ++c)
    factor[c] = T(1) + T(0.25) * static_cast<T>(c % 3);
  std::vector<Eigen::Array<T, Eigen::Dynamic, 1>> out(static_cast<std::size_t>(pool.rows()));
  for (const Eigen::Index r : order) {
    auto& row = out[static_cast<std::size_t>(r)];
    row.setConstant(n, std::numeric_limits<T>::quiet_NaN());
    pool(r, factor.data(), row.data());
  }
  return out;
}

/// Banded builds of several band sizes, in order and out of order, against the whole map as one
/// band: the same bits (each field row is computed by the same operations whatever the band).
template <int NumBins, int NumAngles, class T>
void check_bands(Eigen::Index patch, Eigen::Index spacing,
                 const std::vector<std::pair<pixel_size, pixel_size>>& cases) {
  unsigned seed = 40;
  for (const auto& [map_size, window] : cases) {
    const auto offsets = patch_offsets(window, patch, spacing);
    REQUIRE_FALSE(offsets.empty());
    for (const auto& [name, map] : test_maps<T>(map_size.height, map_size.width, seed++)) {
      // Noise (every stencil matters) and blobs on zero (weak, unnormalised values); the other
      // maps are checked against the per-window reference above.
      if (name != "noise" && name != "blobs") continue;
      const Eigen::Index rows = map_size.height - window.height + 1;
      std::vector<Eigen::Index> forward(static_cast<std::size_t>(rows));
      for (Eigen::Index r = 0; r < rows; ++r) forward[static_cast<std::size_t>(r)] = r;
      const auto whole =
          pooled_rows<NumBins, NumAngles, T>(map, window, offsets, patch, rows, forward);
      std::vector<Eigen::Index> shuffled = forward;
      std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937(seed));
      for (const Eigen::Index band : {Eigen::Index{1}, Eigen::Index{7}, Eigen::Index{32}}) {
        for (const bool in_order : {true, false}) {
          if (!in_order && band != 7) continue;
          CAPTURE(name);
          CAPTURE(map_size.width);
          CAPTURE(map_size.height);
          CAPTURE(window.width);
          CAPTURE(window.height);
          CAPTURE(band);
          CAPTURE(in_order);
          const auto banded = pooled_rows<NumBins, NumAngles, T>(map, window, offsets, patch, band,
                                                                 in_order ? forward : shuffled);
          Eigen::Index differing = 0;
          for (std::size_t r = 0; r < whole.size(); ++r) {
            // Bit for bit (NaN, were a value left unwritten, differs from everything).
            differing += (banded[r] != whole[r]).count();
          }
          CHECK(differing == 0);
        }
      }
    }
  }
}

}  // namespace

TEST_CASE(
    "window_pooler: fields built in bands of window rows equal the whole-map build, bit for bit") {
  // Window heights 42 and 18 and map heights giving 1 .. 37 window rows: bands that divide the
  // rows, that leave a short last band, and bands larger than the map.
  check_bands<2, 8, float>(
      18, 9,
      {{{24, 78}, {18, 42}}, {{24, 42}, {18, 42}}, {{47, 36}, {42, 18}}, {{38, 45}, {34, 34}}});
  check_bands<4, 8, float>(16, 9, {{{20, 61}, {18, 42}}, {{37, 41}, {34, 34}}});
  check_bands<2, 8, double>(18, 9, {{{22, 61}, {18, 42}}});
  // Three bins and four orientations, patches every 5 px (several row groups).
  check_bands<3, 4, float>(18, 5, {{{21, 40}, {18, 26}}});
  // Patch 4, one bin: windows of 4 and 7 px (frame classes meeting, no inner rows).
  check_bands<1, 8, float>(4, 1, {{{9, 15}, {4, 4}}, {{12, 19}, {4, 7}}});
}

TEST_CASE("descriptor_tiles::set_columns (packet transposes) equals its scalar reference") {
  // Every alignment of the first position against a tile, runs shorter and longer than a tile,
  // and columns with a stride (every M-th column of a block, as descriptor_likelihood passes).
  std::mt19937 gen(5);
  std::uniform_real_distribution<float> u(-1.0F, 1.0F);
  for (const Eigen::Index dim : {Eigen::Index{128}, Eigen::Index{32}, Eigen::Index{12}}) {
    const Eigen::Index positions = 61;
    Eigen::ArrayXXf block(dim, 3 * positions);
    for (float& v : block.reshaped()) v = u(gen);
    for (const Eigen::Index q0 : {Eigen::Index{0}, Eigen::Index{3}, Eigen::Index{8}}) {
      for (const Eigen::Index n : {Eigen::Index{5}, Eigen::Index{29}, Eigen::Index{53}}) {
        CAPTURE(dim);
        CAPTURE(q0);
        CAPTURE(n);
        const Eigen::Map<const Eigen::ArrayXXf, 0, Eigen::OuterStride<>> columns(
            block.data() + dim, dim, n, Eigen::OuterStride<>(3 * dim));
        tacmap::detail::descriptor_tiles<float> fast(positions, dim);
        tacmap::detail::descriptor_tiles<float> scalar(positions, dim);
        fast.set_columns(q0, columns);
        scalar.set_columns_scalar(q0, columns);
        bool same = true;
        double norm_error = 0.0;
        for (Eigen::Index q = 0; q < positions; ++q) {
          for (Eigen::Index k = 0; k < dim; ++k) same = same && fast.at(q, k) == scalar.at(q, k);
          norm_error =
              std::max(norm_error, static_cast<double>(std::abs(*fast.squared_norms_from(q) -
                                                                *scalar.squared_norms_from(q))));
        }
        CHECK(same);  // the elements are copies: bit for bit
        CHECK(norm_error <= 1e-4);
        CHECK(fast.at(q0, 0) == columns(0, 0));
        CHECK(fast.at(q0 + n - 1, dim - 1) == columns(dim - 1, n - 1));
      }
    }
  }
}

}  // namespace test_describe_windows
