// next_touch: candidate moves ranked by what the touch after each is expected to decide
// (filter/next_touch.hpp), on a map with a distinctive half and a flat half, on the gecko, and
// over a library of two maps that differ on one half only.
#include <doctest/doctest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "sim/gecko_protocol.hpp"
#include "tacmap/filter/next_touch.hpp"
#include "tacmap/library_localizer.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/sim/calibration.hpp"
#include "tacmap/sim/experiment.hpp"
#include "tacmap/sim/library_experiment.hpp"
#include "tacmap/sim/tactile_simulator.hpp"

namespace test_next_touch {

namespace {

constexpr double scale = 3.4 / 3.0;  // mm per px: the paper's (the 14 x 6 sensor is 42 x 18 px)

// Smooth random texture (blobs of a few px, a fixed seed: splitmix64) in columns
// [0, textured_cols); a constant elsewhere.
tacmap::image<float> half_textured(Eigen::Index rows, Eigen::Index cols, Eigen::Index textured_cols,
                                   std::uint64_t seed) {
  tacmap::image<float> noise(rows, cols);
  std::uint64_t x = seed;
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index c = 0; c < cols; ++c) {
      x += 0x9e3779b97f4a7c15ULL;
      std::uint64_t z = x;
      z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
      z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
      noise(r, c) = static_cast<float>((z ^ (z >> 31)) >> 40) / static_cast<float>(1 << 24);
    }
  tacmap::image<float> map = tacmap::image<float>::Constant(rows, cols, 0.5F);
  for (Eigen::Index r = 2; r + 2 < rows; ++r)
    for (Eigen::Index c = 2; c + 2 < textured_cols; ++c)
      map(r, c) = noise.block(r - 2, c - 2, 5, 5).mean();
  return map;
}

tacmap::localizer_config classic_config() { return {}; }  // the default model (classic_sift)

tacmap::next_touch_params entropy() { return {.objective = tacmap::next_touch_objective::entropy}; }

// The planar grid and model a localizer builds for `map` with the default sensor.
struct planar_setup {
  tacmap::pixel_size window;
  tacmap::planar_grid<float> grid;
  tacmap::configured_measurement model;
  explicit planar_setup(const tacmap::image<float>& map,
                        const tacmap::localizer_config& c = classic_config())
      : window(tacmap::checked_tactile_window({}, scale, {map.cols(), map.rows()}, "test")),
        grid({.width = map.cols(), .height = map.rows()}, scale, window),
        model(c, map, window) {}
  tacmap::next_touch_ranking rank(const tacmap::detail::touch_hypotheses& h,
                                  const std::vector<tacmap::odometry>& moves,
                                  tacmap::next_touch_params p = entropy()) const {
    return tacmap::detail::rank_touches(
        h, std::span<const tacmap::odometry>(moves),
        [&](Eigen::Index) -> const tacmap::planar_grid<float>& { return grid; },
        [&](Eigen::Index) -> const tacmap::configured_measurement& { return model; }, 5.0, p);
  }
};

// Equal-weight hypotheses at `cells` (object 0).
tacmap::detail::touch_hypotheses at_cells(const std::vector<tacmap::grid_cell>& cells,
                                          const std::vector<Eigen::Index>& objects = {}) {
  tacmap::detail::touch_hypotheses h;
  h.cell = cells;
  h.object = objects.empty() ? std::vector<Eigen::Index>(cells.size(), 0) : objects;
  h.weight = Eigen::ArrayXd::Constant(static_cast<Eigen::Index>(cells.size()),
                                      1.0 / static_cast<double>(cells.size()));
  return h;
}

// 12 hypotheses on a lattice inside the flat half (columns >= 110 of a 200-column map whose
// first 100 are textured; the window is 18 px wide).
std::vector<tacmap::grid_cell> flat_cells() {
  std::vector<tacmap::grid_cell> out;
  for (Eigen::Index r = 4; r < 40; r += 12)
    for (Eigen::Index c = 112; c < 176; c += 16) out.push_back({r, c});
  return out;
}

const tacmap::touch_protocol& gecko() { return tacmap_test::gecko(); }

}  // namespace

