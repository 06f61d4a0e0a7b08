// tacmap: the `position_source` concept — where the tactile sensor is, as the arm or haptic
// device reports it — and the map-frame calibration that turns two such poses into the
// odometry the motion model consumes.
//
// In the paper the sensor rides on a Phantom Omni; the position from the device's forward
// kinematics is taken as the sensor centre (Sec. IV), and the change between two touches is the
// control u_t of the control update (Sec. III-B, Table 1). Other sources — a robot arm, a
// motion-capture stream, a recorded session — plug in the same way, so the source is a policy
// (a concept), with the Omni as one model of it (devices/phantom_omni.hpp).
//
// Frames. A source reports poses in its own *device frame* (millimetres). The filter works in the
// *map frame* (x right along the map's columns, y down along its rows, mm; see
// grid/planar_grid.hpp). `map_calibration` is the planar map between them: the object lies in a
// plane of the device frame spanned by two orthonormal axes u and v (u becomes the map's x, v its
// y, before an in-plane rotation); then a rotation, a scale and a translation:
//
//     map_mm = translation_mm + scale * R(rotation_rad) * [u . p ; v . p]
//
// Only differences matter to the filter (odometry), so translation only serves `to_map_mm`
// (e.g. to compare with ground truth or to seed a prior).
//
// Heading. `sensor_pose::yaw_rad` is the sensor's heading in the object's plane, measured from u
// toward v — the same sense as from the map's x toward its y — with an arbitrary zero: only its
// changes are used. A source that knows its full orientation (the Omni) projects its sensor's
// reference direction into the plane to get it (`map_calibration::plane_heading`).
#pragma once

#include <Eigen/Core>
#include <chrono>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string_view>
#include <utility>
#include <vector>

#include "tacmap/image.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"

namespace tacmap {

/// Where the sensor centre is, in the source's device frame, and when it was there.
struct sensor_pose {
  using clock = std::chrono::steady_clock;
  clock::time_point timestamp{};  ///< when the source sampled the pose (steady clock)
  double x_mm = 0.0;              ///< sensor centre, device frame
  double y_mm = 0.0;
  double z_mm = 0.0;
  double yaw_rad = 0.0;  ///< heading in the object's plane (see the file comment)

