#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "tacmap/tactile/preprocess.hpp"
#include "test_support.hpp"

using tacmap::frame_rejection;
using tacmap::preprocess;
using tacmap::preprocess_params;
using tacmap::resize_method;
using tacmap::tactile_frame;

using tacmap_test::message_of;

namespace {
tactile_frame paper_frame() {
  tactile_frame f;  // 14 x 6 at 3.4 mm
  f.counts.setZero();
  f.counts.block(4, 2, 3, 2).setConstant(1000.0F);
  f.counts(5, 3) = 4000.0F;
  return f;
}
}  // namespace

TEST_CASE("the paper's 14 x 6 frame becomes a 42 x 18 image in [0, 1]") {
  const auto out = preprocess(paper_frame());
  REQUIRE(out.accepted());
  CHECK(out.reason().empty());
  CHECK(out.pixels.rows() == 42);
  CHECK(out.pixels.cols() == 18);
  CHECK(out.pixels.maxCoeff() == doctest::Approx(1.0F));
  CHECK(out.pixels.minCoeff() >= 0.0F);
  CHECK(out.peak == 4000.0F);
  CHECK(out.total == doctest::Approx(5.0F * 1000.0F + 4000.0F));
  // Taxel (5, 3) covers pixels rows 15..17, cols 9..11; its centre pixel (16, 10) is the peak.
  CHECK(out.pixels(16, 10) == doctest::Approx(1.0F));
  CHECK(out.pixels(0, 0) == 0.0F);
}

TEST_CASE("nearest resizing fills each taxel's 3 x 3 pixel block") {
  const auto out = preprocess(paper_frame(), {.resize = resize_method::nearest});
  REQUIRE(out.accepted());
  CHECK((out.pixels.block(15, 9, 3, 3) == 1.0F).all());
  CHECK((out.pixels.block(12, 6, 3, 3) == 0.25F).all());  // taxel (4, 2): 1000 / 4000
  CHECK(out.pixels.sum() == doctest::Approx(9.0F * (1.0F + 5.0F * 0.25F)));
}

TEST_CASE("other geometries and scales come from the frame, nothing assumes 14 x 6") {
  tactile_frame f;
  f.geometry = {.rows = 8, .cols = 8, .pitch_mm = 2.0};
  f.counts = tacmap::image<float>::Constant(8, 8, 500.0F);
  const auto out = preprocess(f, {.mm_per_px = 0.5});
  REQUIRE(out.accepted());
  CHECK(out.pixels.rows() == 32);
  CHECK(out.pixels.cols() == 32);
  CHECK((out.pixels == 1.0F).all());
  // 14 x 3.4 mm = 47.6 mm at 1 mm per px rounds to 48 px; 6 x 3.4 = 20.4 mm to 20 px.
  const auto window = tacmap::tactile_window({}, 1.0);
  CHECK(window.height == 48);
  CHECK(window.width == 20);
}

TEST_CASE("weak frames are rejected and reported, never silently used") {
  tactile_frame empty;
  empty.counts.setZero();
  const auto none = preprocess(empty);
  CHECK_FALSE(none.accepted());
  CHECK(none.rejection == frame_rejection::weak_peak);
  CHECK(none.reason().find("below min_peak") != std::string::npos);
  CHECK(none.pixels.size() == 0);

  tactile_frame light;  // one taxel at 300 counts: peak passes 200, total fails 600
  light.counts.setZero();
  light.counts(0, 0) = 300.0F;
  const auto weak = preprocess(light);
  CHECK(weak.rejection == frame_rejection::weak_total);
  CHECK(weak.reason().find("300") != std::string::npos);
  // With thresholds at zero, any non-empty frame is accepted; an all-zero one never is.
  CHECK(preprocess(light, {.min_peak = 0.0F, .min_total = 0.0F}).accepted());
  CHECK_FALSE(preprocess(empty, {.min_peak = 0.0F, .min_total = 0.0F}).accepted());
}

TEST_CASE("malformed frames and parameters raise errors naming the value") {
  tactile_frame f = paper_frame();
  f.counts(2, 1) = std::numeric_limits<float>::quiet_NaN();
  CHECK(message_of([&] { (void)preprocess(f); }).find("taxel (2, 1) = nan") != std::string::npos);
  f = paper_frame();
  f.counts(3, 3) = -5.0F;
  CHECK(message_of([&] { (void)preprocess(f); }).find("taxel (3, 3) = -5") != std::string::npos);
  f = paper_frame();
  f.geometry.rows = 16;
  const auto shape = message_of([&] { (void)preprocess(f); });
  CHECK(shape.find("counts are 14 x 6 but the geometry says 16 x 6") != std::string::npos);
  f = paper_frame();
  f.geometry.pitch_mm = 0.0;
  CHECK(message_of([&] { (void)preprocess(f); }).find("pitch_mm = 0") != std::string::npos);
  CHECK(message_of([&] {
          (void)preprocess(paper_frame(), {.mm_per_px = -1.0});
        }).find("mm_per_px = -1") != std::string::npos);
  CHECK(message_of([&] {
          (void)preprocess(paper_frame(), {.mm_per_px = 100.0});
        }).find("covers less than one pixel") != std::string::npos);
}