TEST_CASE("next_touch: a move onto the distinctive half ranks above a move within the flat half") {
  const auto map = half_textured(90, 200, 100, 7);
  const planar_setup s(map);
  const auto h = at_cells(flat_cells());
  // Candidate 0 stays on the flat half; candidate 1 moves every hypothesis 96 px to the left,
  // onto the texture; candidate 2 moves half of them onto it (the lattice spans 64 columns).
  const std::vector<tacmap::odometry> moves{{.dx_mm = 4.0 * scale, .dy_mm = 0.0},
                                            {.dx_mm = -96.0 * scale, .dy_mm = 0.0},
                                            {.dx_mm = -48.0 * scale, .dy_mm = 0.0}};
  const auto r = s.rank(h, moves);
  CAPTURE(r.score[0]);
  CAPTURE(r.score[1]);
  CAPTURE(r.score[2]);
  CHECK_FALSE(r.uninformative);
  CHECK(r.entropy_nats == doctest::Approx(std::log(12.0)));
  CHECK(r.order == std::vector<std::size_t>{1, 2, 0});
  // Flat windows are alike: the touch there tells (almost) nothing; the textured windows are
  // unlike each other: the touch there tells almost everything.
  CHECK(r.score[0] < 0.05);
  CHECK(r.score[1] > 0.9 * std::log(12.0));
  CHECK(r.on_map[0] == doctest::Approx(1.0));
  CHECK(r.best_move().dx_mm == moves[1].dx_mm);

  // The verdict's objective agrees: the expected probability within 5 mm.
  const auto v = s.rank(h, moves, {.objective = tacmap::next_touch_objective::verdict});
  CHECK(v.order.front() == 1);
  CHECK(v.score[1] > 0.9);
  CHECK(v.score[0] < 0.3);

  // NCC ranks the same way.
  tacmap::localizer_config ncc;
  ncc.model = tacmap::measurement_kind::ncc;
  const planar_setup n(map, ncc);
  CHECK(n.rank(h, moves).order.front() == 1);
}

TEST_CASE("next_touch: hypotheses a move carries off the map are left out, or tell nothing") {
  const auto map = half_textured(90, 200, 100, 7);
  const planar_setup s(map);
  // Six hypotheses on the texture; moving 30 px to the right keeps them all on the map, moving
  // left by 40 px takes the three at column 20 off it (half the belief's mass).
  std::vector<tacmap::grid_cell> cells;
  for (const Eigen::Index c : {20, 60})
    for (const Eigen::Index r : {5, 20, 35}) cells.push_back({r, c});
  const auto h = at_cells(cells);
  const std::vector<tacmap::odometry> moves{{.dx_mm = -40.0 * scale}, {.dx_mm = 3.0 * scale}};
  // Given that the touch lands (the default): the three that land, at most log 3 to decide.
  const auto r = s.rank(h, moves);
  CHECK(r.on_map[0] == doctest::Approx(0.5));
  CHECK(r.on_map[1] == doctest::Approx(1.0));
  CHECK(r.score[0] <= std::log(3.0) + 1e-6);
  CHECK(r.score[0] > 0.9 * std::log(3.0));
  CHECK(r.score[1] > 0.9 * std::log(6.0));
  CHECK(r.order.front() == 1);
  // Weighed by landing: half the mass lands, half of that.
  const auto w = s.rank(
      h, moves, {.objective = tacmap::next_touch_objective::entropy, .weigh_by_landing = true});
  CHECK(w.score[0] == doctest::Approx(0.5 * r.score[0]));
  CHECK(w.score[1] == doctest::Approx(r.score[1]));
}

TEST_CASE(
    "next_touch: one hypothesis makes every candidate equally uninformative, in input order") {
  const auto map = half_textured(90, 200, 100, 7);
  const planar_setup s(map);
  const auto h = at_cells({{10, 60}});
  const std::vector<tacmap::odometry> moves{
      {.dx_mm = 5.0}, {.dx_mm = -30.0}, {.dx_mm = 40.0, .dy_mm = 10.0}, {.dy_mm = -3.0}};
  const auto r = s.rank(h, moves);
  CHECK(r.uninformative);
  CHECK(r.entropy_nats == 0.0);
  CHECK(r.order == std::vector<std::size_t>{0, 1, 2, 3});
  for (const double x : r.score) CHECK(x == 0.0);
}

