// Tests of the experiment runner (sim/experiment.hpp): the paper's metrics on hand-made records,
// and one short gecko sequence end to end.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <stdexcept>

#include "gecko_protocol.hpp"
#include "tacmap/io/png_rgb.hpp"
#include "tacmap/sim/experiment.hpp"
#include "tacmap/sim/protocol.hpp"

namespace test_experiment {

namespace {

std::vector<tacmap::touch_record> records(std::initializer_list<double> errors) {
  std::vector<tacmap::touch_record> out;
  std::size_t step = 0;
  for (const double e : errors) {
    tacmap::touch_record r;
    r.step = step++;
    r.error_mm = e;
    out.push_back(r);
  }
  return out;
}

using tacmap_test::gecko;

}  // namespace

TEST_CASE("touches_to_localize: first touch from which the error stays below the threshold") {
  CHECK(tacmap::touches_to_localize(records({40, 30, 2, 1, 1, 1, 1})) == 3U);
  CHECK(tacmap::touches_to_localize(records({1, 1, 1})) == 1U);
  // Dropping back above resets the count: localized only from touch 5.
  CHECK(tacmap::touches_to_localize(records({1, 2, 30, 9, 4, 3, 1})) == 5U);
  // Never below at the end: not localized.
  CHECK_FALSE(tacmap::touches_to_localize(records({1, 1, 1, 1, 1, 1, 7})).has_value());
  CHECK_FALSE(tacmap::touches_to_localize({}).has_value());
  // Exactly the threshold is not below it.
  CHECK_FALSE(tacmap::touches_to_localize(records({5.0})).has_value());
  CHECK(tacmap::touches_to_localize(records({9, 9, 2.5}), 3.0) == 3U);
}

TEST_CASE("localized: below 5 mm by touch 6 and staying below") {
  CHECK(tacmap::localized(records({40, 30, 20, 10, 8, 4, 3})));
  CHECK_FALSE(tacmap::localized(records({40, 30, 20, 10, 8, 6, 3})));  // only at touch 7
  CHECK_FALSE(tacmap::localized(records({1, 1, 1, 1, 1, 1, 6})));      // lost at the end
  CHECK(tacmap::localized(records({1, 1, 1, 1, 1, 1, 6}), 10.0));
  CHECK(tacmap::localized(records({9, 9, 9, 1}), 5.0, 4));
  CHECK_FALSE(tacmap::localized(records({9, 9, 9, 1}), 5.0, 3));
}

TEST_CASE("median and median_error_per_touch") {
  CHECK(tacmap::median({3, 1, 2}) == 2.0);
  CHECK(tacmap::median({4, 1, 3, 2}) == 2.5);
  CHECK(std::isnan(tacmap::median({})));
  std::vector<tacmap::sequence_result> runs(3);
  runs[0].touches = records({10, 1, 7});
  runs[1].touches = records({20, 3});
  runs[2].touches = records({30, 2, 5});
  const auto m = tacmap::median_error_per_touch(runs);
  REQUIRE(m.size() == 3);
  CHECK(m[0] == 20.0);
  CHECK(m[1] == 2.0);
  CHECK(m[2] == 6.0);  // only two sequences have a third touch
}

TEST_CASE("localization_config::name") {
  tacmap::localization_config c;  // the default: the best configuration measured
  CHECK(c.name() == "classic_sift/aligned/exponential/per_window/latent");
  c.model = tacmap::measurement_kind::ncc;
  CHECK(c.name() == "ncc/latent");
  c.model = tacmap::measurement_kind::lite;
  c.pairs = tacmap::pairing::all_pairs;
  c.shape = tacmap::likelihood_shape::inverse;
  c.features = tacmap::window_features::shared_dense;
  c.appearance = tacmap::appearance_handling::fixed;  // the paper's: raised parts look bright
  CHECK(c.name() == "sift_lite/all_pairs/inverse/shared_dense");
  c.appearance = tacmap::appearance_handling::unsigned_gradients;
  CHECK(c.name() == "sift_lite/all_pairs/inverse/shared_dense/unsigned");
}

TEST_CASE("localization_experiment: a gecko sequence end to end (NCC, fast in Debug)") {
  tacmap::localization_config config;
  config.model = tacmap::measurement_kind::ncc;
  tacmap::localization_experiment experiment(gecko(), config);
  const tacmap::sequence_result r = experiment.run(0, true);
  const tacmap::touch_sequence& seq = gecko().sequences[0];
  REQUIRE(r.touches.size() == seq.size());
  REQUIRE(r.beliefs.size() == seq.size());
  REQUIRE(r.tactile_images.size() == seq.size());
  for (std::size_t t = 0; t < seq.size(); ++t) {
    const auto& rec = r.touches[t];
    CHECK(rec.step == t);
    CHECK(rec.location == seq[t].location);
    CHECK(rec.true_x_mm == gecko().locations[seq[t].location].x_mm);
    CHECK(rec.true_y_mm == gecko().locations[seq[t].location].y_mm);
    // The error is the confidence estimate's (the most probable 5 mm disc); the MAP's is kept.
    CHECK(rec.error_mm == doctest::Approx(std::hypot(rec.estimate_x_mm - rec.true_x_mm,
                                                     rec.estimate_y_mm - rec.true_y_mm)));
    CHECK(rec.map_error_mm ==
          doctest::Approx(std::hypot(rec.map_x_mm - rec.true_x_mm, rec.map_y_mm - rec.true_y_mm)));
    CHECK(rec.probability_within >= 0.0);
    CHECK(rec.probability_within <= 1.0 + 1e-6);
    CHECK((rec.verdict == tacmap::verdict::localized) == (rec.probability_within >= 0.9));
    CHECK(rec.entropy_nats >= 0.0);
    CHECK(r.beliefs[t].rows() == experiment.filter().grid().rows());
    CHECK(r.beliefs[t].cols() == experiment.filter().grid().cols());
    CHECK(r.beliefs[t].sum() == doctest::Approx(1.0).epsilon(1e-3));
    if (rec.accepted) {
      CHECK(r.tactile_images[t].rows() == 42);
      CHECK(r.tactile_images[t].cols() == 18);
    }
  }
  // Touches sharpen the belief: the last entropy is far below the uniform prior's log(8137).
  CHECK(r.touches.back().entropy_nats < 0.5 * std::log(8137.0));
  CHECK(r.touches.back().error_mm < 5.0);
  // Reproducible: the same sequence again gives the same numbers (the filter is reset).
  const tacmap::sequence_result again = experiment.run(0);
  CHECK(again.beliefs.empty());
  for (std::size_t t = 0; t < seq.size(); ++t)
    CHECK(again.touches[t].error_mm == r.touches[t].error_mm);
}

TEST_CASE("localization_experiment: a rejected frame is reported and skips the update") {
  tacmap::localization_config config;
  config.model = tacmap::measurement_kind::ncc;
  config.preprocessing.min_peak = 1e9F;  // nothing is strong enough
  tacmap::localization_experiment experiment(gecko(), config);
  const auto r = experiment.run(1);
  // No update ever: the belief is what the predictions alone make of a uniform prior.
  auto reference = experiment.filter();
  reference.reset();
  const tacmap::touch_sequence& seq = gecko().sequences[1];
  REQUIRE(r.touches.size() == seq.size());
  CHECK(r.touches[0].entropy_nats == doctest::Approx(std::log(8137.0)));
  for (std::size_t t = 0; t < seq.size(); ++t) {
    const auto& rec = r.touches[t];
    CHECK_FALSE(rec.accepted);
    CHECK(rec.rejection == tacmap::frame_rejection::weak_peak);
    if (t > 0) static_cast<void>(reference.predict(seq[t].measured_motion));
    CHECK(rec.entropy_nats == doctest::Approx(reference.estimate().entropy_nats));
  }
}

TEST_CASE("localization_experiment: bad input") {
  tacmap::localization_experiment experiment(gecko(), [] {
    tacmap::localization_config c;
    c.model = tacmap::measurement_kind::ncc;
    return c;
  }());
  CHECK_THROWS_WITH_AS(static_cast<void>(experiment.run(99)),
                       doctest::Contains("sequence 99 does not exist"), std::invalid_argument);
  tacmap::touch_protocol tiny = gecko();
  tiny.map = tacmap::image<float>::Zero(10, 10);
  CHECK_THROWS_AS(tacmap::localization_experiment(tiny, {}), std::invalid_argument);
}

TEST_CASE("encode_png_rgb: header and stored scanlines") {
  tacmap::rgb_image img = tacmap::rgb_image::filled(2, 3, 0.0F, 0.0F, 0.0F);
  img.set(0, 0, 1.0F, 0.0F, 0.0F);
  img.set(1, 2, 0.0F, 1.0F, 0.2F);
  img.set(5, 5, 1.0F, 1.0F, 1.0F);  // off the image: ignored
  const std::string png = tacmap::encode_png_rgb(img);
  REQUIRE(png.size() > 33);
  CHECK(png.substr(0, 8) == std::string("\x89PNG\r\n\x1a\n", 8));
  CHECK(png.substr(12, 4) == "IHDR");
  const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(png[i]); };
  CHECK(byte(19) == 3);  // width
  CHECK(byte(23) == 2);  // height
  CHECK(byte(24) == 8);  // bit depth
  CHECK(byte(25) == 2);  // colour type: RGB
  // IDAT: zlib header (2 bytes), one stored block header (5 bytes), then the raw scanlines.
  const std::size_t idat = png.find("IDAT");
  REQUIRE(idat != std::string::npos);
  const std::string raw = png.substr(idat + 4 + 2 + 5, 2 * (1 + 3 * 3));
  const std::string expected(
      "\0\xff\0\0\0\0\0\0\0\0"
      "\0\0\0\0\0\0\0\0\xff\x33",
      20);
  CHECK(raw == expected);
  tacmap::rgb_image bad = img;
  bad.g = tacmap::image<float>::Zero(3, 3);
  CHECK_THROWS_WITH_AS(static_cast<void>(tacmap::encode_png_rgb(bad)),
                       doctest::Contains("channel sizes differ"), std::invalid_argument);
  bad = img;
  bad.b(0, 1) = std::nanf("");
  CHECK_THROWS_AS(static_cast<void>(tacmap::encode_png_rgb(bad)), std::invalid_argument);
}