  [[nodiscard]] Eigen::Vector3d position_mm() const { return {x_mm, y_mm, z_mm}; }
  [[nodiscard]] bool finite() const {
    return std::isfinite(x_mm) && std::isfinite(y_mm) && std::isfinite(z_mm) &&
           std::isfinite(yaw_rad);
  }
  friend bool operator==(const sensor_pose&, const sensor_pose&) = default;
};

/// A source of sensor poses: a haptic device, an arm, a replayed session.
///
/// A type `S` models `position_source` when, for an `S s` (not const: reading advances the
/// source) and a `std::chrono::milliseconds timeout`:
///  1. `s.next_pose(timeout)` returns `std::optional<sensor_pose>`: the next pose, with every
///     field finite. A live source returns the current pose, waiting at most `timeout` for it,
///     and throws `tacmap::device_error` (devices/serial_port.hpp) naming the device and the
///     remedy when it cannot. A finite source (a recording, a script) returns its poses in order
///     and then `std::nullopt`, and keeps returning `std::nullopt`: nothing else means "no pose".
///
/// Minimal conforming type (a sensor that never moves):
/// ```
/// struct parked {
///   std::optional<sensor_pose> next_pose(std::chrono::milliseconds) {
///     return sensor_pose{sensor_pose::clock::now()};
///   }
/// };
/// ```
template <class S>
concept position_source = requires(S& source, std::chrono::milliseconds timeout) {
  { source.next_pose(timeout) } -> std::same_as<std::optional<sensor_pose>>;
};

namespace detail {

/// Wraps an angle to (-pi, pi].
[[nodiscard]] inline double wrap_angle(double a) {
  constexpr double pi = std::numbers::pi;
  a = std::remainder(a, 2.0 * pi);  // [-pi, pi]
  return a <= -pi ? a + 2.0 * pi : a;
}

}  // namespace detail

/// `to - from` on the steady clock, checked: the tick difference of two time points far apart
/// (a corrupt log, an uninitialised timestamp) overflows the clock's signed 64-bit count, which
/// is undefined behaviour in C++. Throws std::invalid_argument naming both ticks and `what`.
[[nodiscard]] inline std::chrono::steady_clock::duration checked_elapsed(
    std::chrono::steady_clock::time_point from, std::chrono::steady_clock::time_point to,
    std::string_view what) {
  using rep = std::chrono::steady_clock::rep;
  const rep a = to.time_since_epoch().count();
  const rep b = from.time_since_epoch().count();
  if (b > 0 ? a < std::numeric_limits<rep>::min() + b : a > std::numeric_limits<rep>::max() + b)
    detail::fail(what, ": the time from tick ", from.time_since_epoch().count(), " to tick ",
                 to.time_since_epoch().count(),
                 " of the steady clock does not fit its 64-bit count; expected timestamps of "
                 "one clock, less than 292 years apart — one of them is corrupt or unset");
  return std::chrono::steady_clock::duration(a - b);
}

namespace detail {

/// The object plane of the Omni with the object lying on the table, seen from above with the
/// device at the far edge of the map: device +x (right) is map x, device +z (toward the user) is
/// map y (down the image).
[[nodiscard]] inline Eigen::Matrix<double, 2, 3> horizontal_plane_axes() {
  Eigen::Matrix<double, 2, 3> a;
  a << 1.0, 0.0, 0.0, 0.0, 0.0, 1.0;
  return a;
}

}  // namespace detail

/// The planar map from a source's device frame to the map frame (see the file comment).
struct map_calibration {
  /// Rows u and v: orthonormal device-frame directions spanning the object's plane; u becomes
  /// the map's x axis and v its y axis before `rotation_rad` is applied.
  Eigen::Matrix<double, 2, 3> plane_axes = detail::horizontal_plane_axes();
  double rotation_rad = 0.0;                                 ///< in-plane rotation, from x toward y
  Eigen::Vector2d translation_mm = Eigen::Vector2d::Zero();  ///< map position of the device origin
  double scale = 1.0;  ///< map mm per device mm (corrects a device's scale error; normally 1)

  /// Object lying flat under a Phantom Omni (device +y up): u = +x, v = +z.
  [[nodiscard]] static map_calibration horizontal(
      double rotation_rad = 0.0, Eigen::Vector2d translation_mm = Eigen::Vector2d::Zero(),
      double scale = 1.0) {
    return {detail::horizontal_plane_axes(), rotation_rad, std::move(translation_mm), scale};
  }

  /// Object standing upright, facing the user (device +z toward the user): u = +x, v = -y
  /// (the device's y points up, the map's y down).
  [[nodiscard]] static map_calibration vertical(
      double rotation_rad = 0.0, Eigen::Vector2d translation_mm = Eigen::Vector2d::Zero(),
      double scale = 1.0) {
    Eigen::Matrix<double, 2, 3> a;
    a << 1.0, 0.0, 0.0, 0.0, -1.0, 0.0;
    return {a, rotation_rad, std::move(translation_mm), scale};
  }

