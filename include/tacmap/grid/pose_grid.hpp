// tacmap: `pose_grid` — candidate sensor poses (x, y, theta): position AND orientation.
//
// The paper assumes the sensor's orientation on the map is known (Sec. III-A) and names
// rotation as future work; in a real grasp the finger turns. A pose grid is a stack of
// `angle_count()` layers, one per heading, each layer the `planar_grid` of window centres:
//  * Layer a holds heading theta_a = a * step, wrapped into [-pi, pi) (step = 2 pi / angle_count),
//    so layer 0 is theta = 0, the paper's known orientation, and a one-angle pose grid is the
//    planar case.
//  * Heading convention (as `tactile_simulator`): the sensor-frame offset (u, v) (u along the
//    array's columns, v along its rows) lies at map offset R(theta) (u, v) from the sensor
//    centre, R(theta) = [cos -sin; sin cos]: a positive theta turns the array's column axis from
//    the map's +x towards +y (clockwise on screen, y pointing down).
//  * State index = a * (rows * cols) + row * cols + col: layer after layer, each row-major, as the
//    `state_grid` concept lays out multi-layer beliefs. State coordinates: (x mm, y mm, theta rad).
//  * Positions are the planar grid's: every window centre where the *unrotated* window fits. At
//    other headings a footprint near the map's edge may stick out; the measurement model decides
//    what that means (rotated_descriptor_likelihood rules such poses out).
#pragma once

#include <array>
#include <cmath>
#include <numbers>
#include <optional>

#include "tacmap/angle.hpp"
#include "tacmap/grid/planar_grid.hpp"

namespace tacmap {

namespace detail {
/// Heading of layer `layer` of `count` evenly spaced headings, wrapped into [-pi, pi) with
/// integers so that layer count / 2 is -pi, never +pi by rounding. That layer is returned as
/// -pi explicitly: (-count / 2) * (2 pi / count) rounds to one ulp below -pi for some counts
/// (50, 82, 100, ...), which is outside [-pi, pi) and would make layer_of reject a heading the
/// grid itself reported.
inline double layer_heading(Eigen::Index layer, Eigen::Index count) {
  if (2 * layer == count) return -std::numbers::pi;
  const Eigen::Index a = 2 * layer >= count ? layer - count : layer;
  return static_cast<double>(a) * (2.0 * std::numbers::pi / static_cast<double>(count));
}
}  // namespace detail

/// Position and heading of the sensor on the map (x, y in mm, theta in radians in [-pi, pi)).
template <belief_scalar T = float>
class pose_grid {
 public:
  using scalar_type = T;
  static constexpr int dimension = 3;
  using state_type = Eigen::Matrix<double, 3, 1>;
  /// Which coordinates are angles: bayes_filter::estimate uses circular statistics for them.
  static constexpr std::array<bool, 3> circular = {false, false, true};

  /// `positions`: the window centres of every layer; `angle_count`: headings evenly spaced over
  /// the full circle (36 = 10 degree steps). Throws std::invalid_argument for angle_count < 1.
  pose_grid(planar_grid<T> positions, int angle_count)
      : positions_(positions), angles_(angle_count) {
    if (angle_count < 1 || angle_count > 3600)
      detail::fail("pose_grid: angle_count = ", angle_count,
                   "; expected between 1 and 3600 headings over the full circle (36 gives 10 "
                   "degree steps; 1 is the known-orientation, planar case)");
  }

  /// Headings every `step_deg` degrees. Throws std::invalid_argument unless the step divides
  /// the circle (360 / step_deg a whole number, e.g. 5, 7.5, 10, 12, 15, 30 degrees).
  [[nodiscard]] static pose_grid with_step_deg(planar_grid<T> positions, double step_deg) {
    if (!(std::isfinite(step_deg) && step_deg > 0.0 && step_deg <= 360.0))
      detail::fail("pose_grid: angular step = ", step_deg,
                   " degrees; expected a finite step in (0, 360] that divides the circle");
    const double n = 360.0 / step_deg;
    const double whole = std::round(n);
    if (std::abs(n - whole) > 1e-9 * n)
      detail::fail("pose_grid: angular step = ", step_deg, " degrees does not divide the circle (",
                   "360 / ", step_deg, " = ", n, "); expected a step such as ", 360.0 / whole,
                   " degrees (", whole, " headings) or ", 360.0 / (whole + 1.0), " degrees (",
                   whole + 1.0, " headings)");
    return pose_grid(positions, static_cast<int>(whole));
  }

  /// The paper's map and window (`planar_grid::paper()`) with `angle_count` headings.
  [[nodiscard]] static pose_grid paper(int angle_count = 36) {
    return pose_grid(planar_grid<T>::paper(), angle_count);
  }

  [[nodiscard]] Eigen::Index rows() const { return positions_.rows(); }
  [[nodiscard]] Eigen::Index cols() const { return positions_.cols(); }
  /// States in one layer (one heading).
  [[nodiscard]] Eigen::Index layer_size() const { return positions_.size(); }
  [[nodiscard]] Eigen::Index size() const { return layer_size() * angles_; }
  /// The planar grid every layer shares.
  [[nodiscard]] const planar_grid<T>& positions() const { return positions_; }
  [[nodiscard]] int angle_count() const { return angles_; }
  [[nodiscard]] double angle_step_rad() const { return 2.0 * std::numbers::pi / angles_; }
  [[nodiscard]] pixel_size map_size() const { return positions_.map_size(); }
  [[nodiscard]] pixel_size window_size() const { return positions_.window_size(); }
  [[nodiscard]] double mm_per_px() const { return positions_.mm_per_px(); }
  [[nodiscard]] double mm_to_px(double mm) const { return positions_.mm_to_px(mm); }
  [[nodiscard]] double px_to_mm(double px) const { return positions_.px_to_mm(px); }

