// tacmap: a raw tactile frame as a sensor delivers it — taxel counts, geometry and time.
//
// Frames travel from a device adapter (or the simulator, or a replayed log) to preprocessing.
// The geometry comes with every frame, so nothing downstream hard-codes the paper's 14 x 6.
#pragma once

#include <chrono>
#include <cmath>
#include <cstdint>

#include "tacmap/image.hpp"

namespace tacmap {

/// The layout of a tactile array: taxel rows x columns and the centre-to-centre pitch.
struct taxel_geometry {
  Eigen::Index rows = 14;  ///< taxels along the sensor's long side (y on the map)
  Eigen::Index cols = 6;   ///< taxels across (x on the map)
  double pitch_mm = 3.4;   ///< cell pitch in millimetres (Weiss DSA 9205 / WTS 0614-34A)
  friend bool operator==(const taxel_geometry&, const taxel_geometry&) = default;

  /// Throws std::invalid_argument naming the offending field unless the geometry is usable.
  void validate() const {
    if (rows <= 0 || cols <= 0)
      detail::fail("taxel_geometry: rows = ", rows, ", cols = ", cols,
                   "; expected both > 0 (the paper's Weiss array is 14 x 6)");
    if (!(std::isfinite(pitch_mm) && pitch_mm > 0.0))
      detail::fail("taxel_geometry: pitch_mm = ", pitch_mm,
                   "; expected a finite pitch > 0 in millimetres (Weiss arrays: 3.4)");
  }
};

/// One tactile frame: raw counts (row-major, `geometry.rows` x `geometry.cols`), the time it was
/// sampled and where it came from. Counts are kept as the sensor reports them (12-bit for Weiss
/// arrays) in float, so simulated, recorded and live frames share one type.
struct tactile_frame {
  using clock = std::chrono::steady_clock;
  taxel_geometry geometry{};
  image<float> counts = image<float>::Zero(14, 6);
  clock::time_point timestamp{};
  std::uint32_t sequence = 0;  ///< running frame number from the source, when it has one

  /// Throws std::invalid_argument unless counts match the geometry and are finite, >= 0.
  void validate() const {
    geometry.validate();
    if (counts.rows() != geometry.rows || counts.cols() != geometry.cols)
      detail::fail("tactile_frame: counts are ", counts.rows(), " x ", counts.cols(),
                   " but the geometry says ", geometry.rows, " x ", geometry.cols,
                   "; fill counts with one value per taxel, rows first");
    for (Eigen::Index r = 0; r < counts.rows(); ++r)
      for (Eigen::Index c = 0; c < counts.cols(); ++c) {
        const float v = counts(r, c);
        if (!(std::isfinite(v) && v >= 0.0F))
          detail::fail("tactile_frame: taxel (", r, ", ", c, ") = ", v,
                       "; expected a finite, non-negative count");
      }
  }
};

}  // namespace tacmap
