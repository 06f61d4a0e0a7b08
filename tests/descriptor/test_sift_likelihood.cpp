// The shipped SIFT descriptors through the user conformance suite and the paper's measurement
// model.
#include <doctest/doctest.h>

#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/testing/conformance.hpp"

TEST_CASE_TEMPLATE_INVOKE(tacmap_descriptor_conformance, tacmap::sift_lite, tacmap::classic_sift);

static_assert(tacmap::euclidean_descriptor<tacmap::sift_lite>);
static_assert(tacmap::measurement_model<tacmap::descriptor_likelihood<tacmap::sift_lite>,
                                        tacmap::planar_grid<float>>);

TEST_CASE_TEMPLATE("on a noiseless tactile image cut from the map, SIFT ranks the true window first",
                   D, tacmap::sift_lite, tacmap::classic_sift) {
  const auto map = tacmap::testing::conformance_image(120, 120, 11);
  const auto grid = tacmap::planar_grid<float>::paper();
  // The default, per-window features (the paper's): a noiseless cut matches its own window.
  for (const tacmap::pairing pairs : {tacmap::pairing::aligned, tacmap::pairing::all_pairs}) {
    const tacmap::descriptor_likelihood<D> model(D{}, map, grid.window_size(), {.pairs = pairs});
    REQUIRE(model.patches_per_window() == 3);  // the paper: three descriptors per 42 x 18 image
    Eigen::ArrayXf ll(grid.size());
    int first = 0;
    int tried = 0;
    for (Eigen::Index row = 5; row < grid.rows(); row += 17)
      for (Eigen::Index col = 7; col < grid.cols(); col += 23) {
        model.log_likelihood(grid, map.block(row, col, 42, 18), ll);
        Eigen::Index best = 0;
        ll.maxCoeff(&best);
        first += best == grid.index({row, col}) ? 1 : 0;
        ++tried;
      }
    CAPTURE(static_cast<int>(pairs));
    CAPTURE(first);
    CAPTURE(tried);
    CHECK(first == tried);
  }
}
