// Tests of tacmap::unsigned_orientation: dense SIFT with opposite orientation channels folded, so
// that an image and its negative have the same descriptors (candidate for maps whose raised parts
// look darker than around them).
#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <vector>

#include "blob_images.hpp"
#include "ranked_first.hpp"
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/descriptor/unsigned_orientation.hpp"
#include "tacmap/measurement/rotated_descriptor_likelihood.hpp"
#include "tacmap/testing/conformance.hpp"

namespace test_unsigned_orientation {

namespace {

using tacmap::classic_sift;
using tacmap::image;
using tacmap::sift_lite;
using tacmap::unsigned_orientation;

/// Zero with a few soft blobs, like a tactile image: strong (normalised) descriptors on the blobs
/// and weak (unnormalised) ones between them.
image<float> blob_image(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::mt19937 gen(seed);
  image<float> img = image<float>::Zero(rows, cols);
  tacmap_test::add_blobs(img, gen, 4, 2.0);
  return img;
}

/// The contrast-reversed image with the same range (raised parts dark instead of bright).
image<float> inverted(const image<float>& img) { return (img.maxCoeff() + img.minCoeff()) - img; }

}  // namespace

TEST_CASE_TEMPLATE_INVOKE(tacmap_descriptor_conformance, unsigned_orientation<sift_lite>,
                          unsigned_orientation<classic_sift>);

static_assert(tacmap::euclidean_descriptor<unsigned_orientation<sift_lite>>);
static_assert(tacmap::samples_on_grid<unsigned_orientation<sift_lite>>);
static_assert(tacmap::samples_on_grid<unsigned_orientation<classic_sift>>);
static_assert(tacmap::describes_at_reusing<unsigned_orientation<sift_lite>>);
static_assert(
    tacmap::measurement_model<tacmap::descriptor_likelihood<unsigned_orientation<sift_lite>>,
                              tacmap::planar_grid<float>>);

TEST_CASE("unsigned_orientation halves the dimension and keeps the wrapped patch and spacing") {
  const unsigned_orientation<sift_lite> lite;
  CHECK(lite.dimension() == 16);
  CHECK(lite.patch_size() == 18);
  CHECK(lite.grid_spacing() == 9);
  const unsigned_orientation<classic_sift> classic;
  CHECK(classic.dimension() == 64);
  CHECK(classic.patch_size() == 16);
  CHECK(unsigned_orientation<tacmap::dense_sift<3, 6>>{}.dimension() == 27);
  CHECK(unsigned_orientation<classic_sift>::element_index(1, 0, 0) == 4);
  CHECK(unsigned_orientation<classic_sift>::element_index(0, 1, 0) == 16);
  // Parameters reach the wrapped descriptor (and its validation).
  tacmap::dense_sift_params p = sift_lite::default_params();
  p.grid_spacing = 6;
  CHECK(unsigned_orientation<sift_lite>(p).grid_spacing() == 6);
  p.patch_size = 17;
  CHECK_THROWS_AS(unsigned_orientation<sift_lite>{p}, std::invalid_argument);
  const Eigen::ArrayXf a = Eigen::ArrayXf::Zero(16);
  const Eigen::ArrayXf b = Eigen::ArrayXf::Zero(32);
  CHECK_THROWS_AS((void)lite.distance(a, b), std::invalid_argument);
  CHECK(lite.distance(a, Eigen::ArrayXf::Constant(16, 0.5F)) == doctest::Approx(2.0));
}

TEST_CASE_TEMPLATE("an image and its negative have the same unsigned descriptors", D, sift_lite,
                   classic_sift) {
  const image<float> img = blob_image(40, 30, 7);
  const image<float> neg = inverted(img);
  const unsigned_orientation<D> d;
  const auto a = d.compute(img);
  const auto b = d.compute(neg);
  REQUIRE(a.values.cols() == b.values.cols());
  // Equal within rounding, except where a folded descriptor's norm sits on the wrapped rule's
  // threshold (1): there the last rounding bit, which differs between the two images' and
  // between instruction sets' arithmetic, decides whether it is normalised and clamped. Such a
  // column has norm ~1 on both sides; a wrong fold would differ on weak columns too.
  const double threshold = d.params().norm_threshold;
  Eigen::Index at_threshold = 0;
  for (Eigen::Index q = 0; q < a.values.cols(); ++q) {
    if ((a.values.col(q) - b.values.col(q)).abs().maxCoeff() <= 1e-5F) continue;
    CAPTURE(q);
    CHECK(std::abs(static_cast<double>(a.values.col(q).matrix().norm()) - threshold) <= 1e-4);
    CHECK(std::abs(static_cast<double>(b.values.col(q).matrix().norm()) - threshold) <= 1e-4);
    ++at_threshold;
  }
  CHECK(at_threshold * 100 <= a.values.cols());
  // ... where the signed descriptors differ: the test sees the contrast reversal at all.
  const D signed_d;
  CHECK((signed_d.compute(img).values - signed_d.compute(neg).values).abs().maxCoeff() > 0.1F);
  // Also through the sampled path the likelihood uses for touches.
  CHECK((d.sample(img).values - d.sample(neg).values).abs().maxCoeff() <= 1e-5F);
}

TEST_CASE_TEMPLATE("the fold is channel k plus channel k + A/2 per bin, renormalised", D, sift_lite,
                   classic_sift) {
  // Every position of a blob image (strong and weak descriptors) against a hand computation from
  // the wrapped descriptor's values, in double.
  const image<float> img = blob_image(36, 30, 3);
  const D wrapped;
  const unsigned_orientation<D> d(wrapped);
  const auto w = wrapped.compute(img);
  const auto u = d.compute(img);
  REQUIRE(u.rows == w.rows);
  REQUIRE(u.cols == w.cols);
  REQUIRE(u.values.rows() == D::descriptor_size / 2);
  constexpr int bins = D::num_bins;
  constexpr int half = D::num_angles / 2;
  const double threshold = wrapped.params().norm_threshold;
  const double clamp = wrapped.params().clamp;
  int strong = 0;
  int weak = 0;
  for (Eigen::Index q = 0; q < w.values.cols(); ++q) {
    Eigen::ArrayXd folded(bins * bins * half);
    for (Eigen::Index bx = 0; bx < bins; ++bx)
      for (Eigen::Index by = 0; by < bins; ++by)
        for (Eigen::Index k = 0; k < half; ++k)
          folded(k + half * (by + bins * bx)) =
              static_cast<double>(w.values(D::element_index(by, bx, k), q)) +
              static_cast<double>(w.values(D::element_index(by, bx, k + half), q));
    const double norm = folded.matrix().norm();
    // At the threshold float and double may decide differently; there the two results are
    // legitimately far apart (clamped or not), so such positions are skipped.
    if (std::abs(norm - threshold) < 1e-4) continue;
    if (norm > threshold) {
      ++strong;
      folded = (folded / norm).min(clamp);
      folded /= folded.matrix().norm();
    } else {
      ++weak;
    }
    CAPTURE(q);
    CHECK((u.values.col(q).template cast<double>() - folded).abs().maxCoeff() <= 1e-6);
  }
  CHECK(strong > 0);
  CHECK(weak > 0);
}

TEST_CASE_TEMPLATE("sample and describe_at equal compute at the same top-lefts", D, sift_lite,
                   classic_sift) {
  const image<float> img = blob_image(44, 37, 5);
  const unsigned_orientation<D> d;
  const auto field = d.compute(img);
  const auto s = d.sample(img);
  REQUIRE(s.values.rows() == d.dimension());
  REQUIRE(s.size() == ((44 - d.patch_size()) / 9 + 1) * ((37 - d.patch_size()) / 9 + 1));
  std::vector<tacmap::grid_cell> cells;
  for (Eigen::Index i = 0; i < s.rows; ++i)
    for (Eigen::Index j = 0; j < s.cols; ++j) {
      CAPTURE(i);
      CAPTURE(j);
      CHECK((s.at(i, j) - field.at(s.top_left_row(i), s.top_left_col(j))).abs().maxCoeff() <=
            1e-5F);
      cells.push_back({s.top_left_row(i) + 1, s.top_left_col(j)});
    }
  typename unsigned_orientation<D>::workspace scratch;
  const auto at = d.describe_at(img, cells, scratch);
  REQUIRE(at.cols() == static_cast<Eigen::Index>(cells.size()));
  for (Eigen::Index n = 0; n < at.cols(); ++n) {
    const tacmap::grid_cell c = cells[static_cast<std::size_t>(n)];
    CHECK((at.col(n) - field.at(c.row, c.col)).abs().maxCoeff() <= 1e-5F);
  }
}

TEST_CASE("descriptor_likelihood with unsigned SIFT-lite finds a touch cut from an inverted map") {
  // The map as a photo whose raised parts are dark: the touch (raised = bright) is cut from the
  // inverted map. Per-window features, aligned pairs, as in test_sift_likelihood.cpp. Not exactly
  // zero at the truth: the touch's peak (it is divided by it) is the inverted window's, so its
  // weak descriptors differ in scale from the window's own.
  const auto map = tacmap::testing::conformance_image(66, 60, 11);
  const image<float> touch_map = inverted(map);
  const tacmap::planar_grid<float> grid({.width = 60, .height = 66}, 3.4 / 3.0,
                                        {.width = 18, .height = 42});
  const tacmap::descriptor_likelihood model(unsigned_orientation<sift_lite>{}, map,
                                            grid.window_size(),
                                            {.pairs = tacmap::pairing::aligned});
  REQUIRE(model.patches_per_window() == 3);
  const auto [first, tried] = tacmap_test::ranked_first(model, grid, touch_map);
  CAPTURE(first);
  CAPTURE(tried);
  CHECK(first == tried);
}

}  // namespace test_unsigned_orientation
