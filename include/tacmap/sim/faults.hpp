// tacmap: what goes wrong during exploration — faults the simulator can inject into a sequence.
//
// The scenario (sim/scenario.hpp) describes how the world differs from the map; these describe
// how the exploration differs from what the filter is told:
//  * odometry outliers: with a given probability a move's reported displacement is off by a
//    given distance in a random direction (the arm hit something, the position source dropped
//    a sample);
//  * odometry noise larger than the filter is configured for: the reported displacement is the
//    true one plus N(0, sigma^2) per axis with the given sigma (a user rarely knows the figure);
//  * a slip: from a given touch on, the object lies a given distance away from where it was (in
//    a random direction that keeps the remaining touches on the map) and stays there; the arm's
//    odometry does not see it, so every later touch is offset on the map;
//  * a kidnap: at a given touch the sensor is put down somewhere else on the object (uniformly,
//    keeping the remaining touches on the map) and the filter gets the usual odometry.
// Every draw comes from the sequence's own fault stream, so turning one fault on does not change
// the others' draws or the scenario's.
#pragma once

#include <cmath>
#include <cstddef>
#include <numbers>
#include <optional>
#include <vector>

#include "tacmap/config.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/image.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"
#include "tacmap/sim/protocol.hpp"
#include "tacmap/sim/random.hpp"

namespace tacmap {

/// What the filter is told about the faults: a ceiling for evaluations, not a method (a robot
/// is never told). The experiment applies it after the filter's own prediction, on top of the
/// filter's motion model (its floor and wide component included: turn them off in the
/// configuration to measure the oracle alone); "ring(b, d)" moves every state's mass by d mm in
/// every direction equally.
enum class fault_oracle {
  none,  ///< nothing: the filter's own motion model alone
  /// The outliers' true transition: after every move the belief b becomes
  /// (1 - outlier_probability) b + outlier_probability ring(b, outlier_mm) — with a base model
  /// of the true noise and no wide component, what the best motion model for this fault does.
  /// Needs outliers.
  transition,
  /// When a fault happens and its size, not its direction: after each outlier move the belief
  /// becomes ring(b, outlier_mm), at the slip's touch (when the slip happened)
  /// ring(b, slip_mm); after the other moves only the filter's own prediction applies. Needs
  /// outliers or a slip.
  told,
};

/// Faults injected into a sequence's exploration (see the file's comment). Defaults: none.
struct exploration_faults {
  double outlier_probability = 0.0;  ///< per move, of an odometry outlier
  double outlier_mm = 8.0;           ///< an outlier's error, mm
  /// The true odometry noise per axis, mm (empty: the protocol's own measured odometry).
  std::optional<double> odometry_sigma_mm;
  std::size_t slip_touch = 0;    ///< 1-based touch from which the object has slipped (0: none)
  double slip_mm = 20.0;         ///< how far it slipped, mm
  std::size_t kidnap_touch = 0;  ///< 1-based touch at which the sensor is put elsewhere (0: none)
  /// What the filter is told about the outliers and the slip (evaluations' ceilings only).
  fault_oracle oracle = fault_oracle::none;

  [[nodiscard]] bool any() const {
    return outlier_probability > 0.0 || odometry_sigma_mm.has_value() || slip_touch > 0 ||
           kidnap_touch > 0;
  }

