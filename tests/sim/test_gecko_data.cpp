// The bundled gecko data: the committed files are what the generator makes, the protocol is the
// paper's (7 locations, 22 distinct orders), and simulated touches look like the map.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <vector>

#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/sim/gecko.hpp"
#include "tacmap/sim/protocol.hpp"
#include "tacmap/sim/tactile_simulator.hpp"
#include "tacmap/tactile/preprocess.hpp"

namespace test_gecko_data {

namespace {

const std::filesystem::path gecko_dir = std::filesystem::path(TACMAP_DATA_DIR) / "gecko";

std::string file_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  REQUIRE_MESSAGE(in.good(), "cannot open ", path.string());
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

const tacmap::touch_protocol& bundled() {
  static const tacmap::touch_protocol p = tacmap::load_protocol(gecko_dir / "protocol.txt");
  return p;
}

// Normalised cross-correlation of two equally sized images.
double ncc(const tacmap::image<float>& a, const tacmap::image<float>& b) {
  const Eigen::ArrayXXd x = a.cast<double>() - a.cast<double>().mean();
  const Eigen::ArrayXXd y = b.cast<double>() - b.cast<double>().mean();
  return (x * y).sum() / std::sqrt((x * x).sum() * (y * y).sum());
}

// The relief window under a sensor centred at `loc` (theta = 0), as planar_grid cuts it.
tacmap::image<float> window_at(const tacmap::image<float>& relief,
                               const tacmap::touch_location& loc) {
  const auto grid = tacmap::planar_grid<float>::paper();
  const auto state = grid.nearest_state(loc.x_mm, loc.y_mm);
  REQUIRE(state.has_value());
  const auto cell = grid.top_left_px(*state);
  return relief.block(cell.row, cell.col, 42, 18);
}

}  // namespace

TEST_CASE("the committed data/gecko files equal what the generator produces") {
  const auto files = tacmap::gecko_data_files();
  REQUIRE(files.size() == 4);
  for (const auto& f : files) {
    CAPTURE(f.name);
    const std::string committed = file_bytes(gecko_dir / f.name);
    // On a mismatch, regenerate: tools/generate_gecko_data data/gecko
    CHECK(committed.size() == f.bytes.size());
    CHECK(committed == f.bytes);
  }
}

TEST_CASE("the gecko map: 120 x 120 px, two levels with anti-aliased edges, asymmetric") {
  const auto& p = bundled();
  const tacmap::image<float> made = tacmap::make_gecko_map();
  CHECK(p.map.rows() == 120);
  CHECK(p.map.cols() == 120);
  CHECK((p.map == made).all());  // the PGM stores the generator's 8-bit levels exactly
  CHECK(p.map.minCoeff() == doctest::Approx(0.1).epsilon(0.01));
  CHECK(p.map.maxCoeff() == doctest::Approx(0.9).epsilon(0.01));
  const tacmap::image<float> relief = p.relief_mm();
  const double area = (relief > 0.0F).cast<double>().mean();
  CHECK(area > 0.15);                               // a substantial object...
  CHECK(area < 0.5);                                // ...on a visible base
  CHECK((relief == 0.0F || relief == 4.0F).all());  // the paper's binary 4 mm protrusion
  // No mirror symmetry: the walking pose and the curled tail break both axes.
  CHECK(ncc(relief, relief.rowwise().reverse()) < 0.6);
  CHECK(ncc(relief, relief.colwise().reverse()) < 0.6);
}

TEST_CASE("the protocol: 7 locations on the gecko, 22 distinct orders visiting all of them") {
  const auto& p = bundled();
  CHECK(p.mm_per_px == 3.4 / 3.0);
  CHECK(p.relief.kind == tacmap::relief_kind::binary);
  CHECK(p.relief.height_mm == 4.0);
  CHECK(p.readings_per_location == 20);
  CHECK(p.odometry_sigma_mm == 0.5);
  REQUIRE(p.locations.size() == 7);
  REQUIRE(p.sequences.size() == 22);
  const auto grid = tacmap::planar_grid<float>::paper();
  const tacmap::image<float> relief = p.relief_mm();
  for (const auto& loc : p.locations) {
    CAPTURE(loc.x_mm);
    CAPTURE(loc.y_mm);
    // Each location is (within rounding) a state of the paper's grid, so it can be scored.
    const auto state = grid.nearest_state(loc.x_mm, loc.y_mm);
    REQUIRE(state.has_value());
    CHECK((grid.state_mm(*state) - Eigen::Vector2d(loc.x_mm, loc.y_mm)).norm() < 1e-3);
    // ...and its window holds both object and base: edges to feel.
    const double covered = (window_at(relief, loc) > 0.0F).cast<double>().mean();
    CHECK(covered > 0.1);
    CHECK(covered < 0.95);
  }
  std::set<std::vector<std::size_t>> orders;
  double sum2 = 0.0;
  int moves = 0;
  for (const auto& seq : p.sequences) {
    REQUIRE(seq.size() == 7);
    std::vector<std::size_t> order;
    for (const auto& step : seq) order.push_back(step.location);
    std::vector<std::size_t> sorted = order;
    std::sort(sorted.begin(), sorted.end());
    CHECK(sorted == std::vector<std::size_t>{0, 1, 2, 3, 4, 5, 6});
    orders.insert(order);
    for (std::size_t k = 1; k < seq.size(); ++k) {
      const double ex = seq[k].measured_motion.dx_mm - seq[k].true_motion.dx_mm;
      const double ey = seq[k].measured_motion.dy_mm - seq[k].true_motion.dy_mm;
      sum2 += ex * ex + ey * ey;
      moves += 2;
    }
  }
  CHECK(orders.size() == 22);
  // The paper's Fig. 5 path first: right to left, bottom to top.
  CHECK(p.sequences[0].front().location == 0);
  CHECK(p.locations[0].y_mm > p.locations[6].y_mm);
  // Measured moves scatter around the true ones with the documented sigma (264 values).
  CHECK(std::sqrt(sum2 / moves) == doctest::Approx(0.5).epsilon(0.15));
}

TEST_CASE("the generator is deterministic and follows its parameters") {
  const auto a = tacmap::make_gecko_protocol({.seed = 99, .sequences = 30});
  const auto b = tacmap::make_gecko_protocol({.seed = 99, .sequences = 30});
  const auto c = tacmap::make_gecko_protocol({.seed = 100, .sequences = 30});
  CHECK(tacmap::format_sequences(a.sequences) == tacmap::format_sequences(b.sequences));
  CHECK(tacmap::format_sequences(a.sequences) != tacmap::format_sequences(c.sequences));
  CHECK(a.sequences.size() == 30);
  const auto exact = tacmap::make_gecko_protocol({.odometry_sigma_mm = 0.0});
  for (const auto& seq : exact.sequences)
    for (const auto& step : seq) {
      CHECK(step.measured_motion.dx_mm == step.true_motion.dx_mm);
      CHECK(step.measured_motion.dy_mm == step.true_motion.dy_mm);
    }
  CHECK_THROWS_AS((void)tacmap::make_gecko_protocol({.sequences = 6000}), std::invalid_argument);
}

TEST_CASE("simulated gecko touches pass preprocessing and look like the map at the true pose") {
  const auto& p = bundled();
  const tacmap::image<float> relief = p.relief_mm();
  tacmap::tactile_simulator sim(relief, p.map_size(), p.mm_per_px, {.seed = 2015});
  std::vector<tacmap::image<float>> windows;
  for (const auto& loc : p.locations) windows.push_back(window_at(relief, loc));
  for (std::size_t k = 0; k < p.locations.size(); ++k) {
    CAPTURE(k);
    for (int reading = 0; reading < 3; ++reading) {
      const auto pre = tacmap::preprocess(sim.render(p.locations[k].pose()));
      REQUIRE_MESSAGE(pre.accepted(), pre.reason());
      REQUIRE(pre.pixels.rows() == 42);
      REQUIRE(pre.pixels.cols() == 18);
      const double own = ncc(pre.pixels, windows[k]);
      CHECK(own > 0.6);
      // ...and it looks more like its own window than like any other location's.
      for (std::size_t other = 0; other < windows.size(); ++other)
        if (other != k) CHECK(ncc(pre.pixels, windows[other]) < own);
    }
  }
}

}  // namespace test_gecko_data
