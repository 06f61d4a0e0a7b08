// tacmap: several frames per press — `combine_burst` turns a burst of frames of one press into
// one frame (issue 34, item 3).
//
// The paper's sensor "stays at each location for a certain time and 20 readings are thus
// collected at each location" (Sec. IV-B). Averaging them divides the read-out noise by about
// sqrt(20), but a plain mean inherits what goes wrong while a press is held:
//
//  * The press is still settling: the foam creeps and the arm's controller overshoots, so the
//    first frames carry less (or more) load than the rest. They are a *head* of the burst whose
//    total pressure has not reached the settled level.
//  * Outlier frames: a frame read while the arm twitched, a corrupted transfer that still passed
//    its CRC, a glitch of the read-out: its total pressure is far from the settled level.
//  * Single-taxel spikes within otherwise good frames.
//
// The combination, in order:
//  1. The settled level L: the median of the frames' total counts over the burst's second half
//     (a press settles towards its end; a median ignores a minority of outliers there).
//  2. The settling head: frames before the first one whose total is within `settle_tolerance`
//     x L of L are dropped (a stability test against the settled level, not against the
//     previous frame, so a slow creep is caught as well as an overshoot).
//  3. Outliers: of the remaining frames, those whose total differs from L by more than
//     `outlier_tolerance` x L are dropped.
//  4. Per taxel, the median (default) or a trimmed mean of the frames kept: a spike in one
//     frame does not move it.
// Every frame's fate is reported (`burst_frame_status`), so nothing is silently lost.
//
// Bad input: an empty burst, frames whose geometry (or counts' shape) differs from the first
// frame's, or a frame with a non-finite or negative count: std::invalid_argument naming the
// frame and what was expected.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "tacmap/image.hpp"
#include "tacmap/tactile/frame.hpp"

namespace tacmap {

/// How a burst's frames are combined per taxel.
enum class burst_statistic {
  median,        ///< per-taxel median of the frames kept (default: robust to single spikes)
  trimmed_mean,  ///< per-taxel mean after dropping `trim_fraction` of the values at each end
};

/// Configuration of `combine_burst`.
struct burst_params {
  /// A frame belongs to the settled press once its total is within this fraction of the settled
  /// level; the frames before the first such frame are the settling head.
  double settle_tolerance = 0.05;
  /// After the head, frames whose total differs from the settled level by more than this
  /// fraction are outliers. At least `settle_tolerance`.
  double outlier_tolerance = 0.15;
  burst_statistic statistic = burst_statistic::median;
  /// trimmed_mean: fraction of the values dropped at each end, [0, 0.5).
  double trim_fraction = 0.2;
  /// Totals below this (counts) count as no load: a burst of frames without contact combines
  /// to their median whatever its relative variation (noise on nothing is not "unsettled").
  double min_total = 1.0;

  /// Throws std::invalid_argument naming the field unless the parameters are usable.
  void validate() const {
    if (!(std::isfinite(settle_tolerance) && settle_tolerance >= 0.0))
      detail::fail("burst_params: settle_tolerance = ", settle_tolerance,
                   "; expected a finite fraction >= 0 of the settled total (e.g. 0.05)");
    if (!(std::isfinite(outlier_tolerance) && outlier_tolerance >= settle_tolerance))
      detail::fail("burst_params: outlier_tolerance = ", outlier_tolerance,
                   "; expected a finite fraction >= settle_tolerance (", settle_tolerance,
                   "): a settled frame must not be an outlier");
    if (statistic != burst_statistic::median && statistic != burst_statistic::trimmed_mean)
      detail::fail("burst_params: statistic = ", static_cast<int>(statistic),
                   "; expected burst_statistic::median or trimmed_mean");
    if (!(trim_fraction >= 0.0 && trim_fraction < 0.5))
      detail::fail("burst_params: trim_fraction = ", trim_fraction,
                   "; expected a fraction in [0, 0.5) dropped at each end");
    if (!(std::isfinite(min_total) && min_total >= 0.0))
      detail::fail("burst_params: min_total = ", min_total, "; expected a finite count >= 0");
  }
};

/// What became of one frame of a burst.
enum class burst_frame_status {
  used,      ///< combined
  settling,  ///< dropped: before the press settled
  outlier,   ///< dropped: its total pressure is far from the settled level
};

[[nodiscard]] inline const char* to_string(burst_frame_status s) {
  switch (s) {
    case burst_frame_status::used:
      return "used";
    case burst_frame_status::settling:
      return "settling";
    case burst_frame_status::outlier:
      return "outlier";
  }
  return "?";
}

/// The result of `combine_burst`.
struct combined_burst {
  /// The combined frame: the burst's geometry, per-taxel statistic of the frames used, the
  /// timestamp and sequence number of the last frame used.
  tactile_frame frame;
  std::vector<burst_frame_status> status;  ///< one per frame of the burst, in order
  double settled_total = 0.0;              ///< the settled level L (counts)
  std::size_t used = 0;                    ///< frames combined (>= 1)
};

namespace detail::burst {

inline double median_of(std::vector<double> v) {
  const auto mid = static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  const double upper = v[static_cast<std::size_t>(mid)];
  if (v.size() % 2 == 1) return upper;
  return 0.5 * (*std::max_element(v.begin(), v.begin() + mid) + upper);
}

}  // namespace detail::burst

/// Combines a burst of frames of one press (see the file comment). Throws std::invalid_argument
/// for an empty burst, a frame whose geometry or shape differs from the first's (naming both),
/// an invalid frame, or bad parameters.
[[nodiscard]] inline combined_burst combine_burst(std::span<const tactile_frame> frames,
                                                  const burst_params& params = {}) {
  params.validate();
  if (frames.empty())
    detail::fail(
        "combine_burst: the burst has no frames; expected at least one frame of the "
        "press (the paper took 20)");
  const taxel_geometry& g = frames.front().geometry;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const tactile_frame& f = frames[i];
    if (!(f.geometry == g))
      detail::fail("combine_burst: frame ", i, " of ", frames.size(), " has geometry ",
                   f.geometry.rows, " x ", f.geometry.cols, " at ", f.geometry.pitch_mm,
                   " mm but frame 0 has ", g.rows, " x ", g.cols, " at ", g.pitch_mm,
                   " mm; expected every frame of a burst from the same array (one press of one "
                   "sensor)");
    try {
      f.validate();
    } catch (const std::invalid_argument& e) {
      detail::fail("combine_burst: frame ", i, " of ", frames.size(), ": ", e.what());
    }
  }
  const std::size_t n = frames.size();
  std::vector<double> totals(n);
  for (std::size_t i = 0; i < n; ++i) totals[i] = frames[i].counts.cast<double>().sum();

