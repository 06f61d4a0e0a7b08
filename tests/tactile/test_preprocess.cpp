#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "tacmap/tactile/preprocess.hpp"
#include "test_support.hpp"

namespace test_preprocess {

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
  // A flat frame, so the no-pattern check is turned off: this test is about the geometry.
  const auto out = preprocess(f, {.min_contrast = 0.0F, .mm_per_px = 0.5});
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

TEST_CASE("a frame without a pattern (saturated, or evenly loaded) is rejected as flat") {
  tactile_frame saturated;  // every taxel at the 12-bit full scale: passes min_peak and min_total
  saturated.counts.setConstant(4095.0F);
  const auto full = preprocess(saturated);
  CHECK_FALSE(full.accepted());
  CHECK(full.rejection == frame_rejection::flat);
  CHECK(full.contrast == 0.0F);
  CHECK(full.peak == 4095.0F);
  CHECK(full.pixels.size() == 0);
  CHECK(full.reason().find("contrast (max - min) / max 0.000000 is below min_contrast") !=
        std::string::npos);

  // Saturated with read-out noise below it (0 to 100 counts): still no pattern.
  tactile_frame noisy = saturated;
  for (Eigen::Index i = 0; i < noisy.counts.size(); ++i)
    noisy.counts.data()[i] -= static_cast<float>((i * 37) % 101);
  const auto noise_only = preprocess(noisy);
  CHECK(noise_only.rejection == frame_rejection::flat);
  CHECK(noise_only.contrast == doctest::Approx(100.0 / 4095.0));

  // Flat at any level, not only full scale.
  tactile_frame even;
  even.counts.setConstant(1500.0F);
  CHECK(preprocess(even).rejection == frame_rejection::flat);

  // The threshold is min_contrast, a fraction of the peak: at 2000 counts the default 0.05 is
  // 100 counts of pattern; 99 fail, 101 pass.
  tactile_frame faint;
  faint.counts.setConstant(2000.0F);
  faint.counts(3, 2) = 2000.0F - 99.0F;
  CHECK(preprocess(faint).rejection == frame_rejection::flat);
  faint.counts(3, 2) = 2000.0F - 101.0F;
  const auto enough = preprocess(faint);
  CHECK(enough.accepted());
  CHECK(enough.contrast == doctest::Approx(101.0 / 2000.0));
  // Saturated but for a real pattern: accepted.
  tactile_frame clipped = saturated;
  clipped.counts.block(0, 0, 5, 6).setConstant(1000.0F);
  CHECK(preprocess(clipped).accepted());
  // A faint touch with an unloaded taxel spans the whole range: lowering min_peak and min_total
  // is enough to accept it, min_contrast needs no change.
  tactile_frame light;
  light.counts.setZero();
  light.counts(4, 4) = 3.0F;
  const auto weak_but_patterned = preprocess(light, {.min_peak = 1.0F, .min_total = 1.0F});
  CHECK(weak_but_patterned.accepted());
  CHECK(weak_but_patterned.contrast == 1.0F);
  // A one-taxel array has no pattern to lose: the check does not apply.
  tactile_frame single;
  single.geometry = {.rows = 1, .cols = 1, .pitch_mm = 5.0};
  single.counts = tacmap::image<float>::Constant(1, 1, 4095.0F);
  CHECK(preprocess(single, {.min_total = 0.0F}).accepted());
  // 0 turns the check off; a custom threshold applies as given.
  CHECK(preprocess(saturated, {.min_contrast = 0.0F}).accepted());
  CHECK(preprocess(faint, {.min_contrast = 0.06F}).rejection == frame_rejection::flat);
  // The weak checks come first: an empty frame is weak, not flat.
  tactile_frame empty;
  empty.counts.setZero();
  CHECK(preprocess(empty).rejection == frame_rejection::weak_peak);
  CHECK(message_of([] {
          (void)preprocess(tactile_frame{}, {.min_contrast = 5.0F});
        }).find("min_contrast = 5; expected a fraction of the peak in [0, 1]") !=
        std::string::npos);
  CHECK(message_of([] {
          (void)preprocess(tactile_frame{}, {.min_contrast = std::nanf("")});
        }).find("min_contrast = nan") != std::string::npos);
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

}  // namespace test_preprocess
