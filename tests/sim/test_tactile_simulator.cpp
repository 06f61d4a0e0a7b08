#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/sim/tactile_simulator.hpp"
#include "tacmap/tactile/preprocess.hpp"
#include "test_support.hpp"

namespace test_tactile_simulator {

using tacmap::image;
using tacmap::map_pose;
using tacmap::simulator_params;
using tacmap::tactile_simulator;

using tacmap_test::message_of;

namespace {

constexpr double s = 3.4 / 3.0;  // the paper's map scale
constexpr tacmap::pixel_size paper_map{.width = 120, .height = 120};

// A simulator with no noise, no gain spread and no dead taxels: the model's deterministic core.
simulator_params ideal(simulator_params p = {}) {
  p.noise_counts = 0.0;
  p.gain_variation = 0.0;
  p.dead_fraction = 0.0;
  return p;
}

// A relief with a few irregular raised blocks (4 mm), nothing symmetric.
image<float> blocks_relief() {
  image<float> r = image<float>::Zero(120, 120);
  r.block(30, 40, 20, 8).setConstant(4.0F);
  r.block(55, 52, 6, 25).setConstant(4.0F);
  r.block(70, 45, 15, 5).setConstant(4.0F);
  r.block(40, 60, 4, 4).setConstant(4.0F);
  return r;
}

// Map position (mm) of taxel (row, col)'s centre for a pose with theta = 0.
Eigen::Vector2d taxel_centre(const map_pose& pose, const tacmap::taxel_geometry& g,
                             Eigen::Index row, Eigen::Index col) {
  return {
      pose.x_mm + (static_cast<double>(col) - 0.5 * static_cast<double>(g.cols - 1)) * g.pitch_mm,
      pose.y_mm + (static_cast<double>(row) - 0.5 * static_cast<double>(g.rows - 1)) * g.pitch_mm};
}

}  // namespace

TEST_CASE("the default frame is the paper's 14 x 6 array with integer counts in 0..4095") {
  tactile_simulator sim(blocks_relief(), paper_map, s);
  const auto frame = sim.render({60.0, 60.0, 0.0});
  CHECK(frame.geometry == tacmap::taxel_geometry{});
  CHECK(frame.counts.rows() == 14);
  CHECK(frame.counts.cols() == 6);
  CHECK_NOTHROW(frame.validate());
  CHECK((frame.counts == frame.counts.round()).all());
  CHECK(frame.counts.maxCoeff() <= 4095.0F);
  CHECK(frame.counts.maxCoeff() > 1000.0F);  // the blocks are touched
}

TEST_CASE("same seed gives the same frames; another seed gives other noise") {
  const map_pose pose{60.0, 60.0, 0.0};
  tactile_simulator a(blocks_relief(), paper_map, s, {.seed = 42});
  tactile_simulator b(blocks_relief(), paper_map, s, {.seed = 42});
  tactile_simulator c(blocks_relief(), paper_map, s, {.seed = 43});
  const auto a1 = a.render(pose), a2 = a.render(pose);
  const auto b1 = b.render(pose), b2 = b.render(pose);
  const auto c1 = c.render(pose);
  CHECK((a1.counts == b1.counts).all());
  CHECK((a2.counts == b2.counts).all());
  CHECK((a.taxel_gain() == b.taxel_gain()).all());
  // Successive frames of one simulator carry fresh noise, as repeated readings of a sensor do.
  CHECK((a1.counts != a2.counts).any());
  CHECK((a1.counts != c1.counts).any());
  CHECK((a.taxel_gain() != c.taxel_gain()).any());
  // Noise is zero-mean: without gain spread, many frames average to the expected counts.
  tactile_simulator noisy(blocks_relief(), paper_map, s, {.gain_variation = 0.0, .seed = 5});
  const image<float> expected = noisy.expected_counts(pose);
  image<double> mean = image<double>::Zero(14, 6);
  for (int k = 0; k < 400; ++k) mean += noisy.render(pose).counts.cast<double>();
  mean /= 400.0;
  const auto loaded = (expected > 100.0F && expected < 3900.0F);
  REQUIRE(loaded.count() > 5);
  const double worst = loaded.select((mean - expected.cast<double>()).abs(), 0.0).maxCoeff();
  CHECK(worst < 3.0);  // 10-count noise over 400 frames: standard error 0.5
}

TEST_CASE("frames carry running sequence numbers and timestamps") {
  tactile_simulator sim(blocks_relief(), paper_map, s,
                        {.frame_interval = std::chrono::milliseconds(50)});
  const auto f0 = sim.render({60.0, 60.0, 0.0});
  const auto f1 = sim.render({60.0, 60.0, 0.0});
  CHECK(f0.sequence == 0);
  CHECK(f1.sequence == 1);
  CHECK(f1.timestamp - f0.timestamp == std::chrono::milliseconds(50));
}

TEST_CASE("a flat relief pressed reads flat; no press reads zero") {
  const image<float> flat = image<float>::Constant(120, 120, 2.0F);
  SUBCASE("ideal sensor: every taxel reads gain x press depth, border taxels included") {
    tactile_simulator sim(flat, paper_map, s, ideal({.press_depth_mm = 0.5}));
    const auto frame = sim.render({60.0, 60.0, 0.3});
    CHECK((frame.counts == 1000.0F).all());  // 2000 counts/mm x 0.5 mm
  }
  SUBCASE("noisy sensor: flat within the noise") {
    tactile_simulator sim(flat, paper_map, s, {.press_depth_mm = 0.5, .seed = 3});
    const auto frame = sim.render({60.0, 60.0, 0.0});
    const double mean = frame.counts.cast<double>().mean();
    CHECK(mean == doctest::Approx(1000.0).epsilon(0.03));
    CHECK(frame.counts.maxCoeff() - frame.counts.minCoeff() < 0.4F * 1000.0F);
  }
  SUBCASE("press depth 0: just touching, no load, every taxel exactly 0 despite noise") {
    tactile_simulator sim(flat, paper_map, s, {.press_depth_mm = 0.0, .noise_counts = 50.0});
    for (int k = 0; k < 5; ++k) CHECK((sim.render({60.0, 60.0, 0.0}).counts == 0.0F).all());
    // ...and preprocessing rejects such a frame as unintentional.
    CHECK(tacmap::preprocess(sim.render({60.0, 60.0, 0.0})).rejection ==
          tacmap::frame_rejection::weak_peak);
  }
}

TEST_CASE("a single bump under one taxel lights that taxel most") {
  const map_pose pose{50.0, 60.0, 0.0};
  const tacmap::taxel_geometry g{};
  for (const auto& taxel : {std::pair<Eigen::Index, Eigen::Index>{5, 3}, {0, 0}, {13, 5}, {9, 1}}) {
    const Eigen::Index row = taxel.first, col = taxel.second;
    CAPTURE(row);
    CAPTURE(col);
    const Eigen::Vector2d at = taxel_centre(pose, g, row, col);
    image<float> relief = image<float>::Zero(120, 120);
    // A 2 x 2 px (2.3 mm) bump centred on the taxel's centre.
    const auto c0 = static_cast<Eigen::Index>(std::lround(at.x() / s)) - 1;
    const auto r0 = static_cast<Eigen::Index>(std::lround(at.y() / s)) - 1;
    relief.block(r0, c0, 2, 2).setConstant(3.0F);
    tactile_simulator sim(relief, paper_map, s, {.seed = 11});
    const auto frame = sim.render(pose);
    Eigen::Index r = 0, c = 0;
    frame.counts.maxCoeff(&r, &c);
    CHECK(r == row);
    CHECK(c == col);
    CHECK(frame.counts(row, col) > 100.0F);  // 10 sigma of the read-out noise
    // The foam spreads the load to nearby taxels only (its Gaussian is cut at 3 sigma = 1.5
    // taxels): everything farther than two taxels from the bump reads exactly 0.
    for (Eigen::Index rr = 0; rr < 14; ++rr)
      for (Eigen::Index cc = 0; cc < 6; ++cc)
        if (std::abs(rr - row) > 2 || std::abs(cc - col) > 2) CHECK(frame.counts(rr, cc) == 0.0F);
  }
}

TEST_CASE("total counts grow with the press depth") {
  tactile_simulator base(blocks_relief(), paper_map, s, ideal({.gain_counts_per_mm = 500.0}));
  double previous = -1.0;
  for (const double depth : {0.0, 0.25, 0.5, 1.0, 2.0, 4.5}) {
    CAPTURE(depth);
    simulator_params p = base.params();
    p.press_depth_mm = depth;
    tactile_simulator sim(blocks_relief(), paper_map, s, p);
    const double total = sim.expected_counts({55.0, 62.0, 0.0}).cast<double>().sum();
    CHECK(total > previous);
    previous = total;
  }
  // Past the 4 mm protrusion the base is pressed too: the whole array is loaded.
  simulator_params p = base.params();
  p.press_depth_mm = 4.5;
  CHECK((tactile_simulator(blocks_relief(), paper_map, s, p).expected_counts({55.0, 62.0, 0.0}) >
         0.0F)
            .all());
}

TEST_CASE("saturation at 4095 and quantisation to whole counts") {
  tactile_simulator sim(image<float>::Constant(120, 120, 1.0F), paper_map, s,
                        {.press_depth_mm = 1.0, .gain_counts_per_mm = 10000.0});
  const auto frame = sim.render({60.0, 60.0, 0.0});
  CHECK((frame.counts == 4095.0F).all());

  tactile_simulator soft(blocks_relief(), paper_map, s,
                         {.press_depth_mm = 0.37, .gain_counts_per_mm = 1234.5, .seed = 9});
  const auto f = soft.render({55.0, 62.0, 0.0});
  CHECK((f.counts == f.counts.round()).all());
  CHECK(((f.counts - f.counts.round()).abs() == 0.0F).all());
  // Counts are the noiseless values plus noise, rounded: within a few sigma of them.
  const image<float> expected = soft.expected_counts({55.0, 62.0, 0.0});
  CHECK(((f.counts - expected).abs() < 60.0F).all());

  tactile_simulator ten_bit(image<float>::Constant(120, 120, 1.0F), paper_map, s,
                            {.gain_counts_per_mm = 10000.0, .full_scale_counts = 1023.0F});
  CHECK((ten_bit.render({60.0, 60.0, 0.0}).counts == 1023.0F).all());
}

TEST_CASE("dead taxels read 0, fixed per simulator") {
  const image<float> flat = image<float>::Constant(120, 120, 1.0F);
  tactile_simulator sim(flat, paper_map, s, {.dead_fraction = 0.1, .seed = 21});
  const auto& dead = sim.dead_taxels();
  CHECK(dead.count() == 8);  // round(0.1 x 84)
  for (int k = 0; k < 3; ++k) {
    const auto frame = sim.render({60.0, 60.0, 0.0});
    CHECK((dead.select(frame.counts, 0.0F) == 0.0F).all());
    CHECK((dead.select(1.0F, frame.counts) > 0.0F).all());  // the living ones are loaded
  }
  tactile_simulator same(flat, paper_map, s, {.dead_fraction = 0.1, .seed = 21});
  CHECK((same.dead_taxels() == dead).all());
  tactile_simulator other(flat, paper_map, s, {.dead_fraction = 0.1, .seed = 22});
  CHECK((other.dead_taxels() != dead).any());
  CHECK(tactile_simulator(flat, paper_map, s, {.dead_fraction = 1.0}).dead_taxels().all());
  CHECK_FALSE(tactile_simulator(flat, paper_map, s).dead_taxels().any());
}

TEST_CASE("rotation by 180 degrees reverses both frame axes; 90 degrees turns the window") {
  tactile_simulator sim(blocks_relief(), paper_map, s, ideal());
  const map_pose pose{55.0, 62.0, 0.0};
  const image<float> upright = sim.expected_counts(pose);
  const image<float> turned = sim.expected_counts({pose.x_mm, pose.y_mm, std::numbers::pi});
  REQUIRE(upright.maxCoeff() > 0.0F);
  CHECK((upright != upright.reverse()).any());  // the test would be blind to a no-op otherwise
  CHECK(((turned - upright.reverse()).abs() < 1e-3F * upright.maxCoeff()).all());

  // A 90 degree turn: the array's rows now run along -x. A bar along x (relief rows 55..60)
  // seen at 90 degrees lights a band of rows in the frame instead of columns.
  image<float> bar = image<float>::Zero(120, 120);
  bar.block(52, 20, 3, 80).setConstant(2.0F);  // y in [58.9, 62.3) mm, a long bar along x
  tactile_simulator bar_sim(bar, paper_map, s, ideal());
  const image<float> across = bar_sim.expected_counts({60.0, 60.6, 0.0});
  const image<float> along = bar_sim.expected_counts({60.0, 60.6, std::numbers::pi / 2});
  // Rows / columns of the frame that carry more than 5 % of the load, and the two heaviest.
  const auto bands = [](const Eigen::ArrayXf& sums) {
    return (sums > 0.05F * sums.maxCoeff()).count();
  };
  const auto heaviest_two = [](Eigen::ArrayXf sums) {
    Eigen::Index first = 0, second = 0;
    sums.maxCoeff(&first);
    sums(first) = -1.0F;
    sums.maxCoeff(&second);
    return std::pair{std::min(first, second), std::max(first, second)};
  };
  // theta = 0: the bar crosses the array's middle (rows 6 and 7), across all columns.
  CHECK(bands(across.rowwise().sum()) <= 4);
  CHECK(heaviest_two(across.rowwise().sum()) == std::pair<Eigen::Index, Eigen::Index>{6, 7});
  CHECK(bands(across.colwise().sum().transpose()) == 6);
  // theta = pi / 2: the bar runs along the array's rows, lighting the middle columns 2 and 3.
  CHECK(bands(along.colwise().sum().transpose()) <= 4);
  CHECK(heaviest_two(along.colwise().sum().transpose()) ==
        std::pair<Eigen::Index, Eigen::Index>{2, 3});
  CHECK(bands(along.rowwise().sum()) == 14);

  // The sense of rotation: at theta = +pi / 2 the column axis points along +y and the row axis
  // along -x, so taxel (0, 0) sits at (cx + 6.5 pitch, cy - 2.5 pitch).
  const map_pose turned_pose{60.0, 60.0, std::numbers::pi / 2};
  image<float> bump = image<float>::Zero(120, 120);
  const double bx = 60.0 + 6.5 * 3.4, by = 60.0 - 2.5 * 3.4;
  bump.block(static_cast<Eigen::Index>(by / s) - 1, static_cast<Eigen::Index>(bx / s) - 1, 2, 2)
      .setConstant(2.0F);
  Eigen::Index r = -1, c = -1;
  tactile_simulator(bump, paper_map, s, ideal()).expected_counts(turned_pose).maxCoeff(&r, &c);
  CHECK(r == 0);
  CHECK(c == 0);
}

TEST_CASE("geometries other than 14 x 6 work end to end") {
  for (const tacmap::taxel_geometry g :
       {tacmap::taxel_geometry{.rows = 8, .cols = 8, .pitch_mm = 2.0},
        tacmap::taxel_geometry{.rows = 16, .cols = 4, .pitch_mm = 4.25},
        tacmap::taxel_geometry{.rows = 1, .cols = 1, .pitch_mm = 5.0}}) {
    CAPTURE(g.rows);
    CAPTURE(g.cols);
    const map_pose pose{60.0, 60.0, 0.0};
    const Eigen::Index row = g.rows - 1, col = 0;
    const Eigen::Vector2d at = taxel_centre(pose, g, row, col);
    image<float> relief = image<float>::Zero(120, 120);
    relief(static_cast<Eigen::Index>(at.y() / s), static_cast<Eigen::Index>(at.x() / s)) = 2.0F;
    tactile_simulator sim(relief, paper_map, s, {.geometry = g, .seed = 4});
    const auto frame = sim.render(pose);
    CHECK(frame.geometry == g);
    CHECK(frame.counts.rows() == g.rows);
    CHECK(frame.counts.cols() == g.cols);
    Eigen::Index r = 0, c = 0;
    frame.counts.maxCoeff(&r, &c);
    CHECK(r == row);
    CHECK(c == col);
    const auto pre = tacmap::preprocess(frame, {.min_peak = 1.0F, .min_total = 1.0F});
    REQUIRE(pre.accepted());
    CHECK(pre.pixels.rows() == tacmap::tactile_window(g, s).height);
  }
}

TEST_CASE("a footprint off the map throws naming the pose and the map's extent") {
  tactile_simulator sim(blocks_relief(), paper_map, s);
  const std::string msg = message_of([&] { (void)sim.render({5.0, 60.0, 0.0}); });
  CHECK(msg.find("x = 5 mm") != std::string::npos);
  CHECK(msg.find("y = 60 mm") != std::string::npos);
  CHECK(msg.find("x in [-5.2, 15.2] mm") != std::string::npos);
  CHECK(msg.find("[0, 136] mm") != std::string::npos);
  CHECK(msg.find("120 x 120 px") != std::string::npos);
  CHECK(message_of([&] {
          (void)sim.render({60.0, 130.0, 0.0});
        }).find("y = 130 mm") != std::string::npos);
  // Upright the footprint fits at x = 12; turned by 90 degrees it is 47.6 mm wide and does not.
  CHECK_NOTHROW((void)sim.render({12.0, 60.0, 0.0}));
  CHECK(message_of([&] {
          (void)sim.render({12.0, 60.0, std::numbers::pi / 2});
        }).find("theta = 1.57") != std::string::npos);
  CHECK(message_of([&] {
          (void)sim.render({std::numeric_limits<double>::quiet_NaN(), 60.0, 0.0});
        }).find("not finite") != std::string::npos);
  CHECK_FALSE(sim.fits({5.0, 60.0, 0.0}));
  // Every state of the paper's grid is a valid pose, the corner states included.
  const auto grid = tacmap::planar_grid<float>::paper();
  for (const Eigen::Index i :
       {Eigen::Index{0}, grid.cols() - 1, grid.size() - grid.cols(), grid.size() - 1}) {
    const auto c = grid.state_mm(i);
    CHECK(sim.fits({c.x(), c.y(), 0.0}));
    CHECK_NOTHROW((void)sim.render({c.x(), c.y(), 0.0}));
  }
}

TEST_CASE("a relief that disagrees with the map, or holds NaN, is rejected with sizes named") {
  const std::string size_msg =
      message_of([] { tactile_simulator(image<float>::Zero(100, 120), paper_map, s); });
  CHECK(size_msg.find("relief is 120 x 100 px") != std::string::npos);
  CHECK(size_msg.find("map is 120 x 120 px") != std::string::npos);
  image<float> bad = image<float>::Zero(120, 120);
  bad(7, 9) = std::numeric_limits<float>::quiet_NaN();
  const std::string nan_msg = message_of([&] { tactile_simulator(bad, paper_map, s); });
  CHECK(nan_msg.find("(row 7, col 9)") != std::string::npos);
  CHECK(nan_msg.find("120 x 120 px") != std::string::npos);
  CHECK(message_of([] {
          tactile_simulator(image<float>::Zero(120, 120), paper_map, 0.0);
        }).find("mm_per_px = 0") != std::string::npos);
  CHECK(message_of([] {
          tactile_simulator(image<float>::Zero(120, 120), paper_map, s, {.press_depth_mm = -1.0});
        }).find("press_depth_mm = -1") != std::string::npos);
  CHECK(message_of([] {
          tactile_simulator(image<float>::Zero(120, 120), paper_map, s, {.dead_fraction = 1.5});
        }).find("dead_fraction = 1.5") != std::string::npos);
  CHECK(message_of([] {
          tactile_simulator(image<float>::Zero(120, 120), paper_map, s, {.supersample = 0});
        }).find("supersample = 0") != std::string::npos);
  CHECK(message_of([] {
          tactile_simulator(image<float>::Zero(120, 120), paper_map, s,
                            {.geometry = {.rows = 0, .cols = 6, .pitch_mm = 3.4}});
        }).find("rows = 0") != std::string::npos);
}

TEST_CASE("relief_from_image: binary protrusion, smoothing, continuous heights") {
  image<float> img = image<float>::Constant(20, 30, 0.1F);
  img.block(5, 8, 6, 10).setConstant(0.9F);
  SUBCASE("binary: the paper's 4 mm protrusion above the threshold") {
    const image<float> r = tacmap::relief_from_image(img);
    CHECK((r.block(5, 8, 6, 10) == 4.0F).all());
    CHECK(r.sum() == doctest::Approx(4.0 * 60));
    CHECK(tacmap::relief_from_image(img, {.threshold = 0.95F}).maxCoeff() == 0.0F);
  }
  SUBCASE("edge smoothing keeps the plateau and the volume, softens the step") {
    image<float> big = image<float>::Zero(20, 30);
    big.block(4, 6, 12, 18).setConstant(1.0F);
    const image<float> r = tacmap::relief_from_image(big, {.edge_smoothing_px = 1.0});
    CHECK(r(10, 15) == doctest::Approx(4.0F));  // 3 sigma inside: untouched
    CHECK(r(10, 6) > 1.0F);                     // the edge pixel is lowered...
    CHECK(r(10, 6) < 3.5F);
    CHECK(r(10, 5) > 0.5F);  // ...and the base next to it raised
    CHECK(r.sum() == doctest::Approx(4.0 * 216).epsilon(1e-4));
    CHECK(r(0, 0) == 0.0F);
  }
  SUBCASE("continuous: height = scale x intensity") {
    const image<float> r =
        tacmap::relief_from_image(img, {.kind = tacmap::relief_kind::continuous, .height_mm = 2.0});
    CHECK(r(0, 0) == doctest::Approx(0.2F));
    CHECK(r(6, 9) == doctest::Approx(1.8F));
  }
  SUBCASE("bad input names the pixel or field") {
    image<float> bad = img;
    bad(3, 4) = std::numeric_limits<float>::infinity();
    CHECK(message_of([&] { (void)tacmap::relief_from_image(bad); }).find("(row 3, col 4)") !=
          std::string::npos);
    CHECK(message_of([&] { (void)tacmap::relief_from_image(image<float>()); }).find("0 x 0") !=
          std::string::npos);
    CHECK(message_of([&] {
            (void)tacmap::relief_from_image(img, {.edge_smoothing_px = -1.0});
          }).find("edge_smoothing_px = -1") != std::string::npos);
  }
}

TEST_CASE("sim_rng: fixed streams and sane statistics") {
  tacmap::sim_rng a(123), b(123), c(124);
  CHECK(a.next_u64() == b.next_u64());
  CHECK(a.next_u64() != c.next_u64());
  // splitmix64's published first output for seed 0 (Vigna's reference implementation).
  std::uint64_t state = 0;
  CHECK(tacmap::splitmix64(state) == 0xE220A8397B1DCDAFULL);
  tacmap::sim_rng g(7);
  double sum = 0.0, sum2 = 0.0;
  constexpr int n = 20000;
  for (int k = 0; k < n; ++k) {
    const double x = g.normal();
    sum += x;
    sum2 += x * x;
  }
  CHECK(std::abs(sum / n) < 0.03);
  CHECK(sum2 / n == doctest::Approx(1.0).epsilon(0.04));
  int counts[5] = {};
  for (int k = 0; k < 5000; ++k) ++counts[g.below(5)];
  for (const int k : counts) CHECK(std::abs(k - 1000) < 120);
}

}  // namespace test_tactile_simulator