  combined_burst out;
  out.status.assign(n, burst_frame_status::used);
  out.settled_total = detail::burst::median_of(
      std::vector<double>(totals.begin() + static_cast<std::ptrdiff_t>(n / 2), totals.end()));
  const double level = out.settled_total;
  if (level >= params.min_total) {
    std::size_t head = 0;
    while (head < n && std::abs(totals[head] - level) > params.settle_tolerance * level) ++head;
    // The median of the second half is one of its totals (odd count) or between two of them:
    // when no frame is within the tolerance (an even half split by an outlier), keep the frame
    // nearest the level rather than none.
    if (head == n) {
      std::size_t best = 0;
      for (std::size_t i = 1; i < n; ++i)
        if (std::abs(totals[i] - level) < std::abs(totals[best] - level)) best = i;
      head = best;
    }
    for (std::size_t i = 0; i < n; ++i) {
      if (i < head)
        out.status[i] = burst_frame_status::settling;
      else if (i != head && std::abs(totals[i] - level) > params.outlier_tolerance * level)
        out.status[i] = burst_frame_status::outlier;
    }
  }

  std::vector<const tactile_frame*> kept;
  for (std::size_t i = 0; i < n; ++i)
    if (out.status[i] == burst_frame_status::used) kept.push_back(&frames[i]);
  out.used = kept.size();
  out.frame.geometry = g;
  out.frame.timestamp = kept.back()->timestamp;
  out.frame.sequence = kept.back()->sequence;
  out.frame.counts.resize(g.rows, g.cols);
  std::vector<float> values(kept.size());
  const auto m = static_cast<std::ptrdiff_t>(kept.size());
  // trimmed_mean: floor(trim x m) values dropped at each end (none for a small burst).
  const auto trim =
      static_cast<std::ptrdiff_t>(std::floor(params.trim_fraction * static_cast<double>(m)));
  for (Eigen::Index t = 0; t < out.frame.counts.size(); ++t) {
    for (std::size_t k = 0; k < kept.size(); ++k) values[k] = kept[k]->counts.data()[t];
    std::sort(values.begin(), values.end());
    double v = 0.0;
    if (params.statistic == burst_statistic::median) {
      v = m % 2 == 1 ? values[static_cast<std::size_t>(m / 2)]
                     : 0.5 * (static_cast<double>(values[static_cast<std::size_t>(m / 2 - 1)]) +
                              static_cast<double>(values[static_cast<std::size_t>(m / 2)]));
    } else {
      double sum = 0.0;
      for (std::ptrdiff_t k = trim; k < m - trim; ++k) sum += values[static_cast<std::size_t>(k)];
      v = sum / static_cast<double>(m - 2 * trim);
    }
    out.frame.counts.data()[t] = static_cast<float>(v);
  }
  return out;
}

}  // namespace tacmap
