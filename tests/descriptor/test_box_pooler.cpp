// Tests of detail::dsift::box_pooler, the running box sums behind dense_sift's float pooling, on
// images smaller than, around and beyond its kernel: every height and width from 1 px up to about
// twice the triangle's support, against the per-tap pooling it replaces (row_pooler), and
// dense_sift's compute and sample on every image size from one patch up, against the double
// path (which pools per tap). The running sums look b + 1 rows and columns ahead of the pooled
// value, further than the channels' zero margin on small patches: under AddressSanitizer these
// sizes catch any read outside the buffers, and a wrong zero outside the image fails the values.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/descriptor/detail/dense_sift_kernels.hpp"

namespace test_box_pooler {

namespace {

using tacmap::dense_sift;
using tacmap::dense_sift_params;
using tacmap::image;
namespace dsift = tacmap::detail::dsift;

constexpr int angles = 8;

/// Random non-negative channel values (as orientation channels are) for up to `side` x `side`
/// pixels, about a quarter exactly zero and a few 100 x larger than the rest: the integer
/// quantisation's scale is set by the largest.
std::vector<float> random_channels(Eigen::Index side, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<float> u(0.0F, 1.0F);
  std::vector<float> v(static_cast<std::size_t>(side * side * angles));
  for (float& x : v) {
    const float r = u(gen);
    x = r < 0.25F ? 0.0F : (r > 0.995F ? 100.0F * u(gen) : u(gen));
  }
  return v;
}

/// The h x w top-left corner of `source` (side x side pixels) in `orientation_channels`' layout:
/// `margin` zero pixels on every side.
std::vector<float> channel_layout(const std::vector<float>& source, Eigen::Index side,
                                  Eigen::Index h, Eigen::Index w, Eigen::Index margin) {
  const Eigen::Index row = (w + 2 * margin) * angles;
  std::vector<float> c(static_cast<std::size_t>((h + 2 * margin) * row), 0.0F);
  for (Eigen::Index y = 0; y < h; ++y) {
    std::copy_n(source.begin() + y * side * angles, w * angles,
                c.begin() + (y + margin) * row + margin * angles);
  }
  return c;
}

/// Pools rows `rows` (increasing) of every column of an h x w image with both poolers; returns
/// the largest difference relative to the largest per-tap value (0 when both are all zero).
double pooled_difference(const std::vector<dsift::pooling_tap<float>>& taps, Eigen::Index bin,
                         Eigen::Index margin, const std::vector<float>& channels, Eigen::Index h,
                         Eigen::Index w, const std::vector<Eigen::Index>& rows) {
  const Eigen::Index n = w * angles;
  dsift::row_pooler<angles, float> per_tap(taps, channels.data(), w, margin, 0, w);
  dsift::box_pooler<angles> boxes(taps, channels.data(), h, w, margin, bin, w,
                                  *std::max_element(channels.begin(), channels.end()));
  std::vector<float> expected(static_cast<std::size_t>(n));
  std::vector<float> got(static_cast<std::size_t>(n));
  double worst = 0.0;
  double peak = 0.0;
  for (const Eigen::Index y : rows) {
    per_tap(y, expected.data());
    boxes(y, got.data());
    for (std::size_t i = 0; i < expected.size(); ++i) {
      peak = std::max(peak, static_cast<double>(std::abs(expected[i])));
      worst = std::max(worst, static_cast<double>(std::abs(expected[i] - got[i])));
    }
  }
  return peak > 0.0 ? worst / peak : worst;
}

// Two differences per image size, both within 1e-5: a size where either is not is reported
// with h and w (one assertion per failing size, not per size: thousands of sizes), and the worst
// of each is checked at the end.
struct worst_pair {
  double first = 0.0;
  double second = 0.0;
  void record(Eigen::Index h, Eigen::Index w, double a, double b) {
    if (a > 1e-5 || b > 1e-5) {
      CAPTURE(h);
      CAPTURE(w);
      CHECK(a <= 1e-5);
      CHECK(b <= 1e-5);
    }
    first = std::max(first, a);
    second = std::max(second, b);
  }
  void check() const {
    CHECK(first <= 1e-5);
    CHECK(second <= 1e-5);
  }
};

}  // namespace

TEST_CASE("box_pooler equals the per-tap pooling at every size from 1 px, all rows or some") {
  // (patch, bins per side): the bin b = patch / bins. patch 2 and 4 with 2 bins have a margin of
  // only b (1 and 2 px), less than the b + 1 rows the sums look ahead; sift_lite's 18 / 2 cuts
  // the triangle's far tap; classic_sift's 16 / 4 has margin 2b and no cut; 22 / 2 is the
  // largest bin the integer path takes (11 px); 6 / 3 a bin that is not half the patch.
  struct config {
    Eigen::Index patch;
    Eigen::Index bins;
  };
  for (const config c : {config{2, 2}, config{4, 2}, config{6, 2}, config{6, 3}, config{16, 4},
                         config{18, 2}, config{22, 2}}) {
    const Eigen::Index bin = c.patch / c.bins;
    const Eigen::Index margin = c.patch / 2;
    const auto taps = dsift::make_pooling_taps<float>(c.patch, bin);
    CAPTURE(c.patch);
    CAPTURE(c.bins);
    REQUIRE(dsift::box_pooler<angles>::applies(taps, bin, margin));
    // The triangle covers 2b pixels: up to twice that, and a little beyond.
    const Eigen::Index side = 4 * bin + 3;
    const auto source = random_channels(side, static_cast<unsigned>(c.patch * 10 + c.bins));
    worst_pair worst;
    for (Eigen::Index h = 1; h <= side; ++h) {
      for (Eigen::Index w = 1; w <= side; ++w) {
        const auto channels = channel_layout(source, side, h, w, margin);
        std::vector<Eigen::Index> all(static_cast<std::size_t>(h));
        for (Eigen::Index y = 0; y < h; ++y) all[static_cast<std::size_t>(y)] = y;
        // Skipped rows, as `sample` pools them: every third, from an offset that varies.
        std::vector<Eigen::Index> some;
        for (Eigen::Index y = (h + w) % 3; y < h; y += 3) some.push_back(y);
        const double d_all = pooled_difference(taps, bin, margin, channels, h, w, all);
        worst.record(h, w, d_all, pooled_difference(taps, bin, margin, channels, h, w, some));
      }
    }
    worst.check();
  }
}

namespace {

/// Every image size from one patch to two patches and 2 px (the triangle's support, 2 bins, and
/// beyond): float `compute` and `sample` (running box sums) against double (per-tap), within
/// 1e-5.
template <int NumBins>
void check_small_images(const dense_sift_params& p) {
  const dense_sift<NumBins, angles, float> f(p);
  const dense_sift<NumBins, angles, double> d(p);
  const Eigen::Index patch = p.patch_size;
  const Eigen::Index last = 2 * patch + 2;
  std::mt19937 gen(static_cast<unsigned>(patch));
  std::uniform_real_distribution<float> u(0.0F, 1.0F);
  worst_pair worst;
  for (Eigen::Index h = patch; h <= last; ++h) {
    for (Eigen::Index w = patch; w <= last; ++w) {
      // Noise on one half, zero on the other: strong and weak (unnormalised) descriptors.
      image<float> img = image<float>::Zero(h, w);
      for (Eigen::Index r = 0; r < h; ++r) {
        for (Eigen::Index col = 0; col < w; ++col) {
          if ((r + col) % 7 < 4) img(r, col) = u(gen);
        }
      }
      const image<double> img_d = img.cast<double>();
      const auto field = f.compute(img);
      const auto expected = d.compute(img_d);
      REQUIRE(field.values.cols() == expected.values.cols());
      const double df = (field.values.template cast<double>() - expected.values).abs().maxCoeff();
      const auto samples = f.sample(img);
      const auto expected_samples = d.sample(img_d);
      REQUIRE(samples.values.cols() == expected_samples.values.cols());
      worst.record(
          h, w, df,
          (samples.values.template cast<double>() - expected_samples.values).abs().maxCoeff());
    }
  }
  worst.check();
}

dense_sift_params with_patch(Eigen::Index patch, Eigen::Index spacing) {
  dense_sift_params p;
  p.patch_size = patch;
  p.grid_spacing = spacing;
  return p;
}

}  // namespace

TEST_CASE("compute and sample pool small images as the per-tap path does, from one patch up") {
  SUBCASE("patch 2, two 1 px bins: a 1 px margin") { check_small_images<2>(with_patch(2, 1)); }
  SUBCASE("patch 4, two 2 px bins") { check_small_images<2>(with_patch(4, 3)); }
  SUBCASE("patch 6, three 2 px bins") { check_small_images<3>(with_patch(6, 2)); }
  SUBCASE("sift_lite") { check_small_images<2>(tacmap::sift_lite::default_params()); }
  SUBCASE("classic_sift") { check_small_images<4>(tacmap::classic_sift::default_params()); }
}

}  // namespace test_box_pooler
