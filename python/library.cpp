// tacmap's Python module: the library front door — `LibraryLocalizer` (which object, and
// where) and what a touch on a library returns (C++ include/tacmap/library_localizer.hpp).
#include "bindings.hpp"
// (bindings.hpp first: it defines TACMAP_ASSERT for the tacmap headers below.)
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "front_door.hpp"
#include "tacmap/executor/thread_pool.hpp"
#include "tacmap/library_localizer.hpp"

namespace tacmap::python {

namespace {

// The C++ library localizer, its lock, and what the Python one adds: the maps' names and own
// scales.
struct py_library : locked_front_door<library_localizer> {
  py_library(const std::vector<library_map>& maps, localizer_config config, taxel_geometry geometry,
             std::vector<double> prior, std::optional<double> mm_per_px, executor_ref executor)
      : locked_front_door<library_localizer>(maps, std::move(config), geometry, std::move(prior),
                                             mm_per_px, configured_models{}, executor),
        sensor(geometry) {
    for (const library_map& m : maps) {
      names.push_back(m.name);
      photo_mm_per_px.push_back(m.mm_per_px);
    }
  }
  taxel_geometry sensor;  // the C++ library keeps it private
  std::vector<std::string> names;
  std::vector<double> photo_mm_per_px;
};

constexpr const char* owner = "library";

// One entry of the maps argument: (name, map, mm_per_px) as a library_map. `where` names it
// ("maps[2]" or "maps['mug']").
library_map library_map_of(const py::handle& name, const py::handle& map,
                           const py::handle& mm_per_px, const std::string& where) {
  if (!py::isinstance<py::str>(name))
    throw py::type_error("LibraryLocalizer: " + where + ": the name is a " +
                         std::string(py::str(py::type::of(name).attr("__name__"))) +
                         "; expected a str naming the object");
  library_map out;
  out.name = name.cast<std::string>();
  if (out.name.empty())
    throw py::value_error("LibraryLocalizer: " + where +
                          ": the name is empty; expected a short name for the object");
  out.map = to_image(map, "LibraryLocalizer: the map of '" + out.name + "' (" + where + ")",
                     "(rows, cols)");
  const auto not_a_number = [&] {
    return py::type_error("LibraryLocalizer: mm_per_px = " + std::string(py::repr(mm_per_px)) +
                          " for '" + out.name + "' (" + where +
                          ") is not a number; expected the map's scale in millimetres per pixel");
  };
  if (py::isinstance<py::str>(mm_per_px) || py::isinstance<py::bytes>(mm_per_px) ||
      mm_per_px.is_none())
    throw not_a_number();
  try {
    out.mm_per_px = py::float_(py::reinterpret_borrow<py::object>(mm_per_px));
  } catch (py::error_already_set&) {
    throw not_a_number();
  }
  return out;  // the values (finite, positive scale; a usable map) are checked in C++
}

// The maps argument: a dict {name: (map, mm_per_px)} or a sequence of (name, map, mm_per_px).
std::vector<library_map> library_maps_of(const py::object& maps) {
  const std::string expected =
      "a sequence of (name, map, mm_per_px) or a dict {name: (map, mm_per_px)}, one entry per "
      "object";
  std::vector<library_map> out;
  const auto pair_of = [&](const py::handle& entry, std::size_t n, const std::string& where) {
    if (py::isinstance<py::str>(entry) || PySequence_Check(entry.ptr()) == 0 || py::len(entry) != n)
      throw py::value_error("LibraryLocalizer: " + where + " is a " +
                            std::string(py::str(py::type::of(entry).attr("__name__"))) +
                            (PySequence_Check(entry.ptr()) != 0 && !py::isinstance<py::str>(entry)
                                 ? " of " + std::to_string(py::len(entry)) + " values"
                                 : std::string()) +
                            "; expected " +
                            (n == 3 ? "(name, map, mm_per_px)" : "(map, mm_per_px)"));
    return py::reinterpret_borrow<py::sequence>(entry);
  };
  if (py::isinstance<py::dict>(maps)) {
    for (const auto& [key, value] : py::reinterpret_borrow<py::dict>(maps)) {
      const std::string where = "maps[" + std::string(py::repr(key)) + "]";
      const py::sequence v = pair_of(value, 2, where);
      out.push_back(library_map_of(key, v[0], v[1], where));
    }
  } else if (py::isinstance<py::str>(maps) || !py::isinstance<py::iterable>(maps)) {
    throw py::type_error("LibraryLocalizer: maps is a " +
                         std::string(py::str(py::type::of(maps).attr("__name__"))) + "; expected " +
                         expected);
  } else {
    for (const py::handle entry : maps) {
      const std::string where = "maps[" + std::to_string(out.size()) + "]";
      const py::sequence v = pair_of(entry, 3, where);
      out.push_back(library_map_of(v[0], v[1], v[2], where));
    }
  }
  // Names first, before any map is prepared (C++ checks them too, once every map is ready).
  for (std::size_t k = 0; k < out.size(); ++k)
    for (std::size_t j = 0; j < k; ++j)
      if (out[j].name == out[k].name)
        throw py::value_error("LibraryLocalizer: objects " + std::to_string(j) + " and " +
                              std::to_string(k) + " are both named '" + out[k].name +
                              "'; expected one distinct name per object");
  return out;
}

// Object `k` of the library, given as an index or a name.
Eigen::Index object_of(const py_library& self, const py::object& k, const std::string& what) {
  const auto n = static_cast<Eigen::Index>(self.names.size());
  if (py::isinstance<py::str>(k)) {
    const std::string name = k.cast<std::string>();
    for (Eigen::Index i = 0; i < n; ++i)
      if (self.names[static_cast<std::size_t>(i)] == name) return i;
    std::string list;
    for (std::size_t i = 0; i < self.names.size(); ++i)
      list += (i > 0 ? ", '" : "'") + self.names[i] + "'";
    throw py::key_error(what + ": no object named '" + name + "'; the library has " + list);
  }
  if (py::isinstance<py::bool_>(k) || PyIndex_Check(k.ptr()) == 0)
    throw py::type_error(what + ": object " + std::string(py::repr(k)) +
                         "; expected an index (int) or a name (str)");
  const auto i = k.cast<Eigen::Index>();
  if (i < 0 || i >= n)
    throw py::index_error(what + ": object " + std::to_string(i) + "; expected 0 .. " +
                          std::to_string(n - 1) + " (the library's objects)");
  return i;
}

// touch(moved) of a motion given from Python: none, (dx, dy), or (du, dv, 0) (a known heading:
// the sensor's frame is the map's, the turn must be 0).
std::optional<odometry> library_motion_of(const py::object& moved, const std::string& what) {
  const motion mv = motion_of(moved, what);
  if (const auto* o = std::get_if<odometry>(&mv)) return *o;
  if (const auto* s = std::get_if<sensor_odometry>(&mv)) {
    if (s->dtheta_rad != 0.0)
      throw py::value_error(what + ": a turn of " + number(s->dtheta_rad) +
                            " rad; a library is localized with a known heading, so the sensor "
                            "may not turn: give (dx_mm, dy_mm)");
    return odometry{.dx_mm = s->du_mm, .dy_mm = s->dv_mm};
  }
  return std::nullopt;
}

py::tuple extent_of(const planar_grid<float>& g) {
  const auto first = g.state_mm(0);
  const double h = 0.5 * g.mm_per_px();
  const double left = first(0) - h, top = first(1) - h;
  const double right = left + static_cast<double>(g.cols()) * g.mm_per_px();
  const double bottom = top + static_cast<double>(g.rows()) * g.mm_per_px();
  return py::make_tuple(left, right, bottom, top);
}

constexpr const char* library_doc = R"doc(Which object, and where (C++ tacmap::library_localizer).

A robot that has photographed several objects does not know which one its hand closed on. Build
the library from the photographs, each with its name and scale; each touch reports every
object's posterior, P(none of these) and the position on the most probable object's map::

