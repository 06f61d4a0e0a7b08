// tacmap: `self_calibration` — a tactile array that calibrates itself from the touches it makes
// (issue 34, item 2): per-taxel gain and offset, dead and stuck taxels, with no calibration rig.
//
// Why it can: the elastic cover spreads every load over neighbouring cells (the foam, sim/
// tactile_simulator.hpp step 3), so the load a taxel carries is close to the mean load of its
// eight neighbours — in every touch, wherever the relief's edges fall. A taxel whose reading is
// consistently 0.7 of its neighbours' has a gain of 0.7 relative to them; one that reads 0 while
// they are loaded is dead; one whose reading does not move while theirs do is stuck. Over many
// touches the relief's curvature (a taxel on a ridge reads more than its neighbours' mean, one
// in a groove less) averages out, and robust statistics (medians) ignore the touches where it
// does not.
//
// The estimate, recomputed from the last `window` touches observed:
//  1. Dead and stuck. Over the touches that load the taxel's neighbourhood (their mean at least
//     `load_fraction` of the frame's peak; at least `min_touches` of them): *dead* when its
//     median reading is below `dead_fraction` of its neighbours' median (it reads nothing),
//     *stuck* when its reading's spread (10-90 % quantile range) is below `stuck_fraction` of
//     its neighbours' spread (it reads a constant).
//  2. Offsets. The reading of a taxel in the touches where every live neighbour reads within
//     `unloaded_fraction` of the frame's peak of its own zero (first guessed as its 10 %
//     quantile): nothing presses there, and their median (at least `min_touches` of them) is
//     the taxel's zero. Kept only when it differs from 0 by more than twice its standard error.
//  3. Gains, by fixed-point iteration: the ratio of a taxel's offset-corrected reading to the
//     mean of its live neighbours' corrected readings, over the touches where that mean is at
//     least `load_fraction` of the frame's peak; its median is the gain. A taxel at the array's
//     border sees its neighbours from one side, which biases that ratio on a curved relief: each
//     ratio is divided by the median ratio of the taxels with the same sides (its
//     neighbourhood class); a corner has no like and is left as it is. A gain is kept only when
//     it differs from 1 by more than `gain_tolerance` and three standard errors: a healthy
//     taxel is left exactly as it is. A taxel whose gain falls below `dead_fraction` is dead.
//  4. A taxel seen in fewer than `min_gain_touches` usable touches is not estimated: it is left
//     as it is (`taxel_status::unestimated`), and `reason(r, c)` says how many it has seen and
//     needs.
//
// `correct(frame)` returns the frame with (reading - offset) / gain per taxel, and a mask of the
// taxels that vote. A dead or stuck taxel's reading says nothing about the load: its value is
// replaced by the mean of its live neighbours' corrected values (inpainting). Why inpaint rather
// than leave a 0: preprocess normalises by the peak and the descriptors (SIFT gradients) and NCC
// see a 0 among loaded taxels as a pit — two strong gradients of opposite sign and a dark pixel
// that the map does not have, evidence against the true location. The inpainted value is a
// smooth interpolation of the neighbours, so the taxel adds no gradient of its own and no
// contrast the neighbours do not already give: it carries no evidence, it does not vote. (The
// mask is returned for models that can drop taxels outright.)
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <deque>
#include <string>
#include <vector>

#include "tacmap/image.hpp"
#include "tacmap/tactile/frame.hpp"

