// Tests of tacmap::dense_sift::describe_at: descriptors of a few arbitrary patches must be the
// `compute` columns of the same top-lefts, for every layout, scalar, parameter set and position
// (borders included), and bad positions must be rejected with a message that says which and why.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "blob_images.hpp"
#include "tacmap/descriptor/dense_sift.hpp"
#include "test_support.hpp"

namespace test_describe_at {

namespace {

using tacmap::dense_sift;
using tacmap::dense_sift_params;
using tacmap::grid_cell;
using tacmap::image;
using tacmap_test::message_of;

/// Zero with a few soft blobs of random size, position and height (weak and strong descriptors,
/// like a rotated tactile image on its canvas), plus low noise on part of the image so that
/// every channel is exercised.
template <class T>
image<T> test_image(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::mt19937 gen(seed);
  image<T> img = image<T>::Zero(rows, cols);
  tacmap_test::add_blobs(img, gen, 3, 3.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (Eigen::Index r = 0; r < rows / 2; ++r) {
    for (Eigen::Index c = 0; c < cols; ++c) img(r, c) += static_cast<T>(0.05 * u(gen));
  }
  return img;
}

/// Corners, the middle of every border, and a few random interior top-lefts (some repeated).
std::vector<grid_cell> positions_for(Eigen::Index last_row, Eigen::Index last_col, unsigned seed) {
  std::vector<grid_cell> p = {{0, 0},
                              {0, last_col},
                              {last_row, 0},
                              {last_row, last_col},
                              {0, last_col / 2},
                              {last_row, last_col / 2},
                              {last_row / 2, 0},
                              {last_row / 2, last_col}};
  std::mt19937 gen(seed);
  std::uniform_int_distribution<Eigen::Index> row(0, last_row);
  std::uniform_int_distribution<Eigen::Index> col(0, last_col);
  for (int i = 0; i < 6; ++i) p.push_back({row(gen), col(gen)});
  p.push_back(p[9]);
  p.push_back(p[0]);
  return p;
}

/// describe_at(img, positions[, scratch]) against compute(img) column by column; returns the
/// largest difference and checks the shape.
template <class D>
double max_difference_to_compute(const D& d, const image<typename D::scalar_type>& img,
                                 const std::vector<grid_cell>& positions,
                                 typename D::workspace* scratch = nullptr) {
  const auto field = d.compute(img);
  const auto described =
      scratch == nullptr ? d.describe_at(img, positions) : d.describe_at(img, positions, *scratch);
  REQUIRE(described.rows() == d.dimension());
  REQUIRE(described.cols() == static_cast<Eigen::Index>(positions.size()));
  double worst = 0.0;
  for (std::size_t i = 0; i < positions.size(); ++i) {
    const auto expected = field.at(positions[i].row, positions[i].col);
    const auto got = described.col(static_cast<Eigen::Index>(i));
    worst = std::max(worst, static_cast<double>((got - expected).abs().maxCoeff()));
  }
  return worst;
}

template <class D>
void check_against_compute(const D& d, Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  using T = typename D::scalar_type;
  CAPTURE(rows);
  CAPTURE(cols);
  CAPTURE(seed);
  const image<T> img = test_image<T>(rows, cols, seed);
  const auto positions = positions_for(rows - d.patch_size(), cols - d.patch_size(), seed + 100U);
  CHECK(max_difference_to_compute(d, img, positions) <= 1e-5);
}

}  // namespace

TEST_CASE_TEMPLATE("describe_at equals compute's columns at corners, borders and inside", D,
                   tacmap::sift_lite, tacmap::classic_sift, dense_sift<2, 8, double>,
                   dense_sift<4, 8, double>) {
  const D d;
  const Eigen::Index p = d.patch_size();
  // The patch size exactly (a single position), one extra row or column, the paper's tactile
  // image, the rotation canvas of the new measurement model, and a wide image.
  check_against_compute(d, p, p, 1U);
  check_against_compute(d, p + 1, p, 2U);
  check_against_compute(d, p, p + 3, 3U);
  check_against_compute(d, 42, 18, 4U);
  check_against_compute(d, 46, 46, 5U);
  check_against_compute(d, 31, 57, 6U);
}

TEST_CASE_TEMPLATE("describe_at equals compute with non-default parameters", D, tacmap::sift_lite,
                   tacmap::classic_sift, dense_sift<2, 8, double>, dense_sift<4, 8, double>) {
  SUBCASE("wider gradient filters (sigma_edge 2: 9 taps reach past the mirrored pixels)") {
    dense_sift_params prm = D::default_params();
    prm.sigma_edge = 2.0;
    check_against_compute(D(prm), 46, 46, 11U);
  }
  SUBCASE("alpha 5 (compile-time power) and alpha 2.5 (pow)") {
    dense_sift_params prm = D::default_params();
    prm.alpha = 5.0;
    check_against_compute(D(prm), 46, 40, 12U);
    prm.alpha = 2.5;
    check_against_compute(D(prm), 40, 46, 13U);
  }
  SUBCASE("normalisation off, and every descriptor normalised") {
    dense_sift_params prm = D::default_params();
    prm.norm_threshold = std::numeric_limits<double>::infinity();
    check_against_compute(D(prm), 46, 46, 14U);
    prm.norm_threshold = 0.0;
    prm.clamp = 0.1;
    check_against_compute(D(prm), 46, 46, 15U);
  }
  SUBCASE("a larger patch (bigger bins and a longer pooling kernel)") {
    dense_sift_params prm = D::default_params();
    prm.patch_size = 24;
    check_against_compute(D(prm), 24, 24, 16U);
    check_against_compute(D(prm), 46, 46, 17U);
  }
}

TEST_CASE("describe_at keeps the list's order, repeats positions and ignores the grid spacing") {
  const tacmap::sift_lite d;
  const image<float> img = test_image<float>(46, 46, 21U);
  const std::vector<grid_cell> positions = {{20, 3}, {5, 27}, {20, 3}, {11, 14}, {5, 27}};
  const auto out = d.describe_at(img, positions);
  REQUIRE(out.cols() == 5);
  CHECK((out.col(0) == out.col(2)).all());
  CHECK((out.col(1) == out.col(4)).all());
  CHECK((out.col(0) - out.col(1)).abs().maxCoeff() > 1e-3);  // different patches differ
  // One position at a time gives the same columns as the batch (normalisation is per column).
  for (std::size_t i = 0; i < positions.size(); ++i) {
    const auto one = d.describe_at(img, std::span<const grid_cell>(&positions[i], 1));
    CHECK((one.col(0) - out.col(static_cast<Eigen::Index>(i))).abs().maxCoeff() <= 1e-6);
  }
  // Grid points of sample() are describe_at positions too.
  const auto samples = d.sample(img);
  std::vector<grid_cell> grid;
  for (Eigen::Index i = 0; i < samples.rows; ++i) {
    for (Eigen::Index j = 0; j < samples.cols; ++j) {
      grid.push_back({samples.top_left_row(i), samples.top_left_col(j)});
    }
  }
  const auto at_grid = d.describe_at(img, grid);
  CHECK((at_grid - samples.values).abs().maxCoeff() <= 1e-5);
}

TEST_CASE_TEMPLATE("describe_at reusing one workspace equals compute, whatever it saw before", D,
                   tacmap::sift_lite, tacmap::classic_sift) {
  // One workspace through images of different sizes and contents, and positions that touch
  // different pixels each time: what an earlier call left in it (channels outside this call's
  // spans, margins kept zero for the same size, scratch rows) must never leak into the result.
  using T = typename D::scalar_type;
  const D d;
  typename D::workspace scratch;
  const std::vector<std::pair<Eigen::Index, Eigen::Index>> sizes = {{46, 46}, {46, 46}, {30, 52},
                                                                    {46, 46}, {60, 40}, {46, 46}};
  unsigned seed = 300U;
  for (const auto& [rows, cols] : sizes) {
    CAPTURE(rows);
    CAPTURE(cols);
    ++seed;
    const image<T> img = test_image<T>(rows, cols, seed);
    // A different few positions each call (the spans change with them).
    std::vector<grid_cell> positions =
        positions_for(rows - d.patch_size(), cols - d.patch_size(), seed + 50U);
    positions.resize(3 + seed % 4);
    CHECK(max_difference_to_compute(d, img, positions, &scratch) <= 1e-5);
  }
  // Another parameter set (a different patch, so a different margin) through the same workspace,
  // on an image of the size it saw last.
  dense_sift_params other = d.params();
  other.patch_size = d.patch_size() == 16 ? 12 : 10;
  const D small_patch(other);
  const image<T> img = test_image<T>(46, 46, 999U);
  const std::vector<grid_cell> positions = {{0, 0}, {20, 17}, {46 - other.patch_size, 3}};
  CHECK(max_difference_to_compute(small_patch, img, positions, &scratch) <= 1e-5);
}

TEST_CASE("describe_at of an empty list is dimension x 0; the image is still checked") {
  const tacmap::classic_sift d;
  const image<float> img = test_image<float>(20, 20, 31U);
  const auto none = d.describe_at(img, {});
  CHECK(none.rows() == 128);
  CHECK(none.cols() == 0);
  const image<float> small = image<float>::Zero(15, 40);
  const std::string msg = message_of([&] { (void)d.describe_at(small, {}); });
  CHECK(msg.find("describe_at") != std::string::npos);
  CHECK(msg.find("15 x 40") != std::string::npos);
  CHECK(msg.find("16 x 16") != std::string::npos);
}

TEST_CASE("describe_at rejects patches outside the image, naming the entry, position and size") {
  const tacmap::sift_lite d;
  const image<float> img = test_image<float>(42, 18, 41U);
  // Valid top-lefts: rows 0..24, column 0 only.
  struct bad_case {
    grid_cell cell;
    std::string position;
  };
  const std::vector<bad_case> cases = {{{25, 0}, "(row 25, col 0)"},
                                       {{0, 1}, "(row 0, col 1)"},
                                       {{-1, 0}, "(row -1, col 0)"},
                                       {{3, -4}, "(row 3, col -4)"},
                                       {{1000, 1000}, "(row 1000, col 1000)"}};
  for (const auto& c : cases) {
    CAPTURE(c.position);
    const std::vector<grid_cell> positions = {{0, 0}, {24, 0}, c.cell};
    const std::string msg = message_of([&] { (void)d.describe_at(img, positions); });
    CHECK(msg.find("describe_at") != std::string::npos);
    CHECK(msg.find("top_left[2]") != std::string::npos);
    CHECK(msg.find(c.position) != std::string::npos);
    CHECK(msg.find("42 x 18") != std::string::npos);
    CHECK(msg.find("18 x 18") != std::string::npos);
    CHECK(msg.find("0 <= row <= 24") != std::string::npos);
    CHECK(msg.find("0 <= col <= 0") != std::string::npos);
  }
  // The first bad entry is the one named.
  const std::vector<grid_cell> two_bad = {{0, 0}, {30, 0}, {40, 0}};
  const std::string msg = message_of([&] { (void)d.describe_at(img, two_bad); });
  CHECK(msg.find("top_left[1]") != std::string::npos);
  CHECK(msg.find("(row 30, col 0)") != std::string::npos);
}

TEST_CASE("describe_at rejects non-finite images like compute") {
  const tacmap::sift_lite d;
  image<float> img = test_image<float>(46, 46, 51U);
  img(30, 7) = std::numeric_limits<float>::quiet_NaN();
  const std::vector<grid_cell> positions = {{0, 0}};
  const std::string msg = message_of([&] { (void)d.describe_at(img, positions); });
  CHECK(msg.find("describe_at") != std::string::npos);
  CHECK(msg.find("NaN") != std::string::npos);
  CHECK(msg.find("46 x 46") != std::string::npos);
  img(30, 7) = std::numeric_limits<float>::infinity();
  CHECK(message_of([&] { (void)d.describe_at(img, positions); }) != "no exception");
}

}  // namespace test_describe_at