TEST_CASE("next_touch: equal scores keep the input order") {
  const auto map = half_textured(90, 200, 100, 7);
  const planar_setup s(map);
  const auto h = at_cells(flat_cells());
  // The same two moves twice, the informative one second: ties broken by input order.
  const tacmap::odometry flat{.dx_mm = 2.0 * scale}, texture{.dx_mm = -96.0 * scale};
  const std::vector<tacmap::odometry> moves{flat, texture, flat, texture};
  const auto r = s.rank(h, moves);
  REQUIRE(r.score[1] == r.score[3]);
  REQUIRE(r.score[0] == r.score[2]);
  CHECK(r.order == std::vector<std::size_t>{1, 3, 0, 2});
}

TEST_CASE("next_touch: systematic resampling draws the belief's mass, merging equal draws") {
  Eigen::ArrayXd mass = Eigen::ArrayXd::Zero(20);
  mass(3) = 0.5;
  mass(17) = 0.25;
  mass(18) = 0.25;
  const Eigen::Index cols[] = {5};
  const auto h =
      tacmap::detail::sample_hypotheses(std::span<const Eigen::ArrayXd>(&mass, 1), cols, 8);
  REQUIRE(h.cell.size() == 3);
  CHECK(h.cell[0] == tacmap::grid_cell{0, 3});
  CHECK(h.cell[1] == tacmap::grid_cell{3, 2});
  CHECK(h.cell[2] == tacmap::grid_cell{3, 3});
  CHECK(h.weight(0) == doctest::Approx(0.5));
  CHECK(h.weight(1) == doctest::Approx(0.25));
  CHECK(h.weight.sum() == doctest::Approx(1.0));
}