namespace tacmap {

/// What the calibration knows of one taxel.
enum class taxel_status {
  unestimated,  ///< too few usable touches yet: left as it is (see `self_calibration::reason`)
  healthy,      ///< estimated; gain and offset indistinguishable from 1 and 0: left as it is
  calibrated,   ///< estimated; corrected by its gain and offset
  dead,         ///< reads nothing (or far too little) under load: inpainted, never votes
  stuck,        ///< reads a constant whatever the load: inpainted, never votes
};

[[nodiscard]] inline const char* to_string(taxel_status s) {
  switch (s) {
    case taxel_status::unestimated:
      return "unestimated";
    case taxel_status::healthy:
      return "healthy";
    case taxel_status::calibrated:
      return "calibrated";
    case taxel_status::dead:
      return "dead";
    case taxel_status::stuck:
      return "stuck";
  }
  return "?";
}

/// Configuration of `self_calibration` (see the file comment for how each is used).
struct self_calibration_params {
  std::size_t window = 64;  ///< touches kept for the estimate (the most recent)
  /// Touches loading a taxel's neighbourhood needed to call it dead or stuck, and quiet touches
  /// needed to estimate its offset.
  std::size_t min_touches = 8;
  /// Even-enough touches (its neighbours' mean at least `load_fraction` of the peak) a taxel
  /// needs before its gain is estimated. A median of ratios to the neighbours is skewed by the
  /// relief's edges; with fewer than ~24 of them, simulated healthy taxels on a sparse relief
  /// came out 20-40 % off.
  std::size_t min_gain_touches = 24;
  double load_fraction = 0.25;      ///< neighbours' mean >= this x peak: a gain observation
  double unloaded_fraction = 0.02;  ///< every neighbour below this x peak: an offset observation
  double dead_fraction = 0.2;       ///< gain (or median reading ratio) below this: dead
  double stuck_fraction = 0.05;     ///< reading spread below this x neighbours' spread: stuck
  /// Gains within this of 1 are left at 1. The estimate's own error, measured on simulated
  /// binary reliefs with 64 touches, is about 0.05 (the relief's edges, not the read-out
  /// noise, limit it): a taxel is corrected only where its gain is clearly off.
  double gain_tolerance = 0.1;
  float min_peak = 200.0F;  ///< touches whose peak is below this are not used (no contact)
  int iterations = 4;       ///< fixed-point iterations of the gains
  /// The estimate is redone every this many usable touches (and by `refresh()`): about 1 ms
  /// of CPU for a full 64-touch window, so every 8th touch keeps it near 0.15 ms per touch.
  std::size_t refresh_every = 8;

  void validate() const {
    if (window < 1 || window > 100000)
      detail::fail("self_calibration_params: window = ", window,
                   "; expected 1 .. 100000 touches (64 is plenty)");
    if (min_touches < 1 || min_touches > window)
      detail::fail("self_calibration_params: min_touches = ", min_touches, "; expected 1 .. ",
                   window, " (the window)");
    if (min_gain_touches < 1 || min_gain_touches > window)
      detail::fail("self_calibration_params: min_gain_touches = ", min_gain_touches,
                   "; expected 1 .. ", window, " (the window)");
    const auto fraction = [](const char* name, double v, double hi) {
      if (!(std::isfinite(v) && v >= 0.0 && v <= hi))
        detail::fail("self_calibration_params: ", name, " = ", v, "; expected 0 .. ", hi);
    };
    fraction("load_fraction", load_fraction, 1.0);
    fraction("unloaded_fraction", unloaded_fraction, 1.0);
    fraction("dead_fraction", dead_fraction, 1.0);
    fraction("stuck_fraction", stuck_fraction, 1.0);
    fraction("gain_tolerance", gain_tolerance, 1.0);
    if (!(std::isfinite(min_peak) && min_peak >= 0.0F))
      detail::fail("self_calibration_params: min_peak = ", min_peak,
                   "; expected a finite count >= 0");
    if (iterations < 1 || iterations > 100)
      detail::fail("self_calibration_params: iterations = ", iterations, "; expected 1 .. 100");
    if (refresh_every < 1)
      detail::fail("self_calibration_params: refresh_every = ", refresh_every,
                   "; expected >= 1 usable touches between estimates (1 = after every touch)");
  }
};

/// A frame after calibration, and which taxels vote.
struct calibrated_frame {
  tactile_frame frame;  ///< corrected counts (dead and stuck taxels inpainted)
  image<bool> live;     ///< true: the taxel's own reading was used; false: dead or stuck
};

namespace detail::self_calibration {

/// Median of v (mean of the middle two); 0 when empty.
inline double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  const double upper = v[static_cast<std::size_t>(mid)];
  if (v.size() % 2 == 1) return upper;
  return 0.5 * (*std::max_element(v.begin(), v.begin() + mid) + upper);
}

/// The q-quantile of v (nearest rank); 0 when empty.
inline double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::ptrdiff_t>(std::llround(q * static_cast<double>(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<std::size_t>(k)];
}

/// Standard error of a median of v: 1.2533 x 1.4826 x MAD / sqrt(n) (normal data).
inline double median_standard_error(const std::vector<double>& v, double centre) {
  if (v.size() < 2) return 0.0;
  std::vector<double> dev(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) dev[i] = std::abs(v[i] - centre);
  return 1.2533 * 1.4826 * median(std::move(dev)) / std::sqrt(static_cast<double>(v.size()));
}

}  // namespace detail::self_calibration

/// Online self-calibration of one tactile array (see the file comment). Feed it every touch
/// (`observe`), correct every frame before preprocessing (`correct`). A value type; no rig, no
/// global state.
class self_calibration {
 public:
  /// Throws std::invalid_argument for a bad geometry or parameters.
  explicit self_calibration(taxel_geometry geometry = {}, self_calibration_params params = {})
      : geometry_(geometry), params_(params) {
    geometry_.validate();
    params_.validate();
    gain_ = image<float>::Ones(geometry_.rows, geometry_.cols);
    offset_ = image<float>::Zero(geometry_.rows, geometry_.cols);
    status_.assign(static_cast<std::size_t>(geometry_.rows * geometry_.cols),
                   taxel_status::unestimated);
    seen_.assign(status_.size(), 0);
    lonely_.assign(status_.size(), 0);
  }