TEST_CASE("localization_experiment: a random polarity is drawn per sequence, reproducibly") {
  tacmap::localization_config config;
  config.model = tacmap::measurement_kind::ncc;  // fast in Debug
  config.scenario.polarity = tacmap::relief_polarity::random;
  tacmap::localization_experiment experiment(gecko(), config);
  int dark = 0;
  for (std::size_t q = 0; q < 10; ++q) {
    const auto a = experiment.run(q);
    const auto b = experiment.run(q);
    CHECK(a.raised_dark == b.raised_dark);  // fixed by (seed, sequence)
    dark += a.raised_dark ? 1 : 0;
    // The latent default reports which appearance it believes; after the last touch it should
    // lean to the one drawn.
    REQUIRE(a.touches.back().appearance_probability.size() == 2);
    CHECK(a.touches.back().appearance_probability[a.raised_dark ? 1 : 0] > 0.5);
  }
  CHECK(dark > 0);
  CHECK(dark < 10);
  // The dark variant presses the inverted relief: high where the gecko map is dark.
  tacmap::localization_config dark_config = config;
  dark_config.scenario.polarity = tacmap::relief_polarity::dark_raised;
  const tacmap::localization_experiment dark_experiment(gecko(), dark_config);
  CHECK(dark_experiment.relief_mm()(0, 0) > 3.9F);  // the map's corner is the dark base
  CHECK(experiment.relief_mm()(0, 0) < 0.1F);       // the bright variant: base at 0
}

}  // namespace test_experiment
