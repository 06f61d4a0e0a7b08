// The shipped SIFT descriptors through the user conformance suite and the paper's measurement
// model.
#include <doctest/doctest.h>

#include "ranked_first.hpp"
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/testing/conformance.hpp"

namespace test_sift_likelihood {

TEST_CASE_TEMPLATE_INVOKE(tacmap_descriptor_conformance, tacmap::sift_lite, tacmap::classic_sift);

static_assert(tacmap::euclidean_descriptor<tacmap::sift_lite>);
static_assert(tacmap::measurement_model<tacmap::descriptor_likelihood<tacmap::sift_lite>,
                                        tacmap::planar_grid<float>>);

TEST_CASE_TEMPLATE(
    "on a noiseless tactile image cut from the map, SIFT ranks the true window first", D,
    tacmap::sift_lite, tacmap::classic_sift) {
  // The paper's window and scale on a smaller map (25 x 43 states keeps the Debug build quick).
  const auto map = tacmap::testing::conformance_image(66, 60, 11);
  const tacmap::planar_grid<float> grid({.width = 60, .height = 66}, 3.4 / 3.0,
                                        {.width = 18, .height = 42});
  // The default, per-window features (the paper's): a noiseless cut matches its own window.
  for (const tacmap::pairing pairs : {tacmap::pairing::aligned, tacmap::pairing::all_pairs}) {
    const tacmap::descriptor_likelihood<D> model(D{}, map, grid.window_size(), {.pairs = pairs});
    REQUIRE(model.patches_per_window() == 3);  // the paper: three descriptors per 42 x 18 image
    const auto [first, tried] = tacmap_test::ranked_first(model, grid, map);
    CAPTURE(static_cast<int>(pairs));
    CAPTURE(first);
    CAPTURE(tried);
    CHECK(first == tried);
  }
}

TEST_CASE_TEMPLATE("tactile descriptors: the sampled path equals the dense field's columns", D,
                   tacmap::sift_lite, tacmap::classic_sift) {
  // descriptor_likelihood describes a tactile image with dense_sift::sample when the descriptor's
  // grid spacing equals the model's; otherwise it cuts the dense field. Both must agree.
  const auto map = tacmap::testing::conformance_image(60, 40, 5);
  const tacmap::image<float> z = tacmap::testing::conformance_image(42, 18, 6);
  const D d{};
  for (const Eigen::Index spacing : {d.grid_spacing(), Eigen::Index{3}}) {
    CAPTURE(spacing);
    const tacmap::descriptor_likelihood<D> model(d, map, {.width = 18, .height = 42},
                                                 {.spacing = spacing});
    const auto g = model.tactile_descriptors(z);
    const auto field = d.compute(z);
    REQUIRE(g.cols() == model.patches_per_window());
    REQUIRE(g.cols() == (42 - d.patch_size()) / spacing + 1);
    for (Eigen::Index m = 0; m < g.cols(); ++m) {
      const auto o = model.patch_offset(m);
      CHECK((g.col(m) - field.at(o.row, o.col)).abs().maxCoeff() < 1e-6F);
      CHECK(field.at(o.row, o.col).abs().sum() > 0.1F);  // a real, non-zero descriptor
    }
  }
}

}  // namespace test_sift_likelihood