  [[nodiscard]] const taxel_geometry& geometry() const { return geometry_; }
  [[nodiscard]] const self_calibration_params& params() const { return params_; }
  /// Touches observed so far (all of them, not only the window's).
  [[nodiscard]] std::size_t touches() const { return touches_; }
  /// Per-taxel gain (1 where not estimated or healthy).
  [[nodiscard]] const image<float>& gain() const { return gain_; }
  /// Per-taxel offset, counts (0 where not estimated or indistinguishable from 0).
  [[nodiscard]] const image<float>& offset() const { return offset_; }
  [[nodiscard]] taxel_status status(Eigen::Index r, Eigen::Index c) const {
    check_taxel(r, c);
    return status_[index(r, c)];
  }
  /// The taxels that vote (not dead, not stuck).
  [[nodiscard]] image<bool> live() const {
    image<bool> out(geometry_.rows, geometry_.cols);
    for (Eigen::Index r = 0; r < geometry_.rows; ++r)
      for (Eigen::Index c = 0; c < geometry_.cols; ++c) out(r, c) = votes(status_[index(r, c)]);
    return out;
  }
  /// A sentence: why taxel (r, c) has its status (e.g. how many usable touches it has seen).
  [[nodiscard]] std::string reason(Eigen::Index r, Eigen::Index c) const {
    check_taxel(r, c);
    const std::size_t i = index(r, c);
    const std::string at = "taxel (" + std::to_string(r) + ", " + std::to_string(c) + ")";
    switch (status_[i]) {
      case taxel_status::unestimated:
        if (lonely_[i] != 0)
          return at + " is left as it is: its gain is measured against its neighbours, and no " +
                 "other taxel sees its neighbours from the same sides (a corner), so the " +
                 "relief's bias on that ratio cannot be told from its gain";
        return at + " is left as it is: it was loaded in " + std::to_string(seen_[i]) +
               " usable touches of the last " + std::to_string(frames_.size()) + "; it needs " +
               std::to_string(params_.min_gain_touches) +
               " (self_calibration_params::min_gain_touches)";
      case taxel_status::healthy:
        return at + " is healthy: its gain and offset are within their uncertainty of 1 and 0";
      case taxel_status::calibrated:
        return at + " is corrected: gain " + std::to_string(gain_(r, c)) + ", offset " +
               std::to_string(offset_(r, c)) + " counts";
      case taxel_status::dead:
        return at +
               " is dead: it reads (almost) nothing where its neighbours are loaded; its "
               "value is inpainted from them";
      case taxel_status::stuck:
        return at +
               " is stuck: its reading does not follow its neighbours' load; its value is "
               "inpainted from them";
    }
    return at;
  }

  /// Adds one touch's frame to the window (frames below `min_peak` are counted but not used)
  /// and re-estimates every `refresh_every` usable touches. Throws std::invalid_argument for a
  /// frame of another geometry or an invalid frame.
  void observe(const tactile_frame& frame) {
    check_frame(frame, "observe");
    ++touches_;
    if (frame.counts.maxCoeff() < params_.min_peak) return;
    frames_.push_back(frame.counts);
    if (frames_.size() > params_.window) frames_.pop_front();
    if (++usable_ % params_.refresh_every == 0) estimate();
  }