  /// Heading of layer a, radians in [-pi, pi).
  [[nodiscard]] double heading(Eigen::Index layer) const {
    TACMAP_ASSERT(layer >= 0 && layer < angles_, "heading layer out of range");
    return detail::layer_heading(layer, angles_);
  }

  /// The layer whose heading is nearest to `theta_rad`. Throws std::invalid_argument for a
  /// heading that is not finite or outside [-pi, pi) (wrap it first: see `wrap_angle`).
  [[nodiscard]] Eigen::Index layer_of(double theta_rad) const {
    check_heading(theta_rad, "pose_grid::layer_of");
    auto a = static_cast<Eigen::Index>(std::lround(theta_rad / angle_step_rad()));
    a %= angles_;
    return a < 0 ? a + angles_ : a;
  }

  [[nodiscard]] Eigen::Index index(Eigen::Index layer, grid_cell cell) const {
    TACMAP_ASSERT(layer >= 0 && layer < angles_, "heading layer out of range");
    return layer * layer_size() + positions_.index(cell);
  }
  [[nodiscard]] Eigen::Index layer(Eigen::Index index) const {
    TACMAP_ASSERT(index >= 0 && index < size(), "state index out of range");
    return index / layer_size();
  }
  [[nodiscard]] grid_cell cell(Eigen::Index index) const {
    TACMAP_ASSERT(index >= 0 && index < size(), "state index out of range");
    return positions_.cell(index % layer_size());
  }

  /// (x mm, y mm, theta rad) of state `index`.
  [[nodiscard]] state_type state_mm(Eigen::Index index) const {
    const auto xy = positions_.state_mm(index % layer_size());
    return {xy.x(), xy.y(), heading(layer(index))};
  }

  /// The state nearest to (x, y, theta), or nothing when (x, y) is more than half a pixel outside
  /// the positions' reach. Throws std::invalid_argument for a NaN heading or one outside
  /// [-pi, pi).
  [[nodiscard]] std::optional<Eigen::Index> nearest_state(double x_mm, double y_mm,
                                                          double theta_rad) const {
    check_heading(theta_rad, "pose_grid::nearest_state");  // name the caller in the message
    const Eigen::Index a = layer_of(theta_rad);
    const auto xy = positions_.nearest_state(x_mm, y_mm);
    if (!xy) return std::nullopt;
    return a * layer_size() + *xy;
  }

  /// A prior for `bayes_filter::set_prior`: a Gaussian around (x, y) with `sigma_mm` per axis
  /// times a wrapped Gaussian around `theta_rad` with `sigma_rad`; +infinity for either sigma
  /// makes that part flat. Throws std::invalid_argument for NaN values, a heading outside
  /// [-pi, pi), or sigmas that are not > 0.
  [[nodiscard]] Eigen::Array<T, Eigen::Dynamic, 1> gaussian_prior(double x_mm, double y_mm,
                                                                  double theta_rad, double sigma_mm,
                                                                  double sigma_rad) const {
    if (!(std::isfinite(x_mm) && std::isfinite(y_mm)))
      detail::fail("pose_grid::gaussian_prior: centre (", x_mm, ", ", y_mm,
                   ") mm; expected finite map coordinates in millimetres");
    check_heading(theta_rad, "pose_grid::gaussian_prior");
    if (!(sigma_mm > 0.0) || !(sigma_rad > 0.0))
      detail::fail("pose_grid::gaussian_prior: sigma_mm = ", sigma_mm, ", sigma_rad = ", sigma_rad,
                   "; expected both > 0 (+infinity for a flat prior along that axis)");
    Eigen::Array<double, Eigen::Dynamic, 1> along(angles_);
    for (Eigen::Index a = 0; a < angles_; ++a) {
      const double d = wrap_angle(heading(a) - theta_rad);
      along(a) = std::isinf(sigma_rad) ? 1.0 : std::exp(-0.5 * d * d / (sigma_rad * sigma_rad));
    }
    Eigen::Array<double, Eigen::Dynamic, 1> across(layer_size());
    for (Eigen::Index i = 0; i < layer_size(); ++i) {
      const auto xy = positions_.state_mm(i);
      const double d2 = (xy.x() - x_mm) * (xy.x() - x_mm) + (xy.y() - y_mm) * (xy.y() - y_mm);
      across(i) = std::isinf(sigma_mm) ? 1.0 : std::exp(-0.5 * d2 / (sigma_mm * sigma_mm));
    }
    Eigen::Array<T, Eigen::Dynamic, 1> prior(size());
    for (Eigen::Index a = 0; a < angles_; ++a)
      prior.segment(a * layer_size(), layer_size()) = (along(a) * across).template cast<T>();
    return prior;
  }

  /// theta wrapped into [-pi, pi).
  [[nodiscard]] static double wrap_angle(double theta_rad) { return tacmap::wrap_angle(theta_rad); }

 private:
  static void check_heading(double theta_rad, const char* who) {
    if (!std::isfinite(theta_rad))
      detail::fail(who, ": heading theta = ", theta_rad,
                   " rad; expected a finite angle in [-pi, pi) — a NaN heading usually means "
                   "a dropped orientation sample");
    if (!(theta_rad >= -std::numbers::pi && theta_rad < std::numbers::pi))
      detail::fail(who, ": heading theta = ", theta_rad,
                   " rad is outside [-pi, pi); expected a wrapped angle (pose_grid::wrap_angle(",
                   theta_rad, ") = ", wrap_angle(theta_rad), ")");
  }

  planar_grid<T> positions_;
  int angles_;
};

}  // namespace tacmap