  /// Calibration from two reference points: the sensor was placed at map points `map_a` and
  /// `map_b` (mm) and the source reported `device_a` and `device_b` there. Rotation and
  /// translation always come from the points; the scale too when `fit_scale`, else it is 1.
  /// Throws std::invalid_argument when the points are not finite or (in the plane) less than
  /// 1 mm apart, or when the axes are not orthonormal.
  [[nodiscard]] static map_calibration from_two_points(
      const Eigen::Matrix<double, 2, 3>& plane_axes, const Eigen::Vector3d& device_a,
      const Eigen::Vector2d& map_a, const Eigen::Vector3d& device_b, const Eigen::Vector2d& map_b,
      bool fit_scale = false) {
    map_calibration c;
    c.plane_axes = plane_axes;
    c.validate();
    if (!(detail::all_finite(device_a) && detail::all_finite(device_b) &&
          detail::all_finite(map_a) && detail::all_finite(map_b)))
      detail::fail(
          "map_calibration::from_two_points: the reference points are not all finite; "
          "expected device positions and map points in millimetres");
    const Eigen::Vector2d pa = plane_axes * device_a;
    const Eigen::Vector2d pb = plane_axes * device_b;
    const Eigen::Vector2d d_dev = pb - pa;
    const Eigen::Vector2d d_map = map_b - map_a;
    if (d_dev.norm() < 1.0 || d_map.norm() < 1.0)
      detail::fail("map_calibration::from_two_points: the reference points are ", d_dev.norm(),
                   " mm apart in the device's object plane and ", d_map.norm(),
                   " mm apart on the map; expected at least 1 mm (better: most of the map) — "
                   "touch two distant points, and check that plane_axes span the object's plane");
    c.rotation_rad =
        detail::wrap_angle(std::atan2(d_map.y(), d_map.x()) - std::atan2(d_dev.y(), d_dev.x()));
    c.scale = fit_scale ? d_map.norm() / d_dev.norm() : 1.0;
    c.translation_mm = map_a - c.scale * c.rotation() * pa;
    return c;
  }

  /// The in-plane rotation matrix R(rotation_rad).
  [[nodiscard]] Eigen::Matrix2d rotation() const {
    const double c = std::cos(rotation_rad);
    const double s = std::sin(rotation_rad);
    Eigen::Matrix2d r;
    r << c, -s, s, c;
    return r;
  }

  /// Throws std::invalid_argument naming the field unless the calibration is usable.
  void validate() const {
    if (!detail::all_finite(plane_axes))
      detail::fail(
          "map_calibration: plane_axes contain NaN or infinity; expected two orthonormal "
          "device-frame directions (rows u and v)");
    const Eigen::Matrix2d gram = plane_axes * plane_axes.transpose();
    if (!gram.isApprox(Eigen::Matrix2d::Identity(), 1e-6))
      detail::fail(
          "map_calibration: plane_axes rows are not orthonormal (|u| = ", plane_axes.row(0).norm(),
          ", |v| = ", plane_axes.row(1).norm(), ", u.v = ", gram(0, 1),
          "); expected two perpendicular unit vectors spanning the object's plane, e.g. "
          "map_calibration::horizontal() for an object lying under a Phantom Omni");
    if (!std::isfinite(rotation_rad))
      detail::fail("map_calibration: rotation_rad = ", rotation_rad, "; expected a finite angle");
    if (!detail::all_finite(translation_mm))
      detail::fail("map_calibration: translation_mm = (", translation_mm.x(), ", ",
                   translation_mm.y(), "); expected finite millimetres");
    if (!(std::isfinite(scale) && scale > 0.0))
      detail::fail("map_calibration: scale = ", scale,
                   "; expected a finite factor > 0 (map mm per device mm; normally 1)");
  }

  /// A device-frame displacement (mm) as a map-frame displacement (mm).
  [[nodiscard]] Eigen::Vector2d displacement_to_map_mm(const Eigen::Vector3d& d) const {
    return scale * (rotation() * (plane_axes * d));
  }

  /// A device-frame position (mm) as a map-frame position (mm).
  [[nodiscard]] Eigen::Vector2d to_map_mm(const Eigen::Vector3d& p) const {
    return translation_mm + displacement_to_map_mm(p);
  }
  [[nodiscard]] Eigen::Vector2d to_map_mm(const sensor_pose& pose) const {
    return to_map_mm(pose.position_mm());
  }

  /// The device-frame point (mm) over map point `map_mm`, `height_mm` above the object's
  /// surface — along v x u, the side the map is seen from (the inverse of `to_map_mm` in the
  /// plane; for simulations, and to tell a user where to put the stylus).
  [[nodiscard]] Eigen::Vector3d to_device_mm(const Eigen::Vector2d& map_mm,
                                             double height_mm = 0.0) const {
    const Eigen::Vector2d plane = rotation().transpose() * ((map_mm - translation_mm) / scale);
    const Eigen::Vector3d u = plane_axes.row(0).transpose();
    const Eigen::Vector3d v = plane_axes.row(1).transpose();
    const Eigen::Vector3d up(v.y() * u.z() - v.z() * u.y(), v.z() * u.x() - v.x() * u.z(),
                             v.x() * u.y() - v.y() * u.x());  // v x u (no <Eigen/Geometry>)
    return plane_axes.transpose() * plane + height_mm * up;
  }