TEST_CASE("localizer::next_touch ranks without changing the belief, and refuses bad candidates") {
  const auto& p = gecko();
  tacmap::localizer loc(p.map, p.mm_per_px);
  auto sim = tacmap::tactile_simulator(p.relief_mm(), p.map_size(), p.mm_per_px, {.seed = 3});
  const auto& seq = p.sequences[0];
  (void)loc.touch(sim.render(p.locations[seq[0].location].pose()));
  const tacmap::image<float> before = loc.belief();
  // The entropy: after this touch the verdict's objective already finds every move as sure.
  const auto r = loc.next_touch(
      tacmap::touch_region{
          .x_min_mm = -20.0, .x_max_mm = 20.0, .y_min_mm = -20.0, .y_max_mm = 20.0, .step_mm = 4.0},
      entropy());
  CHECK(r.candidates.size() == 121);
  CHECK(r.score.size() == 121);
  CHECK(r.order.size() == 121);
  CHECK(r.hypotheses > 1);
  CHECK_FALSE(r.uninformative);
  for (std::size_t i = 1; i < r.order.size(); ++i)
    CHECK(r.score[r.order[i - 1]] >= r.score[r.order[i]]);
  CHECK((loc.belief() == before).all());
  CHECK(loc.touches() == 1);

  const std::vector<tacmap::odometry> none;
  CHECK_THROWS_WITH_AS((void)loc.next_touch(std::span<const tacmap::odometry>(none)),
                       doctest::Contains("no candidate moves"), std::invalid_argument);
  const std::vector<tacmap::odometry> nan{{.dx_mm = 1.0},
                                          {.dx_mm = std::numeric_limits<double>::quiet_NaN()}};
  CHECK_THROWS_WITH_AS((void)loc.next_touch(std::span<const tacmap::odometry>(nan)),
                       doctest::Contains("candidate 1 moves (nan, 0) mm, not finite"),
                       std::invalid_argument);
  const std::vector<tacmap::odometry> far{
      {.dx_mm = 1.0}, {.dx_mm = 2.0}, {.dx_mm = 0.0, .dy_mm = 900.0}};
  CHECK_THROWS_WITH_AS((void)loc.next_touch(std::span<const tacmap::odometry>(far)),
                       doctest::Contains("candidate 2 moves (0, 900) mm, off the map"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS((void)loc.next_touch(tacmap::touch_region{.x_min_mm = 1.0, .x_max_mm = 0.0}),
                       doctest::Contains("min <= max"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(
      (void)loc.next_touch(std::span<const tacmap::odometry>(far).first(1), {.hypotheses = 0}),
      doctest::Contains("hypotheses = 0"), std::invalid_argument);
  CHECK_THROWS_WITH_AS((void)loc.next_touch(std::span<const tacmap::odometry>(far).first(1),
                                            {.likelihood_scale = 1.5}),
                       doctest::Contains("likelihood_scale = 1.5"), std::invalid_argument);
  CHECK((loc.belief() == before).all());
}

TEST_CASE("next_touch with an unknown heading is refused, saying why and what to do") {
  const auto map = half_textured(70, 90, 90, 5);
  tacmap::localizer_config c;
  c.headings = 8;
  tacmap::localizer loc(map, scale, c);
  const std::vector<tacmap::odometry> moves{{.dx_mm = 2.0}};
  CHECK_THROWS_WITH_AS((void)loc.next_touch(std::span<const tacmap::odometry>(moves)),
                       doctest::Contains("headings = 8; ranking moves needs a known heading"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS((void)loc.next_touch(tacmap::touch_region{.x_max_mm = 2.0}),
                       doctest::Contains("choose the moves yourself"), std::invalid_argument);
  tacmap::localization_config active;
  active.order = tacmap::touch_order::active;
  active.headings = 8;
  CHECK_THROWS_WITH_AS(active.validate(),
                       doctest::Contains("order = active ranks moves with a known heading"),
                       std::invalid_argument);
}

TEST_CASE("localizer::next_touch: a concentrated belief leaves little for any move to decide") {
  const auto& p = gecko();
  tacmap::localizer loc(p.map, p.mm_per_px);
  const tacmap::touch_region region{
      .x_min_mm = -15.0, .x_max_mm = 15.0, .y_min_mm = -15.0, .y_max_mm = 15.0, .step_mm = 5.0};
  const auto fresh = loc.next_touch(region, entropy());
  auto sim = tacmap::tactile_simulator(p.relief_mm(), p.map_size(), p.mm_per_px, {.seed = 5});
  const auto& seq = p.sequences[1];
  tacmap::touch_result t;
  for (std::size_t k = 0; k < seq.size(); ++k) {
    const auto frame = sim.render(p.locations[seq[k].location].pose());
    t = k == 0 ? loc.touch(frame) : loc.touch(frame, seq[k].measured_motion);
  }
  REQUIRE(t.verdict == tacmap::verdict::localized);
  const auto settled = loc.next_touch(region, entropy());
  const auto best = [](const tacmap::next_touch_ranking& r) { return r.score[r.best()]; };
  const auto worst = [](const tacmap::next_touch_ranking& r) { return r.score[r.order.back()]; };
  CAPTURE(best(fresh));
  CAPTURE(best(settled));
  // Entropy: what is left open is the sub-radius spread of the mode, and no touch can decide
  // more than that.
  CHECK(fresh.entropy_nats > 3.0);
  CHECK(settled.entropy_nats < 0.5 * fresh.entropy_nats);
  CHECK(best(settled) <= settled.entropy_nats + 1e-9);
  // The verdict's objective: every move keeps the truth within the radius about as surely as
  // the belief already does; from the fresh belief the moves differ.
  const tacmap::next_touch_params verdict{.objective = tacmap::next_touch_objective::verdict};
  const auto v = loc.next_touch(region, verdict);
  CAPTURE(best(v));
  CAPTURE(worst(v));
  CHECK(worst(v) > 0.85);
  CHECK(best(v) - worst(v) < 0.1);
  loc.reset();
  const auto v0 = loc.next_touch(region, verdict);
  CHECK(best(v0) - worst(v0) > best(v) - worst(v));
}

TEST_CASE("next_touch over a library: a move to where the objects differ ranks first") {
  // Two maps, textured differently on the left half, the same flat right half.
  const auto a = half_textured(90, 200, 100, 7);
  const auto b = half_textured(90, 200, 100, 8);
  const planar_setup sa(a), sb(b);
  // The same flat position on both objects: only the object is in doubt.
  const auto h = at_cells({{10, 150}, {10, 150}}, {0, 1});
  const std::vector<tacmap::odometry> moves{{.dx_mm = 3.0 * scale}, {.dx_mm = -100.0 * scale}};
  const auto r = tacmap::detail::rank_touches(
      h, std::span<const tacmap::odometry>(moves),
      [&](Eigen::Index o) -> const tacmap::planar_grid<float>& {
        return o == 0 ? sa.grid : sb.grid;
      },
      [&](Eigen::Index o) -> const tacmap::configured_measurement& {
        return o == 0 ? sa.model : sb.model;
      },
      5.0, entropy());
  CHECK(r.score[0] < 0.01);
  CHECK(r.score[1] > 0.9 * std::log(2.0));
  CHECK(r.order.front() == 1);

  // The front door: ranks over (object, position), belief unchanged.
  tacmap::library_localizer lib({{"a", a, scale}, {"b", b, scale}});
  const auto before = lib.filter().belief();
  const auto lr = lib.next_touch(std::span<const tacmap::odometry>(moves));
  CHECK(lr.score.size() == 2);
  CHECK((lib.filter().belief() == before).all());
  const std::vector<tacmap::odometry> far{{.dx_mm = 500.0}};
  CHECK_THROWS_WITH_AS((void)lib.next_touch(std::span<const tacmap::odometry>(far)),
                       doctest::Contains("candidate 0 moves (500, 0) mm, off the map"),
                       std::invalid_argument);
}

TEST_CASE("the active touch order: chosen touches, reproducible, their states recorded") {
  const auto& p = gecko();
  tacmap::localization_config c;
  c.order = tacmap::touch_order::active;
  c.active_candidates = 8;
  tacmap::localization_experiment active(p, c);
  const auto a = active.run(2);
  const auto b = active.run(2);
  tacmap::localization_config r = c;
  r.order = tacmap::touch_order::protocol;
  tacmap::localization_experiment random(p, r);
  const auto q = random.run(2);
  REQUIRE(a.touches.size() == p.sequences[2].size());
  // The first touch is the protocol's; the others are chosen, the same each run.
  CHECK(a.touches[0].true_x_mm == q.touches[0].true_x_mm);
  CHECK(a.touches[0].true_y_mm == q.touches[0].true_y_mm);
  std::size_t elsewhere = 0;
  for (std::size_t k = 0; k < a.touches.size(); ++k) {
    CHECK(a.touches[k].true_x_mm == b.touches[k].true_x_mm);
    CHECK(a.touches[k].true_y_mm == b.touches[k].true_y_mm);
    CHECK(a.touches[k].error_mm == b.touches[k].error_mm);
    if (a.touches[k].true_x_mm != q.touches[k].true_x_mm) ++elsewhere;
  }
  CHECK(elsewhere >= a.touches.size() - 2);
  // The chosen touch's map state is its location (the first: the protocol's location index).
  CHECK(a.touches[0].location == q.touches[0].location);
  const auto& grid = active.filter().grid().base();
  for (std::size_t k = 1; k < a.touches.size(); ++k) {
    const auto at = grid.state_mm(static_cast<Eigen::Index>(a.touches[k].location));
    CHECK(at(0) == doctest::Approx(a.touches[k].true_x_mm));
    CHECK(at(1) == doctest::Approx(a.touches[k].true_y_mm));
  }
  tacmap::localization_config none = c;
  none.active_candidates = 0;
  CHECK_THROWS_WITH_AS(tacmap::localization_experiment(p, none),
                       doctest::Contains("active_candidates = 0"), std::invalid_argument);
}

TEST_CASE("the active touch order with faults: each chosen move goes through them") {
  const auto& p = gecko();
  tacmap::localization_config c;
  c.order = tacmap::touch_order::active;
  c.active_candidates = 8;
  c.faults.outlier_probability = 1.0;  // every move reported 8 mm off
  c.faults.slip_touch = 4;
  c.faults.slip_mm = 20.0;
  tacmap::localization_experiment e(p, c);
  const auto r = e.run(1);
  REQUIRE(r.touches.size() == p.sequences[1].size());
  const auto& grid = e.filter().grid().base();
  for (std::size_t k = 1; k < r.touches.size(); ++k) {
    const auto& t = r.touches[k];
    CHECK(t.odometry_outlier);
    CHECK(t.moved_unseen == (k == 3));
    // Where the arm went: the chosen state, then the slip (the object moved 20 mm under it).
    const auto target = grid.state_mm(static_cast<Eigen::Index>(t.location));
    const double unseen = std::hypot(t.true_x_mm - target(0), t.true_y_mm - target(1));
    CHECK(unseen == doctest::Approx(k == 3 ? 20.0 : 0.0).epsilon(1e-9));
    // What the filter is told: the arm's move, off by the outlier (8 mm) and the noise.
    const auto& before = r.touches[k - 1];
    const double off = std::hypot(t.reported_dx_mm - (target(0) - before.true_x_mm),
                                  t.reported_dy_mm - (target(1) - before.true_y_mm));
    CHECK(off > 8.0 - 4.0 * p.odometry_sigma_mm - 1e-9);
    CHECK(off < 8.0 + 4.0 * p.odometry_sigma_mm + 1e-9);
  }
  // Faults of the same sequence are drawn the same way each run.
  const auto again = e.run(1);
  for (std::size_t k = 0; k < r.touches.size(); ++k)
    CHECK(again.touches[k].true_x_mm == r.touches[k].true_x_mm);
  // Both orders of a sequence meet the same odometry errors (noise and outlier), pairwise.
  tacmap::localization_config protocol_order = c;
  protocol_order.order = tacmap::touch_order::protocol;
  tacmap::localization_experiment pe(p, protocol_order);
  const auto q = pe.run(1);
  for (std::size_t k = 1; k < r.touches.size(); ++k) {
    if (k == 3) continue;  // the slip: the true move is not the arm's
    const auto error = [](const tacmap::touch_record& now, const tacmap::touch_record& before) {
      return std::array<double, 2>{now.reported_dx_mm - (now.true_x_mm - before.true_x_mm),
                                   now.reported_dy_mm - (now.true_y_mm - before.true_y_mm)};
    };
    const auto ea = error(r.touches[k], r.touches[k - 1]);
    const auto ep = error(q.touches[k], q.touches[k - 1]);
    CHECK(ea[0] == doctest::Approx(ep[0]));
    CHECK(ea[1] == doctest::Approx(ep[1]));
  }
}

TEST_CASE("library_experiment, active order: the library filter chooses where the objects differ") {
  // Two objects alike but for the columns [0, 40) of 160: after a touch elsewhere the position
  // may be known on both, the object is not. The library filter's next_touch goes where they
  // differ; a filter of one object (what chose without the hooks) has no reason to.
  const auto a = half_textured(90, 160, 160, 7);
  auto b = a;
  b.leftCols(40) = half_textured(90, 40, 40, 8);
  const auto pa = tacmap::photo_touch_protocol(a, scale, 11, 5);
  const auto pb = tacmap::photo_touch_protocol(b, scale, 12, 5);
  tacmap::localization_config c;
  c.order = tacmap::touch_order::active;
  c.active_candidates = 16;
  tacmap::library_experiment e({{"a", &pa}, {"b", &pb}}, c);
  const double differ_mm = (40.0 + 9.0) * scale;  // a window centred left of this sees them
  std::size_t first_elsewhere = 0, chose_differ = 0;
  for (std::size_t q = 0; q < 6; ++q) {
    const auto r = e.run(q % 2, q);
    REQUIRE(r.touches.size() == 5);
    REQUIRE(r.known_object.size() == 5);
    for (std::size_t t = 0; t < r.touches.size(); ++t) {  // the same touches for both filters
      CHECK(r.touches[t].true_x_mm == r.known_object[t].true_x_mm);
      CHECK(r.touches[t].true_y_mm == r.known_object[t].true_y_mm);
    }
    if (r.touches[0].true_x_mm < differ_mm) continue;  // the first touch told them apart
    ++first_elsewhere;
    chose_differ += r.touches[1].true_x_mm < differ_mm ? 1U : 0U;
    CHECK(r.recognized_at(3));
  }
  REQUIRE(first_elsewhere >= 3);
  // A random candidate is there with probability about 1/3.
  CHECK(chose_differ == first_elsewhere);
}

}  // namespace test_next_touch
