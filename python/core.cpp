// tacmap's Python module: the small value types everything else passes around — the sensor's
// geometry, a tactile frame, a burst of frames combined into one, a device pose and the device ->
// map calibration.
#include "bindings.hpp"
// (bindings.hpp first: it defines TACMAP_ASSERT for the tacmap headers below.)

#include <chrono>
#include <cstdint>

#include "tacmap/devices/position_source.hpp"
#include "tacmap/tactile/burst.hpp"
#include "tacmap/tactile/frame.hpp"

namespace tacmap::python {

namespace {

std::int64_t to_ns(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
}

std::chrono::steady_clock::time_point from_ns(std::int64_t ns) {
  return std::chrono::steady_clock::time_point(
      std::chrono::duration_cast<std::chrono::steady_clock::duration>(
          std::chrono::nanoseconds(ns)));
}

std::string number(double v) { return py::repr(py::float_(v)); }

std::string geometry_repr(const taxel_geometry& g) {
  return "TaxelGeometry(rows=" + std::to_string(g.rows) + ", cols=" + std::to_string(g.cols) +
         ", pitch_mm=" + number(g.pitch_mm) + ")";
}

// A (rows, cols) float32 view of a frame's counts that keeps the Python Frame alive. Safe
// because a Frame's counts are never reallocated after construction (the setter copies into
// them), so the view cannot dangle.
py::array_t<float> counts_view(py::object self) {
  auto& f = self.cast<tactile_frame&>();
  const auto rows = static_cast<py::ssize_t>(f.counts.rows());
  const auto cols = static_cast<py::ssize_t>(f.counts.cols());
  const auto item = static_cast<py::ssize_t>(sizeof(float));
  return py::array_t<float>({rows, cols}, {cols * item, item}, f.counts.data(), self);
}

}  // namespace

void bind_core(py::module_& m) {
  // ---- TaxelGeometry ----
  py::class_<taxel_geometry>(m, "TaxelGeometry",
                             "The layout of a tactile array: taxel rows x columns and the "
                             "centre-to-centre pitch (C++ tacmap::taxel_geometry). The default is "
                             "the paper's Weiss array: 14 x 6 taxels at 3.4 mm.")
      .def(py::init([](Eigen::Index rows, Eigen::Index cols, double pitch_mm) {
             taxel_geometry g{rows, cols, pitch_mm};
             g.validate();
             return g;
           }),
           py::arg("rows") = taxel_geometry{}.rows, py::arg("cols") = taxel_geometry{}.cols,
           py::arg("pitch_mm") = taxel_geometry{}.pitch_mm,
           "Raises ValueError unless rows and cols are > 0 and pitch_mm is a finite pitch > 0.")
      .def_readwrite("rows", &taxel_geometry::rows,
                     "Taxels along the sensor's long side (y on the map).")
      .def_readwrite("cols", &taxel_geometry::cols, "Taxels across (x on the map).")
      .def_readwrite("pitch_mm", &taxel_geometry::pitch_mm,
                     "Cell pitch in millimetres (Weiss DSA 9205 / WTS 0614-34A: 3.4).")
      .def_property_readonly(
          "shape", [](const taxel_geometry& g) { return py::make_tuple(g.rows, g.cols); },
          "(rows, cols): the shape of a frame's counts.")
      .def("validate", &taxel_geometry::validate,
           "Raises ValueError naming the offending field unless the geometry is usable.")
      .def(py::self == py::self)  // NOLINT(misc-redundant-expression)
      .def("__repr__", &geometry_repr);

  // ---- Frame ----
  py::class_<tactile_frame>(
      m, "Frame",
      "One tactile frame (C++ tacmap::tactile_frame): raw counts as the sensor reports them "
      "(rows x cols, row-major; 12-bit for Weiss arrays), the time it was sampled and the "
      "source's running frame number. Counts are kept in float32, so simulated, recorded and "
      "live frames share one type.\n\n"
      "numpy.asarray(frame) gives the counts; Localizer.touch takes a Frame or a plain array.")
      .def(py::init([](const py::object& counts, std::optional<double> pitch_mm,
                       std::optional<taxel_geometry> geometry, std::int64_t timestamp_ns,
                       std::uint32_t sequence) {
             tactile_frame f;
             if (geometry) {
               geometry->validate();
               f.geometry = *geometry;
               if (pitch_mm)
                 throw py::value_error(
                     "Frame: both geometry and pitch_mm given; expected one of them (the "
                     "geometry holds the pitch)");
               const std::string shape = "(" + std::to_string(geometry->rows) + ", " +
                                         std::to_string(geometry->cols) + ") (the geometry's)";
               f.counts = to_image(counts, "Frame: counts", shape, geometry->rows, geometry->cols);
             } else {
               f.counts = to_image(counts, "Frame: counts", "(rows, cols)");
               f.geometry = {f.counts.rows(), f.counts.cols(),
                             pitch_mm.value_or(taxel_geometry{}.pitch_mm)};
               f.geometry.validate();
             }
             f.timestamp = from_ns(timestamp_ns);
             f.sequence = sequence;
             f.validate();
             return f;
           }),
           py::arg("counts"), py::kw_only(), py::arg("pitch_mm") = py::none(),
           py::arg("geometry") = py::none(), py::arg("timestamp_ns") = 0, py::arg("sequence") = 0,
           "A frame of `counts` (a 2-D array of finite counts >= 0, any real dtype, copied). "
           "The geometry is the counts' shape at `pitch_mm` (default 3.4 mm), or `geometry` "
           "(then the counts must have its shape). Raises TypeError or ValueError naming what "
           "is wrong.")
      .def_property(
          "counts", &counts_view,
          [](tactile_frame& f, const py::object& value) {
            const std::string shape = "(" + std::to_string(f.counts.rows()) + ", " +
                                      std::to_string(f.counts.cols()) + ") (the frame's geometry)";
            const image<float> c =
                to_image(value, "Frame.counts", shape, f.counts.rows(), f.counts.cols());
            f.counts = c;  // same size: copied into the existing storage, views stay valid
          },
          "The raw counts, a (rows, cols) float32 array viewing the frame's own storage "
          "(writing to it changes the frame). Assigning copies an array of the same shape in.")
      .def_property_readonly(
          "geometry", [](const tactile_frame& f) { return f.geometry; },
          "The taxel layout (a copy: the geometry is fixed with the counts' shape).")
      .def_property(
          "timestamp_ns", [](const tactile_frame& f) { return to_ns(f.timestamp); },
          [](tactile_frame& f, std::int64_t ns) { f.timestamp = from_ns(ns); },
          "When the frame was sampled: integer nanoseconds of the source's steady clock (an "
          "arbitrary epoch: only differences mean something).")
      .def_readwrite("sequence", &tactile_frame::sequence,
                     "Running frame number from the source, when it has one.")
      .def("validate", &tactile_frame::validate,
           "Raises ValueError unless the counts match the geometry and are finite and >= 0.")
      .def(
          "__array__",
          [](py::object self, py::object dtype, py::object copy) {
            py::object a = counts_view(self);
            if (!dtype.is_none()) a = a.attr("astype")(dtype);
            if (!copy.is_none() && copy.cast<bool>()) a = a.attr("copy")();
            return a;
          },
          py::arg("dtype") = py::none(), py::arg("copy") = py::none(),
          "The counts (numpy protocol): numpy.asarray(frame).")
      .def("__repr__", [](const tactile_frame& f) {
        return "Frame(" + std::to_string(f.counts.rows()) + " x " +
               std::to_string(f.counts.cols()) + " taxels at " + number(f.geometry.pitch_mm) +
               " mm, timestamp_ns=" + std::to_string(to_ns(f.timestamp)) +
               ", sequence=" + std::to_string(f.sequence) + ", peak=" +
               number(f.counts.size() > 0 ? static_cast<double>(f.counts.maxCoeff()) : 0.0) + ")";
      });

  // ---- combine_burst ----
  py::class_<combined_burst>(m, "CombinedBurst",
                             "A burst of frames of one press combined into one frame "
                             "(combine_burst).")
      .def_readonly("frame", &combined_burst::frame,
                    "The combined Frame: the per-taxel statistic of the frames used.")
      .def_property_readonly(
          "status",
          [](const combined_burst& b) {
            std::vector<std::string> out;
            for (const auto s : b.status) out.emplace_back(to_string(s));
            return out;
          },
          "One string per frame of the burst, in order: 'used', 'settling' (before the press "
          "settled) or 'outlier' (its total far from the settled level).")
      .def_readonly("settled_total", &combined_burst::settled_total,
                    "The settled level: median total counts of the burst's second half.")
      .def_readonly("used", &combined_burst::used, "Frames combined (at least 1).")
      .def("__repr__", [](const combined_burst& b) {
        return "CombinedBurst(used=" + std::to_string(b.used) + " of " +
               std::to_string(b.status.size()) +
               " frames, settled_total=" + number(b.settled_total) + ")";
      });
  m.def(
      "combine_burst",
      [m](const py::sequence& frames, double settle_tolerance, double outlier_tolerance,
          const std::string& statistic, double trim_fraction) {
        burst_params p;
        p.settle_tolerance = settle_tolerance;
        p.outlier_tolerance = outlier_tolerance;
        p.trim_fraction = trim_fraction;
        if (statistic == "median")
          p.statistic = burst_statistic::median;
        else if (statistic == "trimmed_mean")
          p.statistic = burst_statistic::trimmed_mean;
        else
          throw py::value_error("combine_burst: statistic = '" + statistic +
                                "'; expected 'median' or 'trimmed_mean'");
        std::vector<tactile_frame> burst;
        burst.reserve(frames.size());
        const py::object frame_type = m.attr("Frame");
        for (const auto& item : frames) {
          // A Frame, or anything Frame() takes (a 2-D array of counts).
          const py::object f = py::isinstance(item, frame_type)
                                   ? py::reinterpret_borrow<py::object>(item)
                                   : frame_type(item);
          burst.push_back(f.cast<const tactile_frame&>());
        }
        py::gil_scoped_release release;
        return combine_burst(burst, p);
      },
      py::arg("frames"), py::arg("settle_tolerance") = burst_params{}.settle_tolerance,
      py::arg("outlier_tolerance") = burst_params{}.outlier_tolerance,
      py::arg("statistic") = "median", py::arg("trim_fraction") = burst_params{}.trim_fraction,
      "Combines a burst of frames of one press (Frames or 2-D arrays of counts) into one "
      "(C++ tacmap::combine_burst; tactile/burst.hpp): drops the settling head (frames before "
      "the first whose total is within settle_tolerance of the settled level, the median total "
      "of the burst's second half) and outlier frames (total off by more than "
      "outlier_tolerance), then takes the per-taxel median or trimmed mean. Raises ValueError "
      "for an empty burst or frames of different geometry (naming the frame).");

  // ---- Pose ----
  py::class_<sensor_pose>(m, "Pose",
                          "Where the sensor centre is, in the position source's device frame "
                          "(mm), and when it was there (C++ tacmap::sensor_pose).")
      .def(py::init([](double x, double y, double z, double yaw, std::int64_t ns) {
             return sensor_pose{from_ns(ns), x, y, z, yaw};
           }),
           py::arg("x_mm") = 0.0, py::arg("y_mm") = 0.0, py::arg("z_mm") = 0.0,
           py::arg("yaw_rad") = 0.0, py::arg("timestamp_ns") = 0)
      .def_readwrite("x_mm", &sensor_pose::x_mm, "Sensor centre, device frame, mm.")
      .def_readwrite("y_mm", &sensor_pose::y_mm)
      .def_readwrite("z_mm", &sensor_pose::z_mm)
      .def_readwrite("yaw_rad", &sensor_pose::yaw_rad,
                     "Heading in the object's plane (radians, arbitrary zero: only changes are "
                     "used).")
      .def_property(
          "timestamp_ns", [](const sensor_pose& p) { return to_ns(p.timestamp); },
          [](sensor_pose& p, std::int64_t ns) { p.timestamp = from_ns(ns); },
          "When the source sampled the pose: integer nanoseconds of its steady clock.")
      .def_property_readonly(
          "position_mm", [](const sensor_pose& p) -> Eigen::Vector3d { return p.position_mm(); },
          "(x, y, z) as a numpy array, mm.")
      .def("finite", &sensor_pose::finite)
      .def(py::self == py::self)  // NOLINT(misc-redundant-expression)
      .def("__repr__", [](const sensor_pose& p) {
        return "Pose(x_mm=" + number(p.x_mm) + ", y_mm=" + number(p.y_mm) +
               ", z_mm=" + number(p.z_mm) + ", yaw_rad=" + number(p.yaw_rad) +
               ", timestamp_ns=" + std::to_string(to_ns(p.timestamp)) + ")";
      });

  // ---- MapCalibration ----
  py::class_<map_calibration>(
      m, "MapCalibration",
      "The planar map from a position source's device frame to the map frame (C++ "
      "tacmap::map_calibration):\n\n"
      "    map_mm = translation_mm + scale * R(rotation_rad) * [u . p ; v . p]\n\n"
      "u and v (the rows of plane_axes) are orthonormal device-frame directions spanning the "
      "object's plane; u becomes the map's x axis (right), v its y axis (down). The default is "
      "MapCalibration.horizontal(): an object lying flat under a Phantom Omni.")
      .def(py::init<>())
      .def_static("horizontal", &map_calibration::horizontal, py::arg("rotation_rad") = 0.0,
                  py::arg("translation_mm") = Eigen::Vector2d::Zero().eval(),
                  py::arg("scale") = 1.0,
                  "Object lying flat under a Phantom Omni (device +y up): u = +x, v = +z.")
      .def_static("vertical", &map_calibration::vertical, py::arg("rotation_rad") = 0.0,
                  py::arg("translation_mm") = Eigen::Vector2d::Zero().eval(),
                  py::arg("scale") = 1.0,
                  "Object standing upright, facing the user (device +z toward the user): u = +x, "
                  "v = -y.")
      .def_static("from_two_points", &map_calibration::from_two_points, py::arg("plane_axes"),
                  py::arg("device_a"), py::arg("map_a"), py::arg("device_b"), py::arg("map_b"),
                  py::arg("fit_scale") = false,
                  "Calibration from two reference points: the sensor was placed at map points "
                  "map_a and map_b (mm) and the source reported device_a and device_b there. "
                  "Raises ValueError when the points are not finite or less than 1 mm apart, or "
                  "when the axes are not orthonormal.")
      .def_property(
          "plane_axes",
          [](const map_calibration& c) -> Eigen::Matrix<double, 2, 3> { return c.plane_axes; },
          [](map_calibration& c, const Eigen::Matrix<double, 2, 3>& a) { c.plane_axes = a; },
          "(2, 3) array: rows u and v, orthonormal device-frame directions of the object's "
          "plane.")
      .def_readwrite("rotation_rad", &map_calibration::rotation_rad,
                     "In-plane rotation, from x toward y.")
      .def_property(
          "translation_mm",
          [](const map_calibration& c) -> Eigen::Vector2d { return c.translation_mm; },
          [](map_calibration& c, const Eigen::Vector2d& t) { c.translation_mm = t; },
          "Map position of the device origin, mm.")
      .def_readwrite("scale", &map_calibration::scale,
                     "Map mm per device mm (corrects a device's scale error; normally 1).")
      .def("validate", &map_calibration::validate,
           "Raises ValueError naming the field unless the calibration is usable.")
      .def(
          "to_map_mm",
          [](const map_calibration& c, const sensor_pose& p) -> Eigen::Vector2d {
            return c.to_map_mm(p);
          },
          py::arg("pose"), "A pose's position in the map frame, mm (numpy array (x, y)).")
      .def(
          "to_map_mm",
          [](const map_calibration& c, const Eigen::Vector3d& p) -> Eigen::Vector2d {
            return c.to_map_mm(p);
          },
          py::arg("position_mm"), "A device-frame position (x, y, z), mm, in the map frame.")
      .def(
          "displacement_to_map_mm",
          [](const map_calibration& c, const Eigen::Vector3d& d) -> Eigen::Vector2d {
            return c.displacement_to_map_mm(d);
          },
          py::arg("displacement_mm"),
          "A device-frame displacement (mm) as a map-frame displacement (mm).")
      .def(
          "to_device_mm",
          [](const map_calibration& c, const Eigen::Vector2d& map_mm,
             double height_mm) -> Eigen::Vector3d { return c.to_device_mm(map_mm, height_mm); },
          py::arg("map_mm"), py::arg("height_mm") = 0.0,
          "The device-frame point over map point map_mm, height_mm above the object's surface.")
      .def(py::self == py::self)  // NOLINT(misc-redundant-expression)
      .def("__repr__", [](const map_calibration& c) {
        return "MapCalibration(rotation_rad=" + number(c.rotation_rad) + ", translation_mm=(" +
               number(c.translation_mm.x()) + ", " + number(c.translation_mm.y()) +
               "), scale=" + number(c.scale) + ")";
      });

  // ---- odometry between two poses ----
  py::class_<pose_change>(m, "PoseChange",
                          "How the sensor moved between two poses, in the map frame (C++ "
                          "tacmap::pose_change).")
      .def_readonly("dx_mm", &pose_change::dx_mm, "Along the map's x (columns).")
      .def_readonly("dy_mm", &pose_change::dy_mm, "Along the map's y (rows).")
      .def_readonly("dyaw_rad", &pose_change::dyaw_rad,
                    "Heading change in (-pi, pi], positive from map x toward map y.")
      .def_property_readonly(
          "elapsed_ns",
          [](const pose_change& c) {
            return std::chrono::duration_cast<std::chrono::nanoseconds>(c.elapsed).count();
          },
          "b.timestamp - a.timestamp, ns.")
      .def(
          "control", [](const pose_change& c) { return vec2(c.dx_mm, c.dy_mm); },
          "The planar displacement (dx_mm, dy_mm) as a numpy array: what Localizer.touch takes "
          "as `moved` with a known heading.")
      .def("distance_mm", &pose_change::distance_mm, "Planar distance travelled, mm.")
      .def("__repr__", [](const pose_change& c) {
        return "PoseChange(dx_mm=" + number(c.dx_mm) + ", dy_mm=" + number(c.dy_mm) +
               ", dyaw_rad=" + number(c.dyaw_rad) + ")";
      });
  m.def("odometry_between", &odometry_between, py::arg("a"), py::arg("b"), py::arg("calibration"),
        "The odometry from pose a to pose b (both in the device frame) in the map frame: the "
        "displacement of the sensor centre and the change of heading (the paper's control u_t, "
        "Sec. III-B). Raises ValueError for a non-finite pose or an invalid calibration.");
}

}  // namespace tacmap::python
