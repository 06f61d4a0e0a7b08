// rotated_descriptor_likelihood: the tactile image turned to every heading against the map's
// dense SIFT field, described once.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "pose_test_support.hpp"
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/grid/pose_grid.hpp"
#include "tacmap/measurement/descriptor_likelihood.hpp"
#include "tacmap/measurement/rotated_descriptor_likelihood.hpp"
#include "test_support.hpp"

namespace test_rotated_descriptor_likelihood {

using tacmap::rotated_descriptor_likelihood;
using tacmap::sift_lite;
using tacmap_test::message_of;

static_assert(
    tacmap::measurement_model<rotated_descriptor_likelihood<sift_lite>, tacmap::pose_grid<float>>);
static_assert(tacmap::describes_at<sift_lite>);

namespace {

// The paper's window (18 x 42 px, three 18 px patches 9 px apart) and scale on a 64 x 64 px
// textured map: 23 x 47 positions per heading. Small, because in a Debug build one update over
// 36 headings costs about 0.3 s.
constexpr Eigen::Index map_side = 64;
const tacmap::image<float>& map64() {
  static const tacmap::image<float> map = pose_test::textured_map(map_side, map_side, 5);
  return map;
}
tacmap::pose_grid<float> grid64(int angles) {
  return tacmap::pose_grid<float>(
      tacmap::planar_grid<float>({.width = map_side, .height = map_side}, 3.4 / 3.0,
                                 {.width = 18, .height = 42}),
      angles);
}
// The references below take a patch off the map's mean over every pose where it lands (the
// definition); the models' default estimates it on a lattice (test_pose_tracking.cpp compares
// the two), so they are built with exact means.
constexpr tacmap::rotated_likelihood_params exact_means{.off_map_exact_positions = 1 << 20};
// Models are built once per heading count (describing the map is the slow part in Debug).
const rotated_descriptor_likelihood<sift_lite>& model64(int angles) {
  static const rotated_descriptor_likelihood<sift_lite> m4(sift_lite{}, map64(), grid64(4),
                                                           exact_means);
  static const rotated_descriptor_likelihood<sift_lite> m36(sift_lite{}, map64(), grid64(36),
                                                            exact_means);
  REQUIRE((angles == 4 || angles == 36));
  return angles == 4 ? m4 : m36;
}

// Patch m's centre in the sensor frame, px from the sensor centre: (0, 9 m - 12).
std::array<double, 2> patch_centre(Eigen::Index m) {
  return {0.0, 9.0 * static_cast<double>(m) + 9.0 - 21.0};
}

// The aligned eq. (1) straight from the definition, for heading quarter_turns * 90 degrees:
// the tactile image turned onto the canvas, its patch m (centred at R(theta) c_m) described by
// compute() on the whole canvas, against the map's dense field at the window's cell plus the same
// rotated offset; a patch off the map counts its mean over the states where it lands.
Eigen::ArrayXf reference_distances(const tacmap::image<float>& z, int quarter_turns,
                                   tacmap::pixel_size canvas,
                                   tacmap::pairing pairs = tacmap::pairing::aligned) {
  const sift_lite sift{};
  const auto field = sift.compute(map64());
  const auto turned = sift.compute(pose_test::turn_quarter(z, quarter_turns, canvas));
  const int q = ((quarter_turns % 4) + 4) % 4;
  const double c = q == 0 ? 1.0 : q == 2 ? -1.0 : 0.0;
  const double s = q == 1 ? 1.0 : q == 3 ? -1.0 : 0.0;
  const auto positions = grid64(1).positions();
  std::array<Eigen::ArrayXf, 3> g;  // the tactile patches' descriptors
  for (Eigen::Index n = 0; n < 3; ++n) {
    const auto [cx, cy] = patch_centre(n);
    const double x = c * cx - s * cy;
    const double y = s * cx + c * cy;
    g[static_cast<std::size_t>(n)] =
        turned.at(std::lround(0.5 * static_cast<double>(canvas.height) + y - 9.0),
                  std::lround(0.5 * static_cast<double>(canvas.width) + x - 9.0));
  }
  // Per patch m: its distance term at every state where it lands on the map (NaN elsewhere);
  // off the map it counts its mean over the states where it lands.
  Eigen::ArrayXd d = Eigen::ArrayXd::Zero(positions.size());
  for (Eigen::Index m = 0; m < 3; ++m) {
    const auto [cx, cy] = patch_centre(m);
    const double x = c * cx - s * cy;
    const double y = s * cx + c * cy;
    Eigen::ArrayXd term(positions.size());
    double total = 0.0;
    int landed = 0;
    for (Eigen::Index i = 0; i < positions.size(); ++i) {
      const auto cell = positions.cell(i);
      const auto map_row = cell.row + std::lround(21.0 + y - 9.0);
      const auto map_col = cell.col + std::lround(9.0 + x - 9.0);
      if (map_row < 0 || map_col < 0 || map_row >= field.rows || map_col >= field.cols) {
        term(i) = std::numeric_limits<double>::quiet_NaN();
        continue;
      }
      double sum = 0.0;
      for (Eigen::Index n = 0; n < 3; ++n)
        if (pairs == tacmap::pairing::all_pairs || n == m)
          sum += static_cast<double>(
              (field.at(map_row, map_col) - g[static_cast<std::size_t>(n)]).matrix().norm());
      term(i) = sum;
      total += sum;
      ++landed;
    }
    const double mean = landed > 0 ? total / landed : 0.0;
    for (Eigen::Index i = 0; i < positions.size(); ++i)
      d(i) += std::isnan(term(i)) ? mean : term(i);
  }
  return d.cast<float>();
}

}  // namespace

namespace {
/// sift_lite whose field of the map (not of a tactile canvas) holds `value` at one element.
struct poisoned_map_field : sift_lite {
  float value = 0.0F;
  tacmap::descriptor_field<float> compute(const tacmap::image<float>& img) const {
    auto f = sift_lite::compute(img);
    if (img.rows() == map64().rows() && img.cols() == map64().cols())
      f.values(5, f.values.cols() / 2) = value;
    return f;
  }
};
}  // namespace

TEST_CASE("rotated likelihood: a non-finite value in the map's field is refused by name") {
  // The field is scanned only where the tiles' squared norms are not finite: each such value
  // must still be named, and a large finite one (whose square overflows) accepted.
  for (const float bad :
       {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
        -std::numeric_limits<float>::infinity()}) {
    CAPTURE(bad);
    poisoned_map_field d;
    d.value = bad;
    const std::string m = message_of([&] {
      const rotated_descriptor_likelihood<poisoned_map_field> model(d, map64(), grid64(4));
    });
    CAPTURE(m);
    CHECK(m.find("poisoned_map_field") != std::string::npos);
    CHECK(m.find("described the map with the value") != std::string::npos);
    CHECK(m.find("element 5 of descriptor") != std::string::npos);
  }
  poisoned_map_field big;
  big.value = 1e30F;
  CHECK_NOTHROW(rotated_descriptor_likelihood<poisoned_map_field>(big, map64(), grid64(4)));
}

TEST_CASE("rotated likelihood: rotated_tactile turns the image by +theta (pose_grid convention)") {
  const auto& model = model64(4);  // headings 0, +90, -180, -90 degrees
  const auto g = grid64(4);
  const tacmap::pixel_size canvas = model.canvas_size();
  // Holds the whole 18 x 42 footprint at every heading; same parity as the window, so the
  // sensor centre sits on the same sub-pixel phase.
  CHECK(canvas.width * canvas.width + canvas.height * canvas.height >= 2 * (18 * 18 + 42 * 42));
  CHECK((canvas.width - 18) % 2 == 0);
  CHECK((canvas.height - 42) % 2 == 0);
  // An asymmetric tactile image: turned the wrong way it would not match.
  const tacmap::image<float> z = pose_test::textured_map(42, 18, 77);
  for (int q = 0; q < 4; ++q) {
    CAPTURE(q);
    const auto got = model.rotated_tactile(z, q);
    REQUIRE(got.rows() == canvas.height);
    REQUIRE(got.cols() == canvas.width);
    const tacmap::image<float> want = pose_test::turn_quarter(z, q, canvas);
    CHECK((got - want).abs().maxCoeff() < 1e-5F);
  }
  // End to end with the renderer (an independent statement of the convention): a touch at
  // +90 deg, turned back into the map frame, shows the map around the sensor centre.
  const Eigen::Index row = 10;
  const Eigen::Index col = 20;
  const auto z90 = pose_test::render_state(map64(), g, g.index(1, {row, col}));
  const auto back = model.rotated_tactile(z90, 1);
  const Eigen::Index top = row + 21 - canvas.height / 2;  // map row of canvas row 0
  const Eigen::Index left = col + 9 - canvas.width / 2;
  int compared = 0;
  float worst = 0.0F;
  for (Eigen::Index r = 0; r < canvas.height; ++r)
    for (Eigen::Index k = 0; k < canvas.width; ++k) {
      // Inside the turned footprint (42 px across, 18 px down at +90 deg)?
      const Eigen::Index dx = k - canvas.width / 2;
      const Eigen::Index dy = r - canvas.height / 2;
      if (dx < -21 || dx >= 21 || dy < -9 || dy >= 9) continue;
      worst = std::max(worst, std::abs(back(r, k) - map64()(top + r, left + k)));
      ++compared;
    }
  CHECK(compared == 42 * 18);
  CHECK(worst < 1e-5F);
}

TEST_CASE(
    "rotated likelihood: rotated_tactile at any heading is the bilinear turn, edges clamped") {
  // Headings off the quarter turns (sub-pixel bilinear weights in both directions, clamped
  // samples beyond the footprint): against pose_test::sample, written out independently.
  const auto& model = model64(36);
  const auto g = grid64(36);
  const tacmap::pixel_size canvas = model.canvas_size();
  const tacmap::image<float> z = pose_test::textured_map(42, 18, 91);
  for (const Eigen::Index layer : {1, 4, 7, 13, 22, 30}) {
    CAPTURE(layer);
    const double theta = g.heading(layer);
    const double c = std::cos(theta);
    const double s = std::sin(theta);
    const auto got = model.rotated_tactile(z, layer);
    float worst = 0.0F;
    for (Eigen::Index r = 0; r < canvas.height; ++r)
      for (Eigen::Index k = 0; k < canvas.width; ++k) {
        const double x = static_cast<double>(k) + 0.5 - 0.5 * static_cast<double>(canvas.width);
        const double y = static_cast<double>(r) + 0.5 - 0.5 * static_cast<double>(canvas.height);
        // Canvas offset (x, y) shows the sensor-frame offset R(-theta) (x, y).
        const float want = pose_test::sample(z, c * x + s * y + 9.0, -s * x + c * y + 21.0);
        worst = std::max(worst, std::abs(got(r, k) - want));
      }
    CHECK(worst < 1e-5F);
  }
}

TEST_CASE("rotated likelihood: distances equal eq. (1) computed from the definition") {
  const auto& model = model64(4);
  const auto g = grid64(4);
  REQUIRE(model.patches_per_window() == 3);
  const tacmap::pixel_size canvas = model.canvas_size();
  const auto z = pose_test::render_state(map64(), g, g.index(1, {8, 21}));
  Eigen::ArrayXf d(g.size());
  model.distances(g, z, d);
  Eigen::ArrayXf ll(g.size());
  model.log_likelihood(g, z, ll);
  for (int q = 0; q < 4; ++q) {
    CAPTURE(q);
    const Eigen::ArrayXf want = reference_distances(z, q, canvas);
    const Eigen::ArrayXf got = d.segment(q * g.layer_size(), g.layer_size());
    // Finite everywhere, and the same numbers (describe_at vs compute: equal within 1e-5).
    CHECK(got.isFinite().all());
    CHECK(want.isFinite().all());
    float worst = 0.0F;
    for (Eigen::Index i = 0; i < got.size(); ++i)
      if (std::isfinite(want(i)))
        worst = std::max(worst, std::abs(got(i) - want(i)) / (1.0F + want(i)));
    CHECK(worst < 1e-4F);
    // Patch offsets: R(theta) c_m, rounded, relative to the window's top-left cell.
    const double c = q == 0 ? 1.0 : q == 2 ? -1.0 : 0.0;
    const double s = q == 1 ? 1.0 : q == 3 ? -1.0 : 0.0;
    for (Eigen::Index m = 0; m < 3; ++m) {
      const auto [cx, cy] = patch_centre(m);
      const auto o = model.patch_offset(q, m);
      CHECK(o.row == std::lround(12.0 + s * cx + c * cy));
      CHECK(o.col == std::lround(c * cx - s * cy));
    }
    // The default likelihood: exponential, log p = -d / tau (tau = 0.15, calibrated), finite
    // everywhere.
    REQUIRE(model.params().tau == 0.15);
    const Eigen::ArrayXf lq = ll.segment(q * g.layer_size(), g.layer_size());
    CHECK(lq.isFinite().all());
    CHECK(((lq + got / 0.15F).abs() < 1e-5F * (1.0F + got.abs())).all());
  }
  // +90 deg: the patches reach 12 px right (patch 0) and 6 px left (patch 2) of the centre, so
  // windows at cols < 6 or > 34 have a patch off the map: still finite (that patch counts its
  // mean), so edge poses are neither favoured nor ruled out.
  const auto layer90 = ll.segment(g.layer_size(), g.layer_size());
  CHECK(layer90.isFinite().all());
  CHECK(ll.segment(0, g.layer_size()).isFinite().all());
}

TEST_CASE("rotated likelihood: all pairs, the inverse shape and tempering") {
  const auto g = grid64(4);
  const tacmap::image<float> z = pose_test::render_state(map64(), g, g.index(3, {15, 30}));
  const rotated_descriptor_likelihood<sift_lite> all(sift_lite{}, map64(), g,
                                                     {.pairs = tacmap::pairing::all_pairs,
                                                      .shape = tacmap::likelihood_shape::inverse,
                                                      .epsilon = 0.01,
                                                      .tempering = 0.5,
                                                      .off_map_exact_positions = 1 << 20});
  const tacmap::pixel_size canvas = all.canvas_size();
  Eigen::ArrayXf ll(g.size());
  all.log_likelihood(g, z, ll);
  for (int q = 0; q < 4; ++q) {
    CAPTURE(q);
    const Eigen::ArrayXf d = reference_distances(z, q, canvas, tacmap::pairing::all_pairs);
    const Eigen::ArrayXf lq = ll.segment(q * g.layer_size(), g.layer_size());
    CHECK((lq.isInf() == d.isInf()).all());
    float worst = 0.0F;
    for (Eigen::Index i = 0; i < d.size(); ++i)
      if (std::isfinite(d(i)))
        worst = std::max(worst, std::abs(lq(i) + 0.5F * std::log(d(i) + 0.01F)));
    CHECK(worst < 1e-4F);
  }
  // Tempering 0: a flat likelihood.
  const rotated_descriptor_likelihood<sift_lite> flat(sift_lite{}, map64(), g, {.tempering = 0.0});
  Eigen::ArrayXf lf(g.size());
  flat.log_likelihood(g, z, lf);
  CHECK((lf == 0.0F).all());
}

TEST_CASE("rotated likelihood: a cut at heading 0 ranks its own pose at the very top") {
  const auto& model = model64(36);
  const auto g = grid64(36);
  Eigen::ArrayXf ll(g.size());
  // Measured (textured_map seed 5): ranks 0, 4, 0 of 38,916 poses. A floor of 20 (0.05 %).
  for (const tacmap::grid_cell cell :
       {tacmap::grid_cell{4, 6}, tacmap::grid_cell{12, 27}, tacmap::grid_cell{20, 41}}) {
    const Eigen::Index truth = g.index(0, cell);
    model.log_likelihood(g, pose_test::render_state(map64(), g, truth), ll);
    CHECK(ll.segment(0, g.layer_size()).isFinite().all());
    const Eigen::Index rank = pose_test::rank_of(ll, truth);
    INFO("heading 0 at (", cell.row, ", ", cell.col, "): rank ", rank);
    CHECK(rank <= 20);
  }
}

TEST_CASE("rotated likelihood: a touch at +90 deg ranks its pose near the top, above -90 deg") {
  const auto& model = model64(36);
  const auto g = grid64(36);
  REQUIRE(g.layer_of(std::numbers::pi / 2) == 9);
  Eigen::ArrayXf ll(g.size());
  for (const tacmap::grid_cell cell :
       {tacmap::grid_cell{3, 14}, tacmap::grid_cell{11, 26}, tacmap::grid_cell{19, 32}}) {
    // Rendered from the map at +90 deg (columns of the array along the map's +y).
    const Eigen::Index truth = g.index(9, cell);
    const Eigen::Index mirror = g.index(27, cell);  // the same place at -90 deg
    model.log_likelihood(g, pose_test::render_state(map64(), g, truth), ll);
    const Eigen::Index rank = pose_test::rank_of(ll, truth);
    const Eigen::Index mirror_rank = pose_test::rank_of(ll, mirror);
    INFO("+90 deg at (", cell.row, ", ", cell.col, "): rank ", rank, ", -90 deg rank ", mirror_rank,
         ", log-likelihoods ", ll(truth), " vs ", ll(mirror));
    // Measured: ranks 30, 7, 0 of 38,916; the mirrored heading ranks 2,227 and worse, its
    // log-likelihood 0.85 to 1.8 below.
    CHECK(rank <= 40);
    CHECK(ll(truth) > ll(mirror) + 0.5F);
    CHECK(mirror_rank > 400);
    // Near the map's left and right edges a turned patch leaves the map: finite, not ruled out.
    CHECK(std::isfinite(ll(g.index(9, {cell.row, 0}))));
    CHECK(std::isfinite(ll(g.index(9, {cell.row, 46}))));
  }
}

TEST_CASE("rotated likelihood: with one heading it ranks positions as the shared-dense model") {
  const auto g = grid64(1);
  const auto& planar = g.positions();
  const rotated_descriptor_likelihood<sift_lite> rotated(sift_lite{}, map64(), g);
  const tacmap::descriptor_likelihood<sift_lite> shared(
      sift_lite{}, map64(), planar.window_size(),
      {.features = tacmap::window_features::shared_dense});
  Eigen::ArrayXf a(g.size());
  Eigen::ArrayXf b(planar.size());
  int same = 0;
  int exact_rotated = 0;
  int exact_shared = 0;
  int tried = 0;
  Eigen::Index spread = 0;
  double worst_correlation = 1.0;
  for (Eigen::Index row = 1; row < g.rows(); row += 7)
    for (Eigen::Index col = 2; col < g.cols(); col += 9) {
      const auto z = tacmap::image<float>(map64().block(row, col, 42, 18));  // noiseless cut
      rotated.distances(g, z, a);
      shared.distances(planar, z, b);
      Eigen::Index ia = 0;
      Eigen::Index ib = 0;
      a.minCoeff(&ia);
      b.minCoeff(&ib);
      const auto ca = g.cell(ia);
      const auto cb = planar.cell(ib);
      const Eigen::Index off = std::max({std::abs(ca.row - cb.row), std::abs(ca.col - cb.col),
                                         std::abs(ca.row - row), std::abs(ca.col - col)});
      spread = std::max(spread, off);
      same += ia == ib ? 1 : 0;
      exact_rotated += ca == tacmap::grid_cell{row, col} ? 1 : 0;
      exact_shared += cb == tacmap::grid_cell{row, col} ? 1 : 0;
      ++tried;
      const Eigen::ArrayXd x = a.cast<double>() - a.cast<double>().mean();
      const Eigen::ArrayXd y = b.cast<double>() - b.cast<double>().mean();
      worst_correlation =
          std::min(worst_correlation, (x * y).sum() / std::sqrt((x * x).sum() * (y * y).sum()));
    }
  INFO("one heading vs shared_dense: same argmin in ", same, " of ", tried, ", exact: rotated ",
       exact_rotated, " shared ", exact_shared, ", largest offset ", spread,
       " px, lowest correlation ", worst_correlation);
  // Not the same numbers: the shared model describes the tactile image itself (zero beyond
  // its borders), the rotated one its canvas (edge pixels repeated), and SIFT-lite's bins reach
  // 7 px beyond a patch. Measured on these 20 cuts: the same best window in 15, the true window
  // best in 10 (rotated) and 8 (shared), the two best windows and the truth never more than
  // 2 px apart, distance maps correlated at 0.91 or more.
  CHECK(spread <= 2);
  CHECK(2 * same >= tried);
  CHECK(worst_correlation > 0.85);
}

namespace {
// SIFT-lite without the Euclidean opt-in: the model then calls distance() once per pair (a
// user's own distance) instead of the vectorised kernel.
struct sift_lite_generic : sift_lite {
  static constexpr bool euclidean_distance = false;
};
}  // namespace
static_assert(!tacmap::euclidean_descriptor<sift_lite_generic>);
static_assert(tacmap::euclidean_descriptor<sift_lite>);

TEST_CASE("rotated likelihood: a user's distance gives what the vectorised kernel gives") {
  // Both pairings, 5 headings (3-descriptor blocks that straddle patches and headings), a pose
  // near the edge (patches off the map at some headings).
  const auto g = grid64(5);
  const auto z = pose_test::render_state(map64(), g, g.index(2, {3, 40}));
  for (const auto pairs : {tacmap::pairing::aligned, tacmap::pairing::all_pairs}) {
    CAPTURE(static_cast<int>(pairs));
    // (A user's distance takes the exact off-map means: so does this one.)
    const rotated_descriptor_likelihood<sift_lite> fast(
        sift_lite{}, map64(), g, {.pairs = pairs, .off_map_exact_positions = 1 << 20});
    const rotated_descriptor_likelihood<sift_lite_generic> generic(sift_lite_generic{}, map64(), g,
                                                                   {.pairs = pairs});
    Eigen::ArrayXf a(g.size());
    Eigen::ArrayXf b(g.size());
    fast.distances(g, z, a);
    generic.distances(g, z, b);
    CHECK(a.isFinite().all());
    CHECK(((a - b).abs() <= 1e-4F * (1.0F + b.abs())).all());
    // Twice in a row (the workspaces are reused): the same numbers.
    Eigen::ArrayXf again(g.size());
    fast.distances(g, z, again);
    CHECK((again == a).all());
  }
}

TEST_CASE("rotated likelihood: bad input is rejected with a clear message") {
  const auto& model = model64(4);
  const auto g = grid64(4);
  Eigen::ArrayXf ll(g.size());
  for (const auto& [rows, cols] :
       {std::pair<Eigen::Index, Eigen::Index>{41, 18}, {42, 17}, {18, 42}}) {
    const tacmap::image<float> z = tacmap::image<float>::Constant(rows, cols, 0.5F);
    const std::string m = message_of([&] { model.log_likelihood(g, z, ll); });
    CAPTURE(m);
    CHECK(m.find("rotated_descriptor_likelihood: tactile image is " + std::to_string(rows) + " x " +
                 std::to_string(cols) + " px (rows x cols); expected 42 x 18") !=
          std::string::npos);
    CHECK(message_of([&] { (void)model.rotated_tactile(z, 0); }) == m);
  }
  {
    tacmap::image<float> z = map64().block(0, 0, 42, 18);
    z(5, 7) = std::numeric_limits<float>::quiet_NaN();
    const std::string m = message_of([&] { model.log_likelihood(g, z, ll); });
    CAPTURE(m);
    CHECK(m.find("the tactile image contains NaN or infinite pixels") != std::string::npos);
  }
  const tacmap::image<float> z = map64().block(0, 0, 42, 18);
  {  // A grid with other headings, or another map: caught before any work.
    const auto other = grid64(36);
    Eigen::ArrayXf out(other.size());
    const std::string m = message_of([&] { model.log_likelihood(other, z, out); });
    CAPTURE(m);
    CHECK(m.find("the grid has " + std::to_string(other.size()) + " states (23 x 47 per layer)") !=
          std::string::npos);
    CHECK(m.find("4 headings give " + std::to_string(4 * 23 * 47)) != std::string::npos);
    const tacmap::pose_grid<float> bigger(
        tacmap::planar_grid<float>({.width = 80, .height = 64}, 3.4 / 3.0,
                                   {.width = 18, .height = 42}),
        4);
    Eigen::ArrayXf out2(bigger.size());
    const std::string m2 = message_of([&] { model.log_likelihood(bigger, z, out2); });
    CAPTURE(m2);
    CHECK(m2.find("(23 x 63 per layer)") != std::string::npos);
    CHECK(m2.find("build the pose grid and the model from the same map") != std::string::npos);
  }
  {  // Construction.
    const std::string m = message_of([] {
      (void)rotated_descriptor_likelihood<sift_lite>(sift_lite{}, map64(),
                                                     {.width = 18, .height = 42}, 0);
    });
    CAPTURE(m);
    CHECK(m.find("angle_count = 0") != std::string::npos);
    tacmap::image<float> bad = map64();
    bad(3, 3) = std::numeric_limits<float>::infinity();
    CHECK(message_of([&] {
            (void)rotated_descriptor_likelihood<sift_lite>(sift_lite{}, bad,
                                                           {.width = 18, .height = 42}, 4);
          }).find("the map contains NaN or infinite pixels") != std::string::npos);
    CHECK(message_of([] {
            (void)rotated_descriptor_likelihood<sift_lite>(sift_lite{}, map64(),
                                                           {.width = 18, .height = 70}, 4);
          }).find("expected a positive window no larger than the map") != std::string::npos);
    CHECK(message_of([] {
            (void)rotated_descriptor_likelihood<sift_lite>(sift_lite{}, map64(),
                                                           {.width = 12, .height = 42}, 4);
          }).find("a descriptor patch of 18 px does not fit") != std::string::npos);
    CHECK(message_of([] {
            (void)rotated_descriptor_likelihood<sift_lite>(
                sift_lite{}, map64(), {.width = 18, .height = 42}, 4, {.spacing = 0});
          }).find("spacing = 0") != std::string::npos);
  }
}

TEST_CASE(
    "rotated likelihood: a map whose field cannot fit in memory is refused before allocating") {
  // 8000 x 8000 px (256 MB as floats): classic SIFT's dense field and its tiled copy would take
  // 2 x 64 million x 128 floats, about 65 GB, whatever the number of headings.
  const tacmap::image<float> map = tacmap::image<float>::Constant(8000, 8000, 0.5F);
  const tacmap::pixel_size window{.width = 18, .height = 42};
  const std::uint64_t field = (8000ULL - 42 + 1) * (8000ULL - 42 + 1);  // at least (patch <= 42)
  const std::uint64_t needed = 2 * field * 128 * sizeof(float);
  const auto available = tacmap::available_memory_bytes();
  if (!available || *available >= needed) return;  // a machine that could hold it
  try {
    const tacmap::rotated_descriptor_likelihood<tacmap::classic_sift> model({}, map, window, 36);
    FAIL("expected insufficient_memory");
  } catch (const tacmap::insufficient_memory& e) {
    CHECK(e.needed_bytes >= needed);
    CHECK(e.available_bytes < e.needed_bytes);
    const std::string m = e.what();
    CHECK(m.find("rotated_descriptor_likelihood") != std::string::npos);
    CHECK(m.find("dense descriptors") != std::string::npos);
    CHECK(m.find("GB") != std::string::npos);
    CHECK(m.find("coarser map") != std::string::npos);
  }
}

}  // namespace test_rotated_descriptor_likelihood