  /// Redoes the estimate from the window now (observe does it every `refresh_every` touches).
  void refresh() { estimate(); }

  /// The frame corrected: (reading - offset) / gain per estimated taxel (at least 0), dead and
  /// stuck taxels inpainted from their live neighbours. Throws std::invalid_argument for a
  /// frame of another geometry or an invalid frame.
  [[nodiscard]] calibrated_frame correct(const tactile_frame& frame) const {
    check_frame(frame, "correct");
    calibrated_frame out{frame, live()};
    image<float>& x = out.frame.counts;
    for (Eigen::Index i = 0; i < x.size(); ++i)
      x.data()[i] = std::max(0.0F, (x.data()[i] - offset_.data()[i]) / gain_.data()[i]);
    inpaint(x, out.live);
    return out;
  }

 private:
  [[nodiscard]] std::size_t index(Eigen::Index r, Eigen::Index c) const {
    return static_cast<std::size_t>(c * geometry_.rows + r);  // Eigen's column-major order
  }
  static bool votes(taxel_status s) { return s != taxel_status::dead && s != taxel_status::stuck; }

  void check_taxel(Eigen::Index r, Eigen::Index c) const {
    if (r < 0 || r >= geometry_.rows || c < 0 || c >= geometry_.cols)
      detail::fail("self_calibration: taxel (", r, ", ", c, ") does not exist; expected rows 0 .. ",
                   geometry_.rows - 1, " and columns 0 .. ", geometry_.cols - 1);
  }

  void check_frame(const tactile_frame& frame, const char* who) const {
    if (!(frame.geometry == geometry_))
      detail::fail("self_calibration::", who, ": the frame's geometry is ", frame.geometry.rows,
                   " x ", frame.geometry.cols, " at ", frame.geometry.pitch_mm,
                   " mm but this calibration is of a ", geometry_.rows, " x ", geometry_.cols,
                   " array at ", geometry_.pitch_mm,
                   " mm; expected frames of the array it calibrates (one calibration per sensor)");
    frame.validate();
  }

  /// Visits the 8-neighbours of (r, c) inside the array.
  template <class F>
  void neighbours(Eigen::Index r, Eigen::Index c, F&& f) const {
    for (Eigen::Index dr = -1; dr <= 1; ++dr)
      for (Eigen::Index dc = -1; dc <= 1; ++dc) {
        if (dr == 0 && dc == 0) continue;
        const Eigen::Index rr = r + dr, cc = c + dc;
        if (rr < 0 || rr >= geometry_.rows || cc < 0 || cc >= geometry_.cols) continue;
        f(rr, cc);
      }
  }

  /// Replaces every taxel not `live` by the mean of its live neighbours (repeated outwards when
  /// a dead taxel has none; 0 when the array has no live taxel).
  void inpaint(image<float>& x, const image<bool>& live) const {
    image<bool> known = live;
    for (int pass = 0; pass < static_cast<int>(geometry_.rows + geometry_.cols); ++pass) {
      bool missing = false;
      image<bool> next = known;
      for (Eigen::Index r = 0; r < x.rows(); ++r)
        for (Eigen::Index c = 0; c < x.cols(); ++c) {
          if (known(r, c)) continue;
          double sum = 0.0;
          int n = 0;
          neighbours(r, c, [&](Eigen::Index rr, Eigen::Index cc) {
            if (!known(rr, cc)) return;
            sum += static_cast<double>(x(rr, cc));
            ++n;
          });
          if (n == 0) {
            missing = true;
            continue;
          }
          x(r, c) = static_cast<float>(sum / n);
          next(r, c) = true;
        }
      known = next;
      if (!missing) return;
    }
    for (Eigen::Index i = 0; i < x.size(); ++i)
      if (!known.data()[i]) x.data()[i] = 0.0F;
  }

  /// Which of its sides a taxel has neighbours on (a bit each: up, down, left, right): taxels of
  /// one class see their neighbours from the same side, so their ratio to the neighbours' mean
  /// has the same bias from the relief's curvature.
  [[nodiscard]] int neighbourhood_class(Eigen::Index r, Eigen::Index c) const {
    return (r > 0 ? 1 : 0) | (r + 1 < geometry_.rows ? 2 : 0) | (c > 0 ? 4 : 0) |
           (c + 1 < geometry_.cols ? 8 : 0);
  }

