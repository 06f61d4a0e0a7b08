#include <doctest/doctest.h>

#include <stdexcept>
#include <string>

#include "tacmap/grid/planar_grid.hpp"
#include "test_support.hpp"

namespace test_planar_grid {

using tacmap::grid_cell;
using tacmap::planar_grid;

TEST_CASE("the paper's grid has 79 x 103 = 8,137 states") {
  const auto g = planar_grid<float>::paper();
  CHECK(g.rows() == 79);
  CHECK(g.cols() == 103);
  CHECK(g.size() == 8137);
  CHECK(g.mm_per_px() == doctest::Approx(3.4 / 3.0));
}

TEST_CASE("index, cell, pixel and millimetre conversions agree") {
  const planar_grid<double> g({.width = 50, .height = 40}, 0.5, {.width = 6, .height = 10});
  REQUIRE(g.rows() == 31);
  REQUIRE(g.cols() == 45);
  for (Eigen::Index i = 0; i < g.size(); i += 7) {
    const grid_cell c = g.cell(i);
    CHECK(g.index(c) == i);
    CHECK(g.top_left_px(i) == c);
    const auto px = g.centre_px(i);
    // The state is the window's centre: top-left + half the window.
    CHECK(px.x() == doctest::Approx(static_cast<double>(c.col) + 3.0));
    CHECK(px.y() == doctest::Approx(static_cast<double>(c.row) + 5.0));
    const auto mm = g.state_mm(i);
    CHECK(mm.x() == doctest::Approx(0.5 * px.x()));
    CHECK(mm.y() == doctest::Approx(0.5 * px.y()));
    const auto back = g.nearest_state(mm.x(), mm.y());
    REQUIRE(back.has_value());
    CHECK(*back == i);
  }
  // A point a little off a state's centre still maps to it; far outside maps to nothing.
  const auto mm = g.state_mm(g.index({3, 4}));
  CHECK(g.nearest_state(mm.x() + 0.2, mm.y() - 0.2) == g.index({3, 4}));
  CHECK_FALSE(g.nearest_state(-10.0, 5.0).has_value());
  CHECK_FALSE(g.nearest_state(mm.x(), 1e9).has_value());
  CHECK_FALSE(g.nearest_state(std::nan(""), 1.0).has_value());
  CHECK(g.mm_to_px(g.px_to_mm(3.25)) == doctest::Approx(3.25));
}

TEST_CASE("a map exactly the window's size has one state") {
  const planar_grid<float> g({.width = 18, .height = 42}, 1.0, {.width = 18, .height = 42});
  CHECK(g.size() == 1);
  CHECK(g.state_mm(0).x() == doctest::Approx(9.0));
  CHECK(g.state_mm(0).y() == doctest::Approx(21.0));
}

using tacmap_test::message_of;

TEST_CASE("bad grid configurations are rejected with messages naming the value") {
  const auto small = message_of(
      [] { planar_grid<float>({.width = 10, .height = 120}, 1.0, {.width = 18, .height = 42}); });
  CHECK(small.find("10 x 120") != std::string::npos);
  CHECK(small.find("smaller than the sensor window 18 x 42") != std::string::npos);

  const auto scale = message_of(
      [] { planar_grid<float>({.width = 120, .height = 120}, -2.0, {.width = 18, .height = 42}); });
  CHECK(scale.find("mm_per_px = -2") != std::string::npos);
  CHECK(scale.find("expected a finite scale > 0") != std::string::npos);

  CHECK(message_of([] {
          planar_grid<float>({.width = 120, .height = 120}, std::nan(""),
                             {.width = 18, .height = 42});
        }).find("mm_per_px = nan") != std::string::npos);
  CHECK(message_of([] {
          planar_grid<float>({.width = 120, .height = 120}, 1.0, {.width = 0, .height = 42});
        }).find("window = 0 x 42") != std::string::npos);
}

}  // namespace test_planar_grid
