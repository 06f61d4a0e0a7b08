// tacmap: angles in radians, wrapped into [-pi, pi) — the range of pose_grid's headings and of
// the filter's circular estimates.
#pragma once

#include <cmath>
#include <numbers>

namespace tacmap {

/// `theta_rad` wrapped into [-pi, pi) (pi itself maps to -pi).
[[nodiscard]] inline double wrap_angle(double theta_rad) {
  constexpr double pi = std::numbers::pi;
  double w = std::fmod(theta_rad + pi, 2.0 * pi);
  if (w < 0.0) w += 2.0 * pi;
  w -= pi;
  return w >= pi ? -pi : w;
}

}  // namespace tacmap