  void validate() const {
    if (!(std::isfinite(outlier_probability) && outlier_probability >= 0.0 &&
          outlier_probability <= 1.0))
      detail::fail("exploration_faults: outlier_probability = ", outlier_probability,
                   "; expected a probability in [0, 1] (e.g. 0.1 for one move in ten)");
    if (!(std::isfinite(outlier_mm) && outlier_mm >= 0.0 && outlier_mm <= 100.0))
      detail::fail("exploration_faults: outlier_mm = ", outlier_mm,
                   "; expected 0 .. 100 mm (e.g. 8)");
    if (odometry_sigma_mm && !(std::isfinite(*odometry_sigma_mm) && *odometry_sigma_mm >= 0.0 &&
                               *odometry_sigma_mm <= 50.0))
      detail::fail("exploration_faults: odometry_sigma_mm = ", *odometry_sigma_mm,
                   "; expected 0 .. 50 mm per axis (e.g. 3)");
    if (!(std::isfinite(slip_mm) && slip_mm > 0.0 && slip_mm <= 100.0))
      detail::fail("exploration_faults: slip_mm = ", slip_mm, "; expected 0 .. 100 mm (e.g. 20)");
    if (slip_touch == 1)
      detail::fail(
          "exploration_faults: slip_touch = 1; expected 0 (no slip) or a touch >= 2 (the "
          "object slips between two touches)");
    if (oracle == fault_oracle::transition && !(outlier_probability > 0.0))
      detail::fail("exploration_faults: the transition oracle with outlier_probability = ",
                   outlier_probability,
                   "; expected outliers whose transition it applies (e.g. 0.1), or oracle none");
    if (oracle == fault_oracle::told && !(outlier_probability > 0.0) && slip_touch == 0)
      detail::fail(
          "exploration_faults: the told oracle with outlier_probability = ", outlier_probability,
          " and no slip", "; expected outliers or a slip to tell the filter about, or oracle none");
    if (kidnap_touch == 1)
      detail::fail(
          "exploration_faults: kidnap_touch = 1; expected 0 (no kidnap) or a touch >= 2 "
          "(the first touch has no odometry to contradict)");
  }
};

/// One sequence after its faults: where each touch really is on the map and what odometry the
/// filter is told before it.
struct faulted_sequence {
  std::vector<touch_location> truth;  ///< per touch, map frame
  std::vector<odometry> reported;     ///< per touch (element 0 unused)
  std::vector<char> outlier;          ///< per touch: its reported move is an outlier
  /// The slip happened: false without one, and when no direction (200 draws) kept the later
  /// touches on the map — then the sequence runs without it, and evaluations must not count it
  /// as a slip (`touch_record::moved_unseen` is not set).
  bool slipped = false;
  bool kidnapped = false;  ///< the kidnap happened (as `slipped`)
};

/// Applies `faults` to `sequence` of `protocol`, drawing from `rng`; truths stay within the
/// states of `positions` (a slip's or kidnap's direction is redrawn until they do; after 200
/// draws the fault is dropped for this sequence rather than leaving the map). Throws
/// std::invalid_argument for invalid faults or a slip or kidnap touch beyond the sequence.
[[nodiscard]] inline faulted_sequence apply_faults(const touch_protocol& protocol,
                                                   const touch_sequence& sequence,
                                                   const planar_grid<float>& positions,
                                                   const exploration_faults& faults, sim_rng& rng) {
  faults.validate();
  const std::size_t n = sequence.size();
  if (faults.slip_touch > n || faults.kidnap_touch > n)
    detail::fail("exploration_faults: a fault at touch ",
                 faults.slip_touch > n ? faults.slip_touch : faults.kidnap_touch,
                 " of a sequence of ", n, " touches; expected a touch within the sequence");
  faulted_sequence out;
  for (const auto& st : sequence) {
    out.truth.push_back(protocol.locations.at(st.location));
    out.reported.push_back(st.measured_motion);
    out.outlier.push_back(0);
  }
  const double pi = std::numbers::pi;
  // Draws are made whatever the settings, so one fault does not reshuffle the others.
  for (std::size_t t = 1; t < n; ++t) {
    const double nx = rng.normal(), ny = rng.normal();
    const double u = rng.uniform(), angle = 2.0 * pi * rng.uniform();
    if (faults.odometry_sigma_mm)
      out.reported[t] = {sequence[t].true_motion.dx_mm + *faults.odometry_sigma_mm * nx,
                         sequence[t].true_motion.dy_mm + *faults.odometry_sigma_mm * ny};
    if (u < faults.outlier_probability) {
      out.reported[t].dx_mm += faults.outlier_mm * std::cos(angle);
      out.reported[t].dy_mm += faults.outlier_mm * std::sin(angle);
      out.outlier[t] = 1;
    }
  }
  const auto on_map = [&](std::size_t from, double ox, double oy) {
    for (std::size_t t = from; t < n; ++t)
      if (!positions.nearest_state(out.truth[t].x_mm + ox, out.truth[t].y_mm + oy)) return false;
    return true;
  };
  const auto shift_from = [&](std::size_t from, double ox, double oy) {
    for (std::size_t t = from; t < n; ++t) {
      out.truth[t].x_mm += ox;
      out.truth[t].y_mm += oy;
    }
  };
  if (faults.slip_touch > 0) {
    const std::size_t from = faults.slip_touch - 1;
    for (int attempt = 0; attempt < 200; ++attempt) {
      const double angle = 2.0 * pi * rng.uniform();
      const double ox = faults.slip_mm * std::cos(angle), oy = faults.slip_mm * std::sin(angle);
      if (on_map(from, ox, oy)) {
        shift_from(from, ox, oy);
        out.slipped = true;
        break;
      }
    }
  }
  if (faults.kidnap_touch > 0) {
    const std::size_t from = faults.kidnap_touch - 1;
    for (int attempt = 0; attempt < 200; ++attempt) {
      const auto target = positions.state_mm(
          static_cast<Eigen::Index>(rng.below(static_cast<std::uint64_t>(positions.size()))));
      const double ox = target(0) - out.truth[from].x_mm, oy = target(1) - out.truth[from].y_mm;
      if (on_map(from, ox, oy)) {
        shift_from(from, ox, oy);
        out.kidnapped = true;
        break;
      }
    }
  }
  return out;
}

/// One move of a sequence whose touches are chosen while it runs (the active order) after the
/// faults: where the touch really is and what odometry the filter is told.
struct faulted_move {
  touch_location truth;
  odometry reported;
  bool outlier = false;    ///< the reported move is an outlier
  bool slipped = false;    ///< the object slipped before this touch
  bool kidnapped = false;  ///< the sensor was put down elsewhere for this touch
};

/// `apply_faults`'s faults carried over to one move of a sequence whose touches are chosen while
/// it runs (the active order), so that both orders of a sequence meet the same faults and compare
/// pairwise: the arm moves from the true location `from` to `target` (a place on the object,
/// chosen where the object now lies), touch `t` (0-based, >= 1) of `sequence` whose faulted
/// version is `faulted`. The reported move is the true one plus the protocol's error for move t
/// (`faulted.reported[t]` minus the true move: its noise and outlier); at the slip's touch the
/// object moves by the protocol's slip offset (when that leaves `target` off `positions`, a
/// direction that keeps it on is drawn from `rng`, 200 draws at most, else no slip); at the
/// kidnap's touch the sensor lands where the protocol's did.
[[nodiscard]] inline faulted_move carry_faults_to_move(
    const touch_protocol& protocol, const touch_sequence& sequence, const faulted_sequence& faulted,
    const exploration_faults& faults, std::size_t t, const touch_location& from,
    const touch_location& target, const planar_grid<float>& positions, sim_rng& rng) {
  faulted_move out{target, {target.x_mm - from.x_mm, target.y_mm - from.y_mm}};
  out.reported.dx_mm += faulted.reported[t].dx_mm - sequence[t].true_motion.dx_mm;
  out.reported.dy_mm += faulted.reported[t].dy_mm - sequence[t].true_motion.dy_mm;
  out.outlier = faulted.outlier[t] != 0;
  if (faulted.slipped && faults.slip_touch == t + 1) {
    const touch_location& was = protocol.locations.at(sequence[t].location);
    double ox = faulted.truth[t].x_mm - was.x_mm, oy = faulted.truth[t].y_mm - was.y_mm;
    const double pi = std::numbers::pi;
    for (int attempt = 0;
         attempt < 200 && !positions.nearest_state(target.x_mm + ox, target.y_mm + oy); ++attempt) {
      const double a = 2.0 * pi * rng.uniform();
      ox = faults.slip_mm * std::cos(a);
      oy = faults.slip_mm * std::sin(a);
    }
    if (positions.nearest_state(target.x_mm + ox, target.y_mm + oy)) {
      out.truth = {target.x_mm + ox, target.y_mm + oy};
      out.slipped = true;
    }
  }
  if (faulted.kidnapped && faults.kidnap_touch == t + 1) {
    out.truth = faulted.truth[t];
    out.kidnapped = true;
  }
  return out;
}

/// Whether the estimate is back within `threshold_mm` of the truth within `touches` touches of
/// touch `from` (1-based) and stays there to the end: some touch in [from, from + touches]
/// after which every error is below the threshold.
template <class Record>
[[nodiscard]] bool recovered(const std::vector<Record>& touches, std::size_t from,
                             std::size_t within, double threshold_mm = 5.0) {
  if (from == 0 || from > touches.size()) return false;
  std::size_t first_good = touches.size();  // first touch (0-based) of the final run below
  while (first_good > 0 && touches[first_good - 1].error_mm < threshold_mm) --first_good;
  return first_good < touches.size() && first_good + 1 <= from + within;
}

/// How one sequence came back after its injected faults (`fault_recoveries`).
struct recovery_count {
  std::size_t faults = 0;     ///< touches right after an injected fault
  std::size_t counted = 0;    ///< of those, the faults whose recovery could be judged
  std::size_t recovered = 0;  ///< of those, the faults recovered from in time
  recovery_count& operator+=(const recovery_count& o) {
    faults += o.faults;
    counted += o.counted;
    recovered += o.recovered;
    return *this;
  }
};

/// "Recovered within `within` touches" after each injected fault of one sequence: a touch whose
/// record says a fault happened before it (`odometry_outlier` or `moved_unseen`) at 0-based
/// index j is recovered from when some touch in [j, j + within] has the estimate within
/// `threshold_mm` of the truth and every touch after it does too, up to the next fault or the
/// end (`recovered`'s rule, `from` = j + 1, the next fault closing the window). A fault is
/// counted when it was recovered from or its window holds `within` touches after it: a fault
/// too close to the end, or to the next fault, to tell is not counted as a failure.
template <class Record>
[[nodiscard]] recovery_count fault_recoveries(const std::vector<Record>& touches,
                                              std::size_t within, double threshold_mm = 5.0) {
  recovery_count out;
  const std::size_t n = touches.size();
  const auto is_fault = [&](std::size_t i) {
    return touches[i].odometry_outlier || touches[i].moved_unseen;
  };
  for (std::size_t j = 0; j < n; ++j) {
    if (!is_fault(j)) continue;
    ++out.faults;
    std::size_t end = j + 1;  // one past the window: the next fault or the end
    while (end < n && !is_fault(end)) ++end;
    std::size_t first_good = end;  // first touch of the window's final run below the threshold
    while (first_good > j && touches[first_good - 1].error_mm < threshold_mm) --first_good;
    const bool back = first_good < end && first_good <= j + within;
    if (back || j + within < end) ++out.counted;
    if (back) ++out.recovered;
  }
  return out;
}

}  // namespace tacmap