  void estimate() {
    namespace sc = detail::self_calibration;
    const Eigen::Index rows = geometry_.rows, cols = geometry_.cols;
    const std::size_t n = frames_.size();
    std::vector<taxel_status> status(status_.size(), taxel_status::unestimated);
    std::fill(seen_.begin(), seen_.end(), 0);
    std::fill(lonely_.begin(), lonely_.end(), 0);
    image<float> gain = image<float>::Ones(rows, cols);
    image<float> offset = image<float>::Zero(rows, cols);
    std::vector<double> peak(n);
    for (std::size_t f = 0; f < n; ++f) peak[f] = frames_[f].maxCoeff();

    // 1. Dead and stuck: does the reading follow the neighbours' load at all?
    for (Eigen::Index r = 0; r < rows; ++r)
      for (Eigen::Index c = 0; c < cols; ++c) {
        // Only the touches that load the taxel's neighbourhood say whether it follows the load.
        std::vector<double> own, around;
        for (std::size_t f = 0; f < n; ++f) {
          double sum = 0.0;
          int k = 0;
          neighbours(r, c, [&](Eigen::Index rr, Eigen::Index cc) {
            sum += frames_[f](rr, cc);
            ++k;
          });
          const double mean = k > 0 ? sum / k : 0.0;
          if (!(mean >= params_.load_fraction * peak[f]) || !(mean > 0.0)) continue;
          own.push_back(frames_[f](r, c));
          around.push_back(mean);
        }
        if (own.size() < params_.min_touches) continue;
        if (sc::median(own) < params_.dead_fraction * sc::median(around)) {
          status[index(r, c)] = taxel_status::dead;
          continue;
        }
        const double spread_own = sc::quantile(own, 0.9) - sc::quantile(own, 0.1);
        const double spread_around = sc::quantile(around, 0.9) - sc::quantile(around, 0.1);
        if (spread_around > 0.0 && spread_own <= params_.stuck_fraction * spread_around)
          status[index(r, c)] = taxel_status::stuck;
      }
    const auto alive = [&](Eigen::Index r, Eigen::Index c) { return votes(status[index(r, c)]); };

    // 2. Offsets, from the touches where nothing presses around the taxel. A first guess, each
    //    taxel's 10 % quantile, says which neighbours are quiet despite their own offsets.
    image<float> guess = image<float>::Zero(rows, cols);
    for (Eigen::Index r = 0; r < rows; ++r)
      for (Eigen::Index c = 0; c < cols; ++c) {
        std::vector<double> all(n);
        for (std::size_t f = 0; f < n; ++f) all[f] = frames_[f](r, c);
        guess(r, c) = static_cast<float>(sc::quantile(std::move(all), 0.1));
      }
    for (Eigen::Index r = 0; r < rows; ++r)
      for (Eigen::Index c = 0; c < cols; ++c) {
        if (!alive(r, c)) continue;
        std::vector<double> quiet;
        for (std::size_t f = 0; f < n; ++f) {
          double most = -1.0;
          neighbours(r, c, [&](Eigen::Index rr, Eigen::Index cc) {
            if (!alive(rr, cc)) return;
            most = std::max(most, static_cast<double>(frames_[f](rr, cc) - guess(rr, cc)));
          });
          if (most >= 0.0 && most < params_.unloaded_fraction * peak[f])
            quiet.push_back(frames_[f](r, c));
        }
        if (quiet.size() < params_.min_touches) continue;
        const double o = sc::median(quiet);
        if (std::abs(o) > 2.0 * sc::median_standard_error(quiet, o))
          offset(r, c) = static_cast<float>(o);
      }

    // 3. Gains, by fixed-point iteration against the neighbours' corrected mean, each taxel's
    //    ratio divided by the median ratio of its neighbourhood class (the curvature bias).
    std::vector<double> error(status.size(), 0.0);
    for (int it = 0; it < params_.iterations; ++it) {
      image<float> next = image<float>::Ones(rows, cols);
      for (Eigen::Index r = 0; r < rows; ++r)
        for (Eigen::Index c = 0; c < cols; ++c) {
          if (!alive(r, c)) continue;
          std::vector<double> ratios;
          for (std::size_t f = 0; f < n; ++f) {
            double sum = 0.0;
            int k = 0;
            neighbours(r, c, [&](Eigen::Index rr, Eigen::Index cc) {
              if (!alive(rr, cc)) return;
              sum += (frames_[f](rr, cc) - offset(rr, cc)) / gain(rr, cc);
              ++k;
            });
            if (k == 0) continue;
            const double reference = sum / k;
            if (!(reference >= params_.load_fraction * peak[f]) || !(reference > 0.0)) continue;
            ratios.push_back((frames_[f](r, c) - offset(r, c)) / reference);
          }
          seen_[index(r, c)] = ratios.size();
          if (ratios.size() < params_.min_gain_touches) continue;
          const double g = sc::median(ratios);
          next(r, c) = static_cast<float>(g);
          error[index(r, c)] = sc::median_standard_error(ratios, g);
        }
      // Each class's median ratio is its bias: divide it out (a class of fewer than three
      // estimated taxels, a corner, has nothing to compare with: those stay unestimated).
      for (int k = 0; k < 16; ++k) {
        std::vector<double> members;
        for (Eigen::Index r = 0; r < rows; ++r)
          for (Eigen::Index c = 0; c < cols; ++c)
            if (neighbourhood_class(r, c) == k && alive(r, c) &&
                seen_[index(r, c)] >= params_.min_gain_touches &&
                next(r, c) >= params_.dead_fraction)
              members.push_back(next(r, c));
        const double bias = members.size() >= 3 ? sc::median(members) : 0.0;
        for (Eigen::Index r = 0; r < rows; ++r)
          for (Eigen::Index c = 0; c < cols; ++c) {
            if (neighbourhood_class(r, c) != k || seen_[index(r, c)] < params_.min_gain_touches)
              continue;
            if (bias > 0.0) {
              next(r, c) = static_cast<float>(next(r, c) / bias);
              error[index(r, c)] /= bias;
            } else if (next(r, c) >= params_.dead_fraction) {
              lonely_[index(r, c)] = 1;
              next(r, c) = 1.0F;
            }
          }
      }
      for (Eigen::Index r = 0; r < rows; ++r)
        for (Eigen::Index c = 0; c < cols; ++c)
          if (seen_[index(r, c)] < params_.min_gain_touches) next(r, c) = 1.0F;
      gain = next;
    }

    // 4. Status: dead by gain, healthy when indistinguishable from the nominal taxel; a gain
    //    seen too little (or of a corner) stays 1, an offset is kept on its own evidence.
    for (Eigen::Index r = 0; r < rows; ++r)
      for (Eigen::Index c = 0; c < cols; ++c) {
        const std::size_t i = index(r, c);
        if (!alive(r, c)) {  // dead or stuck: inpainted, never corrected
          gain(r, c) = 1.0F;
          offset(r, c) = 0.0F;
          continue;
        }
        const bool gain_known = seen_[i] >= params_.min_gain_touches && lonely_[i] == 0;
        if (gain_known && gain(r, c) < params_.dead_fraction) {
          status[i] = taxel_status::dead;
          gain(r, c) = 1.0F;
          offset(r, c) = 0.0F;
          continue;
        }
        const double deviation = std::abs(static_cast<double>(gain(r, c)) - 1.0);
        if (!gain_known || deviation <= std::max(params_.gain_tolerance, 3.0 * error[i]))
          gain(r, c) = 1.0F;
        if (!gain_known && offset(r, c) == 0.0F)
          status[i] = taxel_status::unestimated;  // left as it is
        else
          status[i] = gain(r, c) != 1.0F || offset(r, c) != 0.0F ? taxel_status::calibrated
                                                                 : taxel_status::healthy;
      }
    gain_ = gain;
    offset_ = offset;
    status_ = std::move(status);
  }

  taxel_geometry geometry_;
  self_calibration_params params_;
  std::deque<image<float>> frames_;  // the window's touches (raw counts)
  image<float> gain_;
  image<float> offset_;
  std::vector<taxel_status> status_;
  std::vector<std::size_t> seen_;  // usable gain observations per taxel (last estimate)
  std::vector<char> lonely_;       // 1: no like neighbourhood to compare its ratio with
  std::size_t touches_ = 0;
  std::size_t usable_ = 0;  // touches with contact, ever
};

}  // namespace tacmap
