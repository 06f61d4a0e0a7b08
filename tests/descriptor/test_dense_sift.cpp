// Tests of tacmap::dense_sift: the fast whole-image path against the scalar reference, known
// answers on synthetic images, positions, normalisation and input validation.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

#include "blob_images.hpp"
#include "dense_sift_reference.hpp"
#include "tacmap/descriptor/dense_sift.hpp"

namespace test_dense_sift {

namespace {

using tacmap::classic_sift;
using tacmap::dense_sift;
using tacmap::dense_sift_params;
using tacmap::image;
using tacmap::sift_lite;

template <class T>
image<T> random_image(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  image<T> img(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r) {
    for (Eigen::Index c = 0; c < cols; ++c) img(r, c) = static_cast<T>(u(gen));
  }
  return img;
}

/// Mostly empty, like a tactile image: zero with a couple of soft blobs of random size,
/// position and height. Gives both weak (unnormalised) and strong descriptors.
template <class T>
image<T> tactile_like_image(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::mt19937 gen(seed);
  image<T> img = image<T>::Zero(rows, cols);
  tacmap_test::add_blobs(img, gen, 2, 2.0);
  return img;
}

template <class T>
dsift_reference::mat to_mat(const image<T>& img) {
  dsift_reference::mat m(img.rows(), img.cols());
  for (Eigen::Index r = 0; r < img.rows(); ++r) {
    for (Eigen::Index c = 0; c < img.cols(); ++c) m(r + 1, c + 1) = static_cast<double>(img(r, c));
  }
  return m;
}

template <class D>
dsift_reference::params reference_params(const D& d) {
  dsift_reference::params p;
  p.num_bins = D::num_bins;
  p.num_angles = D::num_angles;
  p.patch = d.params().patch_size;
  p.spacing = d.params().grid_spacing;
  p.sigma_edge = d.params().sigma_edge;
  p.alpha = d.params().alpha;
  p.threshold = d.params().norm_threshold;
  p.clamp = d.params().clamp;
  return p;
}

double norm_of(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return std::sqrt(s);
}

/// How many reference descriptors were normalised (strong) and left alone (weak), so a test can
/// show that it exercised both branches.
struct branch_counts {
  int strong = 0;
  int weak = 0;
};

/// Compares `d.compute(img)` with the reference on `img`; returns the largest absolute
/// difference and counts the branches.
template <class D>
double max_difference_to_reference(const D& d, const image<typename D::scalar_type>& img,
                                   branch_counts& counts) {
  const auto field = d.compute(img);
  // The reference without normalisation, normalised here: the raw norm tells which branch each
  // descriptor took.
  const auto prm = reference_params(d);
  auto raw_prm = prm;
  raw_prm.threshold = std::numeric_limits<double>::infinity();
  const auto raw = dsift_reference::compute(to_mat(img), raw_prm);
  REQUIRE(field.rows == raw.rows);
  REQUIRE(field.cols == raw.cols);
  REQUIRE(field.values.rows() == d.dimension());
  REQUIRE(field.values.cols() == raw.rows * raw.cols);
  double worst = 0.0;
  for (Eigen::Index i = 0; i < field.values.cols(); ++i) {
    auto expected = raw.d[static_cast<std::size_t>(i)];
    dsift_reference::normalise(expected, prm);
    for (Eigen::Index k = 0; k < d.dimension(); ++k) {
      worst = std::max(worst, std::abs(static_cast<double>(field.values(k, i)) -
                                       expected[static_cast<std::size_t>(k)]));
    }
    if (norm_of(raw.d[static_cast<std::size_t>(i)]) > d.params().norm_threshold) {
      ++counts.strong;
    } else {
      ++counts.weak;
    }
  }
  return worst;
}

template <class D>
void check_against_reference(const D& d, double tolerance) {
  const std::vector<std::pair<Eigen::Index, Eigen::Index>> sizes = {
      {d.patch_size(), d.patch_size()}, {42, 18}, {25, 31}, {33, 20}, {40, 47}};
  branch_counts counts;
  unsigned seed = 7;
  for (const auto& size : sizes) {
    const Eigen::Index rows = size.first;  // not structured bindings: CAPTURE is a lambda
    const Eigen::Index cols = size.second;
    if (rows < d.patch_size() || cols < d.patch_size()) continue;
    CAPTURE(rows);
    CAPTURE(cols);
    using T = typename D::scalar_type;
    CHECK(max_difference_to_reference(d, random_image<T>(rows, cols, ++seed), counts) <= tolerance);
    CHECK(max_difference_to_reference(d, tactile_like_image<T>(rows, cols, ++seed), counts) <=
          tolerance);
  }
  // Both normalisation branches were compared.
  CHECK(counts.strong > 0);
  CHECK(counts.weak > 0);
}

/// rot90 counter-clockwise (as displayed, y down): out(i, j) = in(j, W - 1 - i).
template <class T>
image<T> rotate90(const image<T>& in) {
  image<T> out(in.cols(), in.rows());
  for (Eigen::Index i = 0; i < out.rows(); ++i) {
    for (Eigen::Index j = 0; j < out.cols(); ++j) out(i, j) = in(j, in.cols() - 1 - i);
  }
  return out;
}

/// After rot90 (counter-clockwise), theta becomes theta - pi/2: old channel k is new channel
/// k - NumAngles/4, and old bin (by, bx) is new bin (NumBins - 1 - bx, by).
template <class D, class Col>
void check_rotated(const Col& before, const Col& after, double tolerance) {
  constexpr int nb = D::num_bins;
  constexpr int na = D::num_angles;
  static_assert(na % 4 == 0, "a quarter turn must be a whole number of channels");
  double worst = 0.0;
  double energy = 0.0;
  for (Eigen::Index by = 0; by < nb; ++by) {
    for (Eigen::Index bx = 0; bx < nb; ++bx) {
      for (Eigen::Index k = 0; k < na; ++k) {
        const auto old_value = static_cast<double>(before(D::element_index(by, bx, k)));
        const auto new_value = static_cast<double>(
            after(D::element_index(nb - 1 - bx, by, ((k - na / 4) % na + na) % na)));
        worst = std::max(worst, std::abs(old_value - new_value));
        energy += old_value;
      }
    }
  }
  CHECK(worst <= tolerance);
  CHECK(energy > 0.0);  // not a vacuous comparison of zeros
}

dense_sift_params raw_params(dense_sift_params p) {
  p.norm_threshold = std::numeric_limits<double>::infinity();
  return p;
}

}  // namespace

TEST_CASE("dense_sift models the descriptor concept with the paper's sizes") {
  static_assert(tacmap::descriptor<sift_lite>);
  static_assert(tacmap::descriptor<classic_sift>);
  static_assert(tacmap::descriptor<dense_sift<3, 6, double>>);
  static_assert(sift_lite::descriptor_size == 32);
  static_assert(classic_sift::descriptor_size == 128);
  static_assert(sift_lite::euclidean_distance);

  const sift_lite lite;
  CHECK(lite.dimension() == 32);
  CHECK(lite.patch_size() == 18);
  CHECK(lite.grid_spacing() == 9);
  CHECK(lite.bin_size() == 9);
  CHECK(lite.params() == dense_sift_params{});

  const classic_sift classic;
  CHECK(classic.dimension() == 128);
  CHECK(classic.patch_size() == 16);  // 18 is not a multiple of 4
  CHECK(classic.grid_spacing() == 9);
  CHECK(classic.bin_size() == 4);
}

TEST_CASE("dense_sift rejects invalid parameters, naming the value") {
  auto with = [](auto change) {
    dense_sift_params p;
    change(p);
    return p;
  };
  using doctest::Contains;
  CHECK_THROWS_WITH_AS(sift_lite(with([](auto& p) { p.patch_size = 0; })),
                       Contains("patch_size = 0"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(sift_lite(with([](auto& p) { p.patch_size = 1000000000000; })),
                       Contains("patch_size = 1000000000000"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(sift_lite(with([](auto& p) { p.patch_size = 17; })),
                       Contains("patch_size = 17 px is not a multiple of num_bins = 2"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(classic_sift(dense_sift_params{}),
                       Contains("patch_size = 18 px is not a multiple of num_bins = 4"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS((dense_sift<3, 8>(with([](auto& p) { p.patch_size = 15; }))),
                       Contains("patch_size = 15 px is odd"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(sift_lite(with([](auto& p) { p.grid_spacing = 0; })),
                       Contains("grid_spacing = 0"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(sift_lite(with([](auto& p) { p.sigma_edge = 0.0; })),
                       Contains("sigma_edge = 0"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(sift_lite(with([](auto& p) { p.sigma_edge = -1.0; })),
                       Contains("sigma_edge = -1"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(sift_lite(with([](auto& p) { p.sigma_edge = 1e300; })),
                       Contains("sigma_edge = 1e+300"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(
      sift_lite(with([](auto& p) { p.sigma_edge = std::numeric_limits<double>::quiet_NaN(); })),
      Contains("sigma_edge = nan"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(sift_lite(with([](auto& p) { p.alpha = 0.0; })), Contains("alpha = 0"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(
      sift_lite(with([](auto& p) { p.alpha = std::numeric_limits<double>::infinity(); })),
      Contains("alpha = inf"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(sift_lite(with([](auto& p) { p.norm_threshold = -0.5; })),
                       Contains("norm_threshold = -0.5"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(sift_lite(with([](auto& p) { p.clamp = 0.0; })), Contains("clamp = 0"),
                       std::invalid_argument);
  // Edge values that are valid.
  CHECK_NOTHROW(sift_lite(raw_params({})));
  CHECK_NOTHROW(sift_lite(with([](auto& p) { p.sigma_edge = 64.0; })));
  CHECK_NOTHROW(sift_lite(with([](auto& p) { p.patch_size = 2; })));
}

TEST_CASE("dense_sift::compute matches the scalar reference within 1e-5") {
  SUBCASE("sift_lite, the paper's 2 x 2 x 8") { check_against_reference(sift_lite{}, 1e-5); }
  SUBCASE("classic_sift, 4 x 4 x 8 on 16 px patches") {
    check_against_reference(classic_sift{}, 1e-5);
  }
  SUBCASE("double precision") { check_against_reference(dense_sift<2, 8, double>{}, 1e-11); }
  SUBCASE("non-default parameters: wide gradient kernel, real alpha, other threshold/clamp") {
    dense_sift_params p;
    p.patch_size = 12;
    p.grid_spacing = 5;
    p.sigma_edge = 1.5;  // 9-tap kernel: reaches past the 2 mirrored pixels
    p.alpha = 4.5;       // not an integer: the pow path
    p.norm_threshold = 0.5;
    p.clamp = 0.3;
    check_against_reference(sift_lite(p), 1e-5);
    check_against_reference(classic_sift(p), 1e-5);
  }
  SUBCASE("odd number of bins and six orientations") {
    dense_sift_params p;
    p.patch_size = 12;
    check_against_reference(dense_sift<3, 6>(p), 1e-5);
  }
  SUBCASE("even alpha and 2 px bins") {
    dense_sift_params p;
    p.patch_size = 8;
    p.alpha = 4.0;
    check_against_reference(classic_sift(p), 1e-5);
  }
}

TEST_CASE("dense_sift::sample gives the paper's three descriptors on a 42 x 18 tactile image") {
  const auto img = tactile_like_image<float>(42, 18, 3);
  auto check = [&img](const auto& d) {
    const auto samples = d.sample(img);
    CHECK(samples.rows == 3);
    CHECK(samples.cols == 1);
    CHECK(samples.size() == 3);
    CHECK(samples.values.rows() == d.dimension());
    CHECK(samples.values.cols() == 3);
    CHECK(samples.top_left_row(0) == 0);
    CHECK(samples.top_left_row(1) == 9);
    CHECK(samples.top_left_row(2) == 18);
    CHECK(samples.top_left_col(0) == 0);
    // Each sample is the compute() column of the same top-left.
    const auto field = d.compute(img);
    for (Eigen::Index i = 0; i < 3; ++i) {
      const Eigen::ArrayXf diff = samples.at(i, 0) - field.at(i * 9, 0);
      CHECK(diff.abs().maxCoeff() <= 1e-6F);
    }
    // And the reference's grid.
    const auto ref = dsift_reference::sample(to_mat(img), reference_params(d));
    REQUIRE(ref.d.size() == 3);
    CHECK(ref.top_rows == std::vector<long>{0, 9, 18});
    for (Eigen::Index i = 0; i < 3; ++i) {
      for (Eigen::Index k = 0; k < d.dimension(); ++k) {
        CHECK(std::abs(static_cast<double>(samples.at(i, 0)(k)) -
                       ref.d[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)]) <= 1e-5);
      }
    }
  };
  SUBCASE("sift_lite") { check(sift_lite{}); }
  SUBCASE("classic_sift (patch 16, spacing 9)") { check(classic_sift{}); }
}

TEST_CASE("dense_sift::sample follows Lazebnik's grid on other sizes") {
  dense_sift_params p;
  p.patch_size = 8;
  p.grid_spacing = 3;
  const sift_lite d(p);
  for (const auto& size :
       std::vector<std::pair<Eigen::Index, Eigen::Index>>{{8, 8}, {20, 9}, {23, 17}, {30, 31}}) {
    const Eigen::Index rows = size.first;
    const Eigen::Index cols = size.second;
    CAPTURE(rows);
    CAPTURE(cols);
    const auto img = random_image<float>(rows, cols, static_cast<unsigned>(rows * 100 + cols));
    const auto samples = d.sample(img);
    const auto ref = dsift_reference::sample(to_mat(img), reference_params(d));
    REQUIRE(samples.rows == static_cast<Eigen::Index>(ref.top_rows.size()));
    REQUIRE(samples.cols == static_cast<Eigen::Index>(ref.top_cols.size()));
    const auto grid = d.sample_grid_size({cols, rows});
    CHECK(grid.height == samples.rows);
    CHECK(grid.width == samples.cols);
    const auto field = d.compute(img);
    for (Eigen::Index i = 0; i < samples.rows; ++i) {
      CHECK(samples.top_left_row(i) == ref.top_rows[static_cast<std::size_t>(i)]);
      for (Eigen::Index j = 0; j < samples.cols; ++j) {
        CHECK(samples.top_left_col(j) == ref.top_cols[static_cast<std::size_t>(j)]);
        const auto& expected = ref.d[static_cast<std::size_t>(i * samples.cols + j)];
        double worst = 0.0;
        for (Eigen::Index k = 0; k < d.dimension(); ++k) {
          worst = std::max(worst, std::abs(static_cast<double>(samples.at(i, j)(k)) -
                                           expected[static_cast<std::size_t>(k)]));
        }
        CHECK(worst <= 1e-5);
        const Eigen::ArrayXf diff =
            samples.at(i, j) - field.at(samples.top_left_row(i), samples.top_left_col(j));
        CHECK(diff.abs().maxCoeff() <= 1e-6F);
      }
    }
  }
  // (size - patch + 1) a multiple of the spacing: Lazebnik's bound would add a point whose
  // patch overhangs the image; every sample must stay a compute() column.
  dense_sift_params q;
  q.grid_spacing = 1;
  const auto samples = sift_lite(q).sample(random_image<float>(19, 18, 1));
  CHECK(samples.rows == 2);  // top-left rows 0 and 1; 19 - 18 + 1 = 2 patch positions
  CHECK(samples.cols == 1);
}

TEST_CASE("dense_sift rejects images that no patch fits and non-finite images") {
  const sift_lite d;
  using doctest::Contains;
  CHECK_THROWS_WITH_AS(static_cast<void>(d.sample(random_image<float>(17, 18, 1))),
                       Contains("the image is 17 x 18 px (rows x cols), smaller than one 18 x 18"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(static_cast<void>(d.compute(random_image<float>(42, 10, 1))),
                       Contains("42 x 10"), std::invalid_argument);
  CHECK_THROWS_AS(static_cast<void>(d.compute(image<float>(0, 0))), std::invalid_argument);
  CHECK(d.sample_grid_size({18, 17}) == tacmap::pixel_size{0, 0});

  auto img = random_image<float>(42, 18, 2);
  img(5, 7) = std::numeric_limits<float>::quiet_NaN();
  CHECK_THROWS_WITH_AS(static_cast<void>(d.compute(img)), Contains("NaN or infinite"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(static_cast<void>(d.sample(img)), Contains("NaN or infinite"),
                       std::invalid_argument);
  img(5, 7) = std::numeric_limits<float>::infinity();
  CHECK_THROWS_AS(static_cast<void>(d.compute(img)), std::invalid_argument);
}

TEST_CASE("a vertical edge puts its energy in channel 0 (or 4), a horizontal one in 2 (or 6)") {
  // theta = atan2(gy, gx) with y down and the gradient pointing to brighter pixels. A perfect
  // step edge has theta exactly 0 (dark left, bright right) at every pixel, so channel 0 holds
  // the magnitude, channels 1 and 7 cos(45 deg)^9 = 2^-4.5 of it, and channels 2..6 nothing.
  const sift_lite raw(raw_params(sift_lite::default_params()));
  const double side = std::pow(std::cos(std::numbers::pi / 4.0), 9.0);
  image<float> edge = image<float>::Zero(30, 30);
  edge.rightCols(15).setConstant(1.0F);

  auto check_channels = [&](const image<float>& img, int main) {
    CAPTURE(main);
    const auto field = raw.compute(img);
    double total = 0.0;
    for (Eigen::Index i = 0; i < field.values.cols(); ++i) {
      for (Eigen::Index by = 0; by < 2; ++by) {
        for (Eigen::Index bx = 0; bx < 2; ++bx) {
          auto ch = [&](int k) {
            return static_cast<double>(
                field.values(sift_lite::element_index(by, bx, (k + 8) % 8), i));
          };
          const double m = ch(main);
          total += m;
          CHECK(std::abs(ch(main + 1) - side * m) <= 1e-5 * (1.0 + m));
          CHECK(std::abs(ch(main - 1) - side * m) <= 1e-5 * (1.0 + m));
          for (int k = 2; k <= 6; ++k) CHECK(std::abs(ch(main + k)) <= 1e-5 * (1.0 + m));
        }
      }
    }
    CHECK(total > 1.0);  // the edge is seen
  };
  SUBCASE("dark left, bright right: channel 0") { check_channels(edge, 0); }
  SUBCASE("bright left, dark right: channel 4") {
    const image<float> flipped = 1.0F - edge;
    check_channels(flipped, 4);
  }
  SUBCASE("dark top, bright bottom: channel 2 (y points down)") {
    const image<float> horizontal = edge.transpose();
    check_channels(horizontal, 2);
  }
  SUBCASE("bright top, dark bottom: channel 6") {
    const image<float> horizontal = (1.0F - edge).transpose();
    check_channels(horizontal, 6);
  }
  SUBCASE("after normalisation channel 0 still dominates every bin that sees the edge") {
    const auto field = sift_lite{}.compute(edge);
    int seen = 0;
    for (Eigen::Index i = 0; i < field.values.cols(); ++i) {
      for (Eigen::Index b = 0; b < 4; ++b) {
        const Eigen::ArrayXf bin = field.values.col(i).segment(8 * b, 8);
        if (bin.maxCoeff() <= 1e-3F) continue;
        ++seen;
        Eigen::Index best = -1;
        bin.maxCoeff(&best);
        CHECK(best == 0);
      }
    }
    CHECK(seen > 0);
  }
}

TEST_CASE("a 90-degree rotation permutes orientation channels and spatial bins") {
  SUBCASE("classic_sift: every patch (4 px bins are centred in the patch)") {
    const classic_sift d;
    const auto img = random_image<float>(29, 23, 11);
    const auto before = d.compute(img);
    const auto after = d.compute(rotate90(img));
    REQUIRE(after.rows == before.cols);
    REQUIRE(after.cols == before.rows);
    const Eigen::Index w = img.cols();
    for (Eigen::Index r = 0; r < before.rows; ++r) {
      for (Eigen::Index c = 0; c < before.cols; ++c) {
        // Patch (r, c) moves to top-left (W - patch - c, r).
        check_rotated<classic_sift>(before.at(r, c), after.at(w - d.patch_size() - c, r), 1e-5);
      }
    }
  }
  SUBCASE("three bins per side, 4 px bins, double") {
    dense_sift_params p;
    p.patch_size = 12;
    const dense_sift<3, 8, double> d(p);
    const auto img = random_image<double>(20, 26, 12);
    const auto before = d.compute(img);
    const auto after = d.compute(rotate90(img));
    for (Eigen::Index r = 0; r < before.rows; ++r) {
      for (Eigen::Index c = 0; c < before.cols; ++c) {
        check_rotated<dense_sift<3, 8, double>>(
            before.at(r, c), after.at(img.cols() - d.patch_size() - c, r), 1e-12);
      }
    }
  }
  SUBCASE("sift_lite: a pattern inside the bins' common support") {
    // sift_lite's bins are centred at 1.5 and 10.5 px from the top-left (not at 4 and 13), so
    // its descriptor frame is centred 6 px from the top-left and patch (r, c) maps to
    // (W - 13 - c, r). Its 18-tap kernel also drops the triangle's last tap on one side, so the
    // rotation is exact only for gradient energy away from that tap: a 3 x 3 random pattern at
    // rows and columns 17..19, seen from top-left (12, 12).
    image<float> img = image<float>::Zero(40, 40);
    img.block(17, 17, 3, 3) = random_image<float>(3, 3, 13);
    const sift_lite d;
    const auto before = d.compute(img);
    const auto after = d.compute(rotate90(img));
    check_rotated<sift_lite>(before.at(12, 12), after.at(40 - 13 - 12, 12), 1e-5);
  }
}

TEST_CASE("a constant or all-zero image gives zero descriptors, not NaN") {
  for (float value : {0.0F, 0.7F, 250.0F}) {
    CAPTURE(value);
    const image<float> flat = image<float>::Constant(42, 18, value);
    const auto field = sift_lite{}.compute(flat);
    CHECK(field.values.abs().maxCoeff() == 0.0F);
    const auto samples = classic_sift{}.sample(flat);
    CHECK(samples.values.abs().maxCoeff() == 0.0F);
    dense_sift_params wide;  // a 9-tap gradient kernel reaches the zero beyond the padding
    wide.sigma_edge = 2.0;
    CHECK(sift_lite(wide).compute(flat).values.abs().maxCoeff() == 0.0F);
  }
}

TEST_CASE("descriptors do not depend on the image's intensity scale (division by the max)") {
  const auto img = tactile_like_image<float>(40, 30, 21);
  const sift_lite d;
  const auto a = d.compute(img);
  for (float factor : {3.0F, 255.0F, 1e-6F}) {
    CAPTURE(factor);
    const image<float> scaled = img * factor;
    const auto b = d.compute(scaled);
    CHECK((a.values - b.values).abs().maxCoeff() <= 1e-5F);
  }
}

TEST_CASE("normalisation respects flat areas: strong descriptors unit length and clamped") {
  // Texture on the left third, nothing elsewhere: both strong and weak descriptors.
  image<float> img = image<float>::Zero(40, 60);
  img.leftCols(20) = random_image<float>(40, 20, 5);
  img.block(20, 35, 4, 4) = image<float>::Constant(4, 4, 0.05F);  // a faint contact
  const sift_lite normed;
  const sift_lite raw(raw_params(sift_lite::default_params()));
  const auto n = normed.compute(img);
  const auto r = raw.compute(img);
  int strong = 0;
  int weak = 0;
  int clamped = 0;
  for (Eigen::Index i = 0; i < n.values.cols(); ++i) {
    const Eigen::ArrayXd v = r.values.col(i).cast<double>();
    const Eigen::ArrayXd out = n.values.col(i).cast<double>();
    const double norm = v.matrix().norm();
    if (norm > 1.0) {
      ++strong;
      CHECK(std::abs(out.matrix().norm() - 1.0) <= 1e-5);
      // Before the final renormalisation the unit vector was clamped at 0.2 ...
      const Eigen::ArrayXd unit_clamped = (v / norm).min(0.2);
      const double rescale = unit_clamped.matrix().norm();
      CHECK(((out * rescale) - unit_clamped).abs().maxCoeff() <= 1e-5);
      CHECK((out * rescale).maxCoeff() <= 0.2 + 1e-6);
      if ((v / norm).maxCoeff() > 0.2) ++clamped;
    } else {
      ++weak;
      CHECK((out - v).abs().maxCoeff() == 0.0);  // left as it is
      CHECK(out.matrix().norm() <= 1.0);
    }
  }
  CHECK(strong > 0);
  CHECK(weak > 0);
  CHECK(clamped > 0);

  // clamp = 1 does nothing to a unit vector: strong descriptors are plain L2-normalised.
  dense_sift_params no_clamp;
  no_clamp.clamp = 1.0;
  const auto u = sift_lite(no_clamp).compute(img);
  for (Eigen::Index i = 0; i < u.values.cols(); ++i) {
    const Eigen::ArrayXd v = r.values.col(i).cast<double>();
    const double norm = v.matrix().norm();
    if (norm > 1.0) {
      CHECK((u.values.col(i).cast<double>() - v / norm).abs().maxCoeff() <= 1e-5);
    }
  }
}

TEST_CASE("element order: bins outer with the bin row fastest, angles inner") {
  // A small bright square in the top-right bin of classic_sift's 4 x 4 grid (bin row 0, bin
  // column 3; 4 px bins centred at 1.5 + 4 b) of a single 16 x 16 patch.
  image<float> img = image<float>::Zero(16, 16);
  img.block(1, 13, 2, 2).setConstant(1.0F);
  const classic_sift d(raw_params(classic_sift::default_params()));
  const auto field = d.compute(img);
  REQUIRE(field.values.cols() == 1);
  Eigen::Array<double, 16, 1> energy = Eigen::Array<double, 16, 1>::Zero();
  for (Eigen::Index by = 0; by < 4; ++by) {
    for (Eigen::Index bx = 0; bx < 4; ++bx) {
      for (Eigen::Index k = 0; k < 8; ++k) {
        energy(by + 4 * bx) += static_cast<double>(field.values(d.element_index(by, bx, k), 0));
      }
    }
  }
  Eigen::Index best = -1;
  energy.maxCoeff(&best);
  CHECK(best == 0 + 4 * 3);                      // (by = 0, bx = 3)
  CHECK(energy(3 + 4 * 0) < 1e-3 * energy(12));  // the transposed bin (by = 3, bx = 0) is empty
  CHECK(classic_sift::element_index(1, 0, 0) == 8);
  CHECK(classic_sift::element_index(0, 1, 0) == 32);
  CHECK(classic_sift::element_index(0, 0, 7) == 7);
}

TEST_CASE("distance is Euclidean, symmetric and zero on itself") {
  const sift_lite d;
  const auto field = d.compute(random_image<float>(30, 30, 9));
  const Eigen::ArrayXf a = field.at(0, 0);
  const Eigen::ArrayXf b = field.at(5, 7);
  const double expected = std::sqrt((a.cast<double>() - b.cast<double>()).square().sum());
  CHECK(d.distance(a, b) == doctest::Approx(expected).epsilon(1e-6));
  CHECK(d.distance(a, b) == d.distance(b, a));
  CHECK(d.distance(a, a) == 0.0F);
  CHECK(expected > 0.0);
  const Eigen::ArrayXf short_column = Eigen::ArrayXf::Zero(31);
  CHECK_THROWS_WITH_AS(static_cast<void>(d.distance(a, short_column)),
                       doctest::Contains("length 32 and 31"), std::invalid_argument);
}

// The hand-vectorised normalisation kernels against their scalar references
// (detail/dense_sift_kernels.hpp): random descriptors of both branches, all-zero ones, counts
// that are not a multiple of the register width.
namespace {

/// Random non-negative descriptors (pooled channels are non-negative): strong ones, weak ones
/// (scaled below the threshold) and all-zero ones, mixed.
template <class T>
std::vector<T> random_descriptors(Eigen::Index size, Eigen::Index count, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<T> v(static_cast<std::size_t>(size * count));
  for (Eigen::Index c = 0; c < count; ++c) {
    const double scale = c % 5 == 0 ? 0.0 : (c % 3 == 0 ? 0.01 : 3.0 * u(gen));
    // Some peaky descriptors, so that the clamp is active.
    const Eigen::Index peak =
        c % 2 == 0 ? static_cast<Eigen::Index>(u(gen) * static_cast<double>(size)) : -1;
    for (Eigen::Index i = 0; i < size; ++i) {
      v[static_cast<std::size_t>(c * size + i)] =
          static_cast<T>(scale * (i == peak ? 20.0 : u(gen)));
    }
  }
  return v;
}

template <int Size, class T>
void check_normalise(Eigen::Index count, unsigned seed, double tolerance) {
  CAPTURE(Size);
  CAPTURE(count);
  const std::vector<T> input = random_descriptors<T>(Size, count, seed);
  std::vector<T> simd = input;
  std::vector<T> eigen = input;
  std::vector<T> scalar = input;
  tacmap::detail::dsift::normalise_simd<tacmap::detail::kernel_arch<T>, Size>(simd.data(), count,
                                                                              T(1), T(0.2));
  tacmap::detail::dsift::normalise_eigen<Size>(eigen.data(), count, T(1), T(0.2));
  tacmap::detail::dsift::normalise_scalar<Size>(scalar.data(), count, T(1), T(0.2));
  double worst = 0.0;
  double worst_eigen = 0.0;
  for (std::size_t i = 0; i < input.size(); ++i) {
    worst = std::max(worst, std::abs(static_cast<double>(simd[i]) - scalar[i]));
    worst_eigen = std::max(worst_eigen, std::abs(static_cast<double>(eigen[i]) - scalar[i]));
  }
  CHECK(worst <= tolerance);
  CHECK(worst_eigen <= tolerance);
  // Weak descriptors are left exactly as they are.
  for (Eigen::Index c = 0; c < count; ++c) {
    double norm = 0.0;
    for (Eigen::Index i = 0; i < Size; ++i) {
      norm += std::pow(static_cast<double>(input[static_cast<std::size_t>(c * Size + i)]), 2);
    }
    if (std::sqrt(norm) < 0.99) {
      for (Eigen::Index i = 0; i < Size; ++i) {
        const auto k = static_cast<std::size_t>(c * Size + i);
        CHECK(simd[k] == input[k]);
      }
    }
  }
}

}  // namespace

TEST_CASE("normalise_simd equals the scalar normalisation (both branches, any count)") {
  // Past 8 registers: normalise_chunk's chunks (a whole one, one more, a partial one).
  for (Eigen::Index count : {0, 1, 3, 7, 8, 9, 16, 29, 31, 32, 33, 63, 64, 65, 130}) {
    check_normalise<32, float>(count, static_cast<unsigned>(count) + 1U, 1e-6);
    check_normalise<128, float>(count, static_cast<unsigned>(count) + 2U, 1e-6);
    check_normalise<32, double>(count, static_cast<unsigned>(count) + 3U, 1e-12);
  }
}

TEST_CASE("assemble_normalise_simd equals assembling and the scalar normalisation") {
  using tacmap::detail::kernel_arch;
  using namespace tacmap::detail::dsift;
  auto check = [](auto bins, auto angles, Eigen::Index bin, Eigen::Index count, unsigned seed) {
    constexpr int nb = decltype(bins)::value;
    constexpr int na = decltype(angles)::value;
    constexpr Eigen::Index size = nb * nb * na;
    CAPTURE(nb);
    CAPTURE(count);
    // NumBins pooled rows of nx pixels (any non-negative values), their squared norms padded.
    const Eigen::Index nx = count + (nb - 1) * bin;
    const std::vector<float> pooled = random_descriptors<float>(na, nb * nx, seed);
    std::vector<std::vector<float>> squares(static_cast<std::size_t>(nb));
    std::array<const float*, static_cast<std::size_t>(nb)> rows{};
    std::array<const float*, static_cast<std::size_t>(nb)> sq{};
    for (std::size_t by = 0; by < static_cast<std::size_t>(nb); ++by) {
      rows[by] = pooled.data() + static_cast<Eigen::Index>(by) * nx * na;
      squares[by].assign(static_cast<std::size_t>(nx + 16), 0.0F);
      pixel_square_norms_simd<kernel_arch<float>, na>(rows[by], nx, squares[by].data());
      for (Eigen::Index x = 0; x < nx; ++x) {
        double s = 0.0;
        for (Eigen::Index k = 0; k < na; ++k)
          s += std::pow(static_cast<double>(rows[by][x * na + k]), 2);
        CHECK(std::abs(squares[by][static_cast<std::size_t>(x)] - s) <= 1e-6 * (1.0 + s));
      }
      sq[by] = squares[by].data();
    }
    std::vector<float> simd(static_cast<std::size_t>(size * count), -1.0F);
    std::vector<float> scalar(simd.size(), -2.0F);
    assemble_normalise_simd<kernel_arch<float>, nb, na>(rows.data(), sq.data(), bin, count, 1.0F,
                                                        0.2F, simd.data());
    assemble_normalise_scalar<nb, na>(rows.data(), bin, count, 1.0F, 0.2F, scalar.data());
    double worst = 0.0;
    for (std::size_t i = 0; i < simd.size(); ++i) {
      worst = std::max(worst, std::abs(static_cast<double>(simd[i]) - scalar[i]));
    }
    CHECK(worst <= 1e-6);
  };
  for (Eigen::Index count : {1, 5, 8, 13, 40, 63, 64, 65, 103, 129}) {
    check(std::integral_constant<int, 2>{}, std::integral_constant<int, 8>{}, 9, count, 5U);
    check(std::integral_constant<int, 4>{}, std::integral_constant<int, 8>{}, 4, count, 6U);
  }
}

TEST_CASE("compute on a wide image equals describe_at at scattered positions") {
  // Wider than the reference tests' images: many whole registers of descriptors per row.
  const sift_lite d;
  const auto img = tactile_like_image<float>(61, 150, 21);
  const auto field = d.compute(img);
  std::vector<tacmap::grid_cell> at;
  for (Eigen::Index r = 0; r < field.rows; r += 7) {
    for (Eigen::Index c = 0; c < field.cols; c += 5) at.push_back({r, c});
  }
  const auto out = d.describe_at(img, at);
  double worst = 0.0;
  for (std::size_t i = 0; i < at.size(); ++i) {
    worst = std::max(worst, static_cast<double>((out.col(static_cast<Eigen::Index>(i)) -
                                                 field.at(at[i].row, at[i].col))
                                                    .abs()
                                                    .maxCoeff()));
  }
  CHECK(worst <= 1e-5);
}

TEST_CASE("compute's running sums do not drift: long rows and columns, a saturated edge, flat") {
  // compute pools with running box sums (detail::dsift::box_pooler). In float they would round at
  // the scale of the largest sum seen and leave a residue after it; in integers they are exact.
  // The extremes: the largest channel values the image scaling allows (a 0/1 checkerboard, every
  // gradient saturated) at one end of a 1200 px line, exact zeros across the middle, a faint
  // texture (1e-3 of the maximum: weak descriptors, compared unnormalised) at the far end.
  const sift_lite d;
  constexpr Eigen::Index length = 1200;
  constexpr Eigen::Index across = 24;
  image<float> wide = image<float>::Zero(across, length);
  std::mt19937 gen(11);
  std::uniform_real_distribution<float> u(0.0F, 1e-3F);
  for (Eigen::Index r = 0; r < across; ++r) {
    for (Eigen::Index c = 0; c < 60; ++c) wide(r, c) = static_cast<float>((r + c) % 2);
    for (Eigen::Index c = length - 60; c < length; ++c) wide(r, c) = u(gen);
  }
  const image<float> tall = wide.transpose();
  for (const image<float>* img : std::array<const image<float>*, 2>{&wide, &tall}) {
    const bool is_wide = img == &wide;
    CAPTURE(is_wide);
    branch_counts counts;
    CHECK(max_difference_to_reference(d, *img, counts) <= 1e-5);
    CHECK(counts.strong > 0);
    CHECK(counts.weak > 0);
    // Patches that see only the flat middle are exactly zero, however far the running sums went.
    const auto field = d.compute(*img);
    float flat = 0.0F;
    for (Eigen::Index r = 0; r < field.rows; ++r) {
      for (Eigen::Index c = 0; c < field.cols; ++c) {
        const Eigen::Index along = is_wide ? c : r;
        if (along >= 100 && along <= length - 120) {
          flat = std::max(flat, field.at(r, c).abs().maxCoeff());
        }
      }
    }
    CHECK(flat == 0.0F);
  }
}

TEST_CASE(
    "compute into a reused field and workspace gives compute(img)'s descriptors bit for bit") {
  // One field and one workspace through images of different sizes and back (the buffers shrink,
  // grow and are reused), float (box sums) and double (per-tap pooling), and after a scratch
  // that `describe_at` used (its zero-margin bookkeeping must not leak into the whole-image path).
  const auto check = [](auto d, auto tag) {
    using T = decltype(tag);
    typename decltype(d)::workspace scratch;
    tacmap::descriptor_field<T> field;
    const std::array<std::pair<Eigen::Index, Eigen::Index>, 4> sizes{
        {{40, 52}, {23, 23}, {61, 30}, {40, 52}}};
    unsigned seed = 3;
    for (const auto& [rows, cols] : sizes) {
      CAPTURE(rows);
      CAPTURE(cols);
      const image<T> img = random_image<T>(rows, cols, ++seed);
      const tacmap::grid_cell corner{0, 0};
      (void)d.describe_at(img, std::span<const tacmap::grid_cell>(&corner, 1), scratch);
      d.compute(img, field, scratch);
      const auto fresh = d.compute(img);
      REQUIRE(field.rows == fresh.rows);
      REQUIRE(field.cols == fresh.cols);
      REQUIRE(field.values.rows() == fresh.values.rows());
      REQUIRE(field.values.cols() == fresh.values.cols());
      CHECK((field.values == fresh.values).all());
    }
  };
  check(sift_lite{}, float{});
  check(classic_sift{}, float{});
  check(dense_sift<2, 8, double>{}, double{});
}

TEST_CASE("sample into a reused workspace and output gives sample(img)'s descriptors bit for bit") {
  // What the descriptor models do per touch: one workspace and one output through touches of
  // one size, then other sizes and back (the buffers shrink, grow and are reused, the grid and
  // its pooled rows change), with compute and describe_at sharing the workspace in between
  // (their channels and zero-margin bookkeeping must not leak into sample's).
  const auto check = [](auto d, auto tag) {
    using T = decltype(tag);
    typename decltype(d)::workspace scratch;
    tacmap::descriptor_samples<T> out;
    tacmap::descriptor_field<T> field;
    const std::array<std::pair<Eigen::Index, Eigen::Index>, 6> sizes{
        {{42, 18}, {42, 18}, {30, 41}, {42, 18}, {60, 25}, {42, 18}}};
    unsigned seed = 40;
    for (const auto& [rows, cols] : sizes) {
      CAPTURE(rows);
      CAPTURE(cols);
      const image<T> img = random_image<T>(rows, cols, ++seed);
      if (seed % 2 == 0) {
        const tacmap::grid_cell corner{0, 0};
        (void)d.describe_at(img, std::span<const tacmap::grid_cell>(&corner, 1), scratch);
      } else if (seed % 3 == 0) {
        d.compute(img, field, scratch);
      }
      d.sample(img, scratch, out);
      const auto fresh = d.sample(img);
      REQUIRE(out.rows == fresh.rows);
      REQUIRE(out.cols == fresh.cols);
      REQUIRE(out.spacing == fresh.spacing);
      REQUIRE(out.values.rows() == fresh.values.rows());
      REQUIRE(out.values.cols() == fresh.values.cols());
      CHECK((out.values == fresh.values).all());
    }
    // A bad image is refused as by sample(img), and the workspace still serves afterwards.
    image<T> bad = random_image<T>(42, 18, 7U);
    bad(3, 4) = std::numeric_limits<T>::quiet_NaN();
    CHECK_THROWS_AS(d.sample(bad, scratch, out), std::invalid_argument);
    const image<T> good = random_image<T>(42, 18, 8U);
    d.sample(good, scratch, out);
    CHECK((out.values == d.sample(good).values).all());
  };
  check(sift_lite{}, float{});
  check(classic_sift{}, float{});
  check(dense_sift<2, 8, double>{}, double{});
}

}  // namespace test_dense_sift