    lib = tacmap.LibraryLocalizer([("gecko", gecko_map, 1.13), ("mug", mug_map, 0.5)])
    r = lib.touch(frame)                       # first touch
    r = lib.touch(frame, (4.0, 0.0))           # moved 4 mm to the right
    if r.verdict == "localized": use(r.object_name, r.position_mm)

The belief over (object, appearance, position) is one Bayes filter with the Localizer's
defaults; the verdict's probability is the joint one (the right object and within the radius),
and "none of these" (probability_unknown, LocalizerConfig.prior_unknown) is weighed by the same
touches. The maps are matched at one scale (the coarsest map's or the working resolution,
whichever is coarser; mm_per_px chooses another); positions stay in each map's own millimetres.
A known heading only (config.headings = 0). Frames, motions and threads as for Localizer.)doc";

}  // namespace

void bind_library(py::module_& m) {
  // ---- LibraryTouchResult ----
  py::class_<library_touch_result>(
      m, "LibraryTouchResult",
      "What one touch on a library gave (C++ tacmap::library_touch_result): which object, "
      "where on it, how sure, and P(none of these). Read-only.")
      .def_property_readonly(
          "verdict", [](const library_touch_result& r) { return to_string(r.verdict); },
          "'localized': the most probable object and position_mm on its map are right with "
          "probability_within at the threshold; 'uncertain', 'contradicted', 'rejected_frame' "
          "as TouchResult.verdict.")
      .def_readonly("object", &library_touch_result::object,
                    "The most probable object: its index in the library.")
      .def_readonly("object_name", &library_touch_result::object_name,
                    "The most probable object's name.")
      .def_property_readonly(
          "object_probability",
          [](const library_touch_result& r) {
            return py::array_t<double>(static_cast<py::ssize_t>(r.object_probability.size()),
                                       r.object_probability.data());
          },
          "Every object's posterior (numpy float64, the library's order: LibraryLocalizer."
          "names); with probability_unknown they sum to 1.")
      .def_readonly("probability_unknown", &library_touch_result::probability_unknown,
                    "P(none of these): the touched object is not in the library "
                    "(LocalizerConfig.prior_unknown, weighed by the touches).")
      .def_property_readonly(
          "tied_objects",
          [](const library_touch_result& r) {
            return std::vector<std::int64_t>(r.tied_objects.begin(), r.tied_objects.end());
          },
          "Other objects as probable as `object` (identical maps): the position holds on each.")
      .def_property_readonly(
          "position_mm",
          [](const library_touch_result& r) { return vec2(r.position_mm.x(), r.position_mm.y()); },
          "The estimate on `object`'s map (its own millimetres, numpy (x, y)): the centre of the "
          "disc of confidence.radius_mm that holds the most belief.")
      .def_readonly("probability_within", &library_touch_result::probability_within,
                    "P(the object is in the library, is `object`, and the position is within "
                    "the radius of position_mm).")
      .def_readonly("appearance_probability", &library_touch_result::appearance_probability,
                    "`object`'s appearance hypotheses' posteriors (as photographed, inverted).")
      .def_readonly("log_prediction_support", &library_touch_result::log_prediction_support,
                    "As TouchResult.log_prediction_support; 0 for a rejected frame.")
      .def_property_readonly(
          "rejection",
          [](const library_touch_result& r) { return choice_name(r.rejection, rejection_names); },
          "Why the frame was rejected: 'none' when it was used, else 'weak_peak', "
          "'weak_total' or 'flat'.")
      .def_readonly("restarted", &library_touch_result::restarted,
                    "The filter started again from each object's prior at this touch.")
      .def_readonly("touches", &library_touch_result::touches,
                    "Touches used since construction or reset(), this one included.")
      .def_readonly("frames_combined", &library_touch_result::frames_combined,
                    "Frames combined into this touch (1, or the frames a burst kept).")
      .def_property_readonly("accepted", &library_touch_result::accepted,
                             "True when the frame was used (rejection == 'none').")
      .def("__repr__", [](const library_touch_result& r) {
        return std::string("LibraryTouchResult(verdict='") + to_string(r.verdict) +
               "', object_name='" + r.object_name + "', position_mm=(" + number(r.position_mm.x()) +
               ", " + number(r.position_mm.y()) +
               "), probability_within=" + number(r.probability_within) +
               ", probability_unknown=" + number(r.probability_unknown) +
               ", touches=" + std::to_string(r.touches) + ")";
      });

  // ---- LibraryLocalizer ----
  py::class_<py_library> library_class(m, "LibraryLocalizer", library_doc);
  def_front_door_members<py_library>(
      library_class, "Restarts from each object's prior since construction or reset().");
  library_class
      .def(py::init([](const py::object& maps, std::optional<localizer_config> config,
                       std::optional<taxel_geometry> sensor,
                       std::optional<std::vector<double>> prior, std::optional<double> mm_per_px,
                       int threads) {
             std::vector<library_map> library = library_maps_of(maps);
             if (threads < 1 || threads > 1024)
               throw py::value_error("LibraryLocalizer: threads = " + std::to_string(threads) +
                                     "; expected 1 .. 1024 threads preparing the maps (1: one "
                                     "after the other, on the caller)");
             const py::gil_scoped_release release;  // preparing the maps takes a while
             std::optional<thread_pool_executor> pool;
             // One map a chunk: more threads than maps would wait.
             const std::size_t workers =
                 std::min(static_cast<std::size_t>(threads), library.size());
             if (workers > 1) pool.emplace(workers);
             return std::make_unique<py_library>(library, config.value_or(localizer_config{}),
                                                 sensor.value_or(taxel_geometry{}),
                                                 prior.value_or(std::vector<double>{}), mm_per_px,
                                                 pool ? executor_ref(*pool) : executor_ref());
           }),
           py::arg("maps"), py::arg("config") = py::none(), py::arg("sensor") = py::none(),
           py::arg("prior") = py::none(), py::arg("mm_per_px") = py::none(), py::arg("threads") = 1,
           "maps: a sequence of (name, map, mm_per_px) or a dict {name: (map, mm_per_px)}: each "
           "object's name, photograph (a 2-D array of intensities, any real dtype, row 0 at the "
           "top) and the photograph's scale. config: a LocalizerConfig (None: the defaults; "
           "headings must be 0). sensor: a TaxelGeometry (None: 14 x 6 at 3.4 mm). prior: each "
           "object's prior probability (None: uniform). mm_per_px: the scale the library works "
           "at (None: the coarsest map's or the working resolution, whichever is coarser). "
           "threads: how many threads prepare the maps (one map each at a time).\n\n"
           "Raises TypeError or ValueError for an empty library, an entry that is not "
           "(name, map, mm_per_px), a repeated or empty name, a map that is not a 2-D real "
           "array, empty, non-finite, given twice or smaller than the sensor, a scale that is "
           "not a finite positive number, a prior that does not sum to 1, or an invalid "
           "configuration (each named with what was expected).")
      .def(
          "touch",
          [](py_library& self, const py::object& frame, const py::object& moved) {
            const tactile_frame f =
                frame_of(self.sensor, frame, "LibraryLocalizer.touch: frame", owner);
            const std::optional<odometry> mv =
                library_motion_of(moved, "LibraryLocalizer.touch: moved");
            return locked(self, [&](library_localizer& lib) {
              return mv ? lib.touch(f, *mv) : lib.touch(f);
            });
          },
          py::arg("frame"), py::arg("moved") = py::none(),
          "One touch; returns a LibraryTouchResult. frame: a Frame or a 2-D array of raw counts "
          "of shape (sensor.rows, sensor.cols). moved: None (no motion: the first touch), "
          "(dx_mm, dy_mm) in the maps' frame (the arm's motion, the same on every object), or "
          "(du_mm, dv_mm, 0.0) (a known heading: the sensor's frame is the maps'). The motion "
          "of the first call after construction or reset() is ignored.")
      .def(
          "touch_burst",
          [](py_library& self, const py::object& frames, const py::object& moved) {
            const std::vector<tactile_frame> burst =
                burst_of(self.sensor, frames, "LibraryLocalizer.touch_burst", owner);
            const std::optional<odometry> mv =
                library_motion_of(moved, "LibraryLocalizer.touch_burst: moved");
            const std::span<const tactile_frame> view(burst);
            return locked(self, [&](library_localizer& lib) {
              return mv ? lib.touch(view, *mv) : lib.touch(view);
            });
          },
          py::arg("frames"), py::arg("moved") = py::none(),
          "One touch from a burst of frames of the same press, combined robustly first "
          "(config.burst), then as touch(). frames: a sequence of Frames or 2-D arrays, or a "
          "3-D array (frames, rows, cols). Raises ValueError for an empty burst or frames of "
          "different geometry, before anything changes.")
      .def(
          "touch_at",
          [](py_library& self, const py::object& frame, double x_mm, double y_mm,
             double theta_rad) {
            const tactile_frame f =
                frame_of(self.sensor, frame, "LibraryLocalizer.touch_at: frame", owner);
            return locked(self, [&](library_localizer& lib) {
              return lib.touch_at(f, {.x_mm = x_mm, .y_mm = y_mm, .theta_rad = theta_rad});
            });
          },
          py::arg("frame"), py::arg("x_mm"), py::arg("y_mm"), py::arg("theta_rad") = 0.0,
          "A touch with the arm's pose (its own frame, mm and radians): the motion since the "
          "previous touch_at becomes the odometry, as Localizer.touch_at with a known heading: "
          "the arm's x and y axes parallel to the maps', the yaw within 5 degrees of the "
          "previous touch's.")
      .def(
          "touch_at_burst",
          [](py_library& self, const py::object& frames, double x_mm, double y_mm,
             double theta_rad) {
            const std::vector<tactile_frame> burst =
                burst_of(self.sensor, frames, "LibraryLocalizer.touch_at_burst", owner);
            const std::span<const tactile_frame> view(burst);
            return locked(self, [&](library_localizer& lib) {
              return lib.touch_at(view, {.x_mm = x_mm, .y_mm = y_mm, .theta_rad = theta_rad});
            });
          },
          py::arg("frames"), py::arg("x_mm"), py::arg("y_mm"), py::arg("theta_rad") = 0.0,
          "touch_at() with a press read as a burst of frames (as touch_burst).")
      .def(
          "next_touch",
          [](py_library& self, const py::object& candidates, int hypotheses,
             const std::string& objective) {
            const std::vector<odometry> moves =
                candidates_of(candidates, "LibraryLocalizer.next_touch");
            const next_touch_params params =
                next_touch_params_of(hypotheses, objective, "LibraryLocalizer.next_touch");
            return locked(self, [&](library_localizer& lib) {
              return lib.next_touch(std::span<const odometry>(moves), params);
            });
          },
          py::arg("candidates"), py::arg("hypotheses") = 64, py::arg("objective") = "verdict",
          "Ranks candidate moves (the maps' frame, mm, from where the sensor is now) by what "
          "the touch after each is expected to decide about the object and the position "
          "together (hypotheses over (object, position)); returns a NextTouchRanking, the "
          "belief unchanged. Arguments and errors as Localizer.next_touch.")
      .def(
          "reset",
          [](py_library& self) { locked(self, [](library_localizer& lib) { lib.reset(); }); },
          "Starts a new exploration: each object's prior, a uniform belief on each map, no "
          "previous pose.")
      .def(
          "object_belief",
          [](py_library& self, const py::object& k) {
            const Eigen::Index i = object_of(self, k, "LibraryLocalizer.object_belief");
            return to_numpy(
                locked(self, [i](library_localizer& lib) { return lib.object_belief_image(i); }));
          },
          py::arg("object"),
          "Object k's position belief given that it is the object touched (summed over its "
          "appearance hypotheses): a new float32 array (rows, cols) on its map at the "
          "library's scale, summing to 1; plot it with imshow(b, extent="
          "lib.object_extent_mm(k)). object: an index or a name. Raises ValueError when the "
          "object's posterior is 0.")
      .def(
          "object_extent_mm",
          [](py_library& self, const py::object& k) {
            const Eigen::Index i = object_of(self, k, "LibraryLocalizer.object_extent_mm");
            return extent_of(self.impl.filter().grid().object(i).base());
          },
          py::arg("object"),
          "(left, right, bottom, top) in mm of object_belief(k)'s pixels on the object's map, "
          "for matplotlib's imshow(..., extent=...).")
      .def_property_readonly(
          "names", [](py_library& self) { return self.names; },
          "The objects' names, in the library's order (that of object_probability).")
      .def_property_readonly(
          "objects", [](py_library& self) { return self.impl.objects(); },
          "How many objects the library holds.")
      .def("__len__", [](py_library& self) { return self.names.size(); })
      .def_property_readonly(
          "probability_unknown",
          [](py_library& self) {
            return locked(self, [](library_localizer& lib) { return lib.probability_unknown(); });
          },
          "P(none of these) after the last touch (LibraryTouchResult.probability_unknown).")
      .def_property_readonly(
          "mm_per_px", [](py_library& self) { return self.impl.mm_per_px(); },
          "The scale every map was resampled to and is matched at, mm per px.")
      .def_property_readonly(
          "photo_mm_per_px", [](py_library& self) { return self.photo_mm_per_px; },
          "Each photograph's own scale, as given (a list in the library's order).")
      .def_property_readonly(
          "config", [](py_library& self) { return self.impl.config(); },
          "The configuration (a copy), with preprocessing.mm_per_px set to the library's scale.")
      .def_property_readonly(
          "sensor", [](py_library& self) { return self.sensor; },
          "The sensor's geometry (a TaxelGeometry copy).")
      .def("__repr__", [](py_library& self) {
        std::string names;
        for (std::size_t k = 0; k < self.names.size(); ++k)
          names += (k > 0 ? ", '" : "'") + self.names[k] + "'";
        return "LibraryLocalizer([" + names + "] at " + number(self.impl.mm_per_px()) +
               " mm/px, touches=" +
               std::to_string(locked(self, [](library_localizer& lib) { return lib.touches(); })) +
               ")";
      });
}

}  // namespace tacmap::python