  /// The heading (rad, from u toward v) of a device-frame direction projected into the object's
  /// plane; nothing when the direction is within about 6 degrees of the plane's normal, where the
  /// heading is meaningless.
  [[nodiscard]] std::optional<double> plane_heading(const Eigen::Vector3d& direction) const {
    const Eigen::Vector2d in_plane = plane_axes * direction;
    const double length = direction.norm();
    if (!(std::isfinite(length) && length > 0.0) || in_plane.norm() < 0.1 * length)
      return std::nullopt;
    return std::atan2(in_plane.y(), in_plane.x());
  }

  friend bool operator==(const map_calibration&, const map_calibration&) = default;
};

/// How the sensor moved between two poses, in the map frame.
struct pose_change {
  double dx_mm = 0.0;     ///< along the map's x (columns)
  double dy_mm = 0.0;     ///< along the map's y (rows)
  double dyaw_rad = 0.0;  ///< heading change in (-pi, pi], positive from map x toward map y
  std::chrono::steady_clock::duration elapsed{};  ///< b.timestamp - a.timestamp

  /// The control of the paper's motion model (`odometry_gaussian`): the planar displacement.
  [[nodiscard]] odometry control() const { return {dx_mm, dy_mm}; }
  /// Planar distance travelled, mm.
  [[nodiscard]] double distance_mm() const { return std::hypot(dx_mm, dy_mm); }
};

/// The odometry from pose `a` to pose `b` (both in the device frame) in the map frame: the
/// displacement of the sensor centre and the change of heading (Sec.\ III-B: the control u_t).
/// Throws std::invalid_argument for a non-finite pose or an invalid calibration.
[[nodiscard]] inline pose_change odometry_between(const sensor_pose& a, const sensor_pose& b,
                                                  const map_calibration& calibration) {
  calibration.validate();
  for (const sensor_pose* p : {&a, &b})
    if (!p->finite())
      detail::fail("odometry_between: pose ", p == &a ? "a" : "b", " = (", p->x_mm, ", ", p->y_mm,
                   ", ", p->z_mm, " mm, yaw ", p->yaw_rad,
                   " rad); expected finite values — the position source delivered an invalid "
                   "sample");
  const Eigen::Vector2d d = calibration.displacement_to_map_mm(b.position_mm() - a.position_mm());
  return {d.x(), d.y(), detail::wrap_angle(b.yaw_rad - a.yaw_rad),
          checked_elapsed(a.timestamp, b.timestamp, "odometry_between")};
}

/// A finite position source that hands out a fixed list of poses in order, then nothing:
/// for tests, demos and scripted runs.
class scripted_position_source {
 public:
  scripted_position_source() = default;

  /// Throws std::invalid_argument naming the first pose that is not finite.
  explicit scripted_position_source(std::vector<sensor_pose> poses) : poses_(std::move(poses)) {
    for (std::size_t i = 0; i < poses_.size(); ++i)
      if (!poses_[i].finite())
        detail::fail("scripted_position_source: pose ", i, " = (", poses_[i].x_mm, ", ",
                     poses_[i].y_mm, ", ", poses_[i].z_mm, " mm, yaw ", poses_[i].yaw_rad,
                     " rad); expected finite values");
  }

  /// The next scripted pose (never waits), or nothing once the script is exhausted.
  std::optional<sensor_pose> next_pose(std::chrono::milliseconds /*timeout*/ = {}) {
    if (next_ >= poses_.size()) return std::nullopt;
    return poses_[next_++];
  }

  [[nodiscard]] std::size_t remaining() const { return poses_.size() - next_; }
  [[nodiscard]] std::size_t size() const { return poses_.size(); }

 private:
  std::vector<sensor_pose> poses_;
  std::size_t next_ = 0;
};

static_assert(position_source<scripted_position_source>);

}  // namespace tacmap
