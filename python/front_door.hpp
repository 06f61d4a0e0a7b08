// tacmap's Python module: what the two front doors' bindings share (localizer.cpp: Localizer;
// library.cpp: LibraryLocalizer) — frames, bursts, motions and next-touch candidates read from
// Python objects with errors that name the argument, and the localizers' mutex.
//
// Included after bindings.hpp (which defines TACMAP_ASSERT for the tacmap headers).
#pragma once

#include <array>
#include <cmath>
#include <mutex>
#include <numbers>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "bindings.hpp"
#include "tacmap/localizer.hpp"

namespace tacmap::python {

/// TouchResult.rejection and LibraryTouchResult.rejection.
inline const choices<frame_rejection> rejection_names = {
    {"none", frame_rejection::none},
    {"weak_peak", frame_rejection::weak_peak},
    {"weak_total", frame_rejection::weak_total},
    {"flat", frame_rejection::flat}};

/// repr() of a float: "0.2", "nan".
inline std::string number(double v) { return py::repr(py::float_(v)); }

/// A C++ front door and the lock that makes it safe to share between threads. The C++ objects
/// are not thread-safe; the Python ones release the GIL during touches, so two Python threads
/// could otherwise run one localizer at once. Every method takes the mutex with the GIL
/// released (never the other way round, so no deadlock).
template <class Impl>
struct locked_front_door {
  template <class... Args>
  explicit locked_front_door(Args&&... args) : impl(std::forward<Args>(args)...) {}
  Impl impl;
  std::mutex mutex;
};

/// Runs f(impl) with the GIL released and the lock held. f must not touch Python objects.
template <class Impl, class F>
auto locked(locked_front_door<Impl>& self, F&& f) {
  py::gil_scoped_release release;
  const std::lock_guard<std::mutex> lock(self.mutex);
  return f(self.impl);
}

/// The members Localizer and LibraryLocalizer share, bound on `cls` (a py::class_ of `Holder`,
/// a locked_front_door): touches, restarts, warnings, sensor_calibration,
/// reset_sensor_calibration and sensor. `restarts_doc` says what a restart goes back to.
template <class Holder, class PyClass>
void def_front_door_members(PyClass& cls, const char* restarts_doc) {
  cls.def_property_readonly(
         "touches",
         [](Holder& self) { return locked(self, [](auto& loc) { return loc.touches(); }); },
         "Touches used (accepted frames) since construction or reset().")
      .def_property_readonly(
          "restarts",
          [](Holder& self) { return locked(self, [](auto& loc) { return loc.restarts(); }); },
          restarts_doc)
      .def_property_readonly(
          "warnings",
          [](Holder& self) {
            return std::vector<std::string>(self.impl.warnings().begin(),
                                            self.impl.warnings().end());
          },
          "What the localizer could not do as well as it should, in words (a list of str, "
          "from construction): e.g. a photograph coarser than the working resolution and what "
          "that costs in accuracy. Empty when nothing is amiss; tacmap prints nothing, show "
          "them to the user.")
      .def_property_readonly(
          "sensor_calibration",
          [](Holder& self) -> std::optional<self_calibration> {
            return locked(self, [](auto& loc) -> std::optional<self_calibration> {
              if (const self_calibration* c = loc.sensor_calibration()) return *c;
              return std::nullopt;
            });
          },
          "The sensor's self-calibration (a SensorCalibration copy), or None when "
          "config.calibrate_sensor is off.")
      .def(
          "reset_sensor_calibration",
          [](Holder& self) { locked(self, [](auto& loc) { loc.reset_sensor_calibration(); }); },
          "Forgets what the self-calibration learnt (a new or repaired sensor); reset() keeps "
          "it.");
}

inline std::string sensor_shape(const taxel_geometry& s, const char* owner) {
  return "(" + std::to_string(s.rows) + ", " + std::to_string(s.cols) + ") (the " + owner +
         "'s sensor: " + std::to_string(s.rows) + " x " + std::to_string(s.cols) + " taxels)";
}

/// A Frame (copied: another thread may write to its counts while the GIL is released) or a 2-D
/// array of counts for `sensor`.
inline tactile_frame frame_of(const taxel_geometry& sensor, const py::handle& obj,
                              const std::string& what, const char* owner) {
  if (py::isinstance<tactile_frame>(obj)) return obj.cast<tactile_frame>();
  tactile_frame f;
  f.geometry = sensor;
  f.counts = to_image(obj, what, sensor_shape(sensor, owner), sensor.rows, sensor.cols);
  return f;
}

/// A burst: a sequence of Frames or 2-D arrays, or a 3-D array (frames, rows, cols). `who`
/// names the call in errors ("Localizer.touch_burst"), frame k as "<who>: frame k".
inline std::vector<tactile_frame> burst_of(const taxel_geometry& sensor, const py::object& frames,
                                           const std::string& who, const char* owner) {
  if (py::isinstance<tactile_frame>(frames) || py::isinstance<py::str>(frames) ||
      !py::isinstance<py::iterable>(frames))
    throw py::type_error(who + ": frames is a " +
                         std::string(py::str(py::type::of(frames).attr("__name__"))) +
                         "; expected a sequence of Frames or 2-D arrays, or a 3-D array (frames, "
                         "rows, cols)");
  std::vector<tactile_frame> burst;
  for (const py::handle f : frames)
    burst.push_back(frame_of(sensor, f, who + ": frame " + std::to_string(burst.size()), owner));
  return burst;
}

using motion = std::variant<std::monostate, odometry, sensor_odometry>;

/// None, (dx_mm, dy_mm) in the map's frame or (du_mm, dv_mm, dtheta_rad) in the sensor's.
inline motion motion_of(const py::object& moved, const std::string& what) {
  if (moved.is_none()) return {};
  const std::string expected =
      "None (no motion since the previous touch), (dx_mm, dy_mm) in the map's frame or "
      "(du_mm, dv_mm, dtheta_rad) in the sensor's";
  if (py::isinstance<py::str>(moved) || PySequence_Check(moved.ptr()) == 0)
    throw py::type_error(what + ": got " +
                         std::string(py::str(py::type::of(moved).attr("__name__"))) +
                         "; expected " + expected);
  const auto seq = py::reinterpret_borrow<py::sequence>(moved);
  const auto n = py::len(seq);
  if (n != 2 && n != 3)
    throw py::value_error(what + ": " + std::to_string(n) + " values (" +
                          std::string(py::repr(moved)) + "); expected " + expected);
  std::array<double, 3> v{};
  for (std::size_t k = 0; k < n; ++k) {
    try {
      v[k] = py::float_(seq[k]);
    } catch (py::error_already_set&) {
      throw py::type_error(what + ": element " + std::to_string(k) + " = " +
                           std::string(py::repr(seq[k])) + " is not a number; expected " +
                           expected);
    }
  }
  if (n == 2) return odometry{.dx_mm = v[0], .dy_mm = v[1]};
  return sensor_odometry{.du_mm = v[0], .dv_mm = v[1], .dtheta_rad = v[2]};
}

/// Next-touch candidates, an (N, 2) array or a sequence of (dx_mm, dy_mm), as moves.
inline std::vector<odometry> candidates_of(const py::object& candidates, const std::string& what) {
  // ensure() gives an empty handle (the Python error cleared) for what numpy cannot convert.
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(candidates);
  if (!a || a.ndim() != 2 || a.shape(1) != 2)
    throw py::value_error(what +
                          ": candidates must be moves (dx_mm, dy_mm): an (N, 2) "
                          "array or a sequence of pairs");
  std::vector<odometry> moves;
  moves.reserve(static_cast<std::size_t>(a.shape(0)));
  for (py::ssize_t i = 0; i < a.shape(0); ++i)
    moves.push_back({.dx_mm = a.at(i, 0), .dy_mm = a.at(i, 1)});
  return moves;
}

/// Moves as a new (N, 2) numpy array of (dx_mm, dy_mm).
inline py::array_t<double> moves_to_numpy(const std::vector<odometry>& moves) {
  py::array_t<double> out({static_cast<py::ssize_t>(moves.size()), py::ssize_t{2}});
  auto a = out.mutable_unchecked<2>();
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    a(i, 0) = moves[static_cast<std::size_t>(i)].dx_mm;
    a(i, 1) = moves[static_cast<std::size_t>(i)].dy_mm;
  }
  return out;
}

/// next_touch's keyword arguments as C++ parameters.
inline next_touch_params next_touch_params_of(int hypotheses, const std::string& objective,
                                              const std::string& what) {
  next_touch_params params{.hypotheses = hypotheses};
  if (objective == "verdict")
    params.objective = next_touch_objective::verdict;
  else if (objective == "entropy")
    params.objective = next_touch_objective::entropy;
  else
    throw py::value_error(what + ": objective = '" + objective +
                          "'; expected 'entropy' or 'verdict'");
  return params;
}

}  // namespace tacmap::python
