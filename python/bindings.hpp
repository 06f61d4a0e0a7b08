// tacmap's Python module: what every translation unit of the bindings shares — numpy <-> image
// conversion with errors that name the argument, enums as strings, and keyword constructors.
//
// Included first by every .cpp of the module: TACMAP_ASSERT must be defined before any tacmap
// header. By default a broken contract aborts the process; inside a Python interpreter that
// would kill the user's session (a Jupyter kernel), so here it throws instead, which pybind11
// turns into a RuntimeError.
#pragma once

#include <stdexcept>
#include <string>

#define TACMAP_ASSERT(cond, message)                                                         \
  do {                                                                                       \
    if (!(cond))                                                                             \
      throw std::logic_error(std::string("tacmap: contract violated: ") + (message) + " (" + \
                             #cond + "); please report this as a bug");                      \
  } while (false)

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/operators.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <array>
#include <cstring>
#include <initializer_list>
#include <optional>
#include <sstream>
#include <string_view>
#include <utility>
#include <vector>

#include "tacmap/image.hpp"

namespace tacmap::python {

namespace py = pybind11;

// ---- the module's parts, one function per translation unit (registration order matters:
// ---- a type must be registered before a signature shows a default value of it) -----------

void bind_core(py::module_& m);         // TaxelGeometry, Frame, Pose, MapCalibration (core.cpp)
void bind_config(py::module_& m);       // LocalizerConfig and its parts (localizer.cpp)
void bind_localizer(py::module_& m);    // Localizer, TouchResult (localizer.cpp)
void bind_library(py::module_& m);      // LibraryLocalizer, LibraryTouchResult (library.cpp)
void bind_simulation(py::module_& m);   // Simulator, scenarios, protocol, experiment (sim.cpp)
void bind_io(py::module_& m);           // session logs, image files (io.cpp)
void bind_descriptors(py::module_& m);  // SiftLite, ClassicSift (descriptor.cpp)

// ---- numpy -> image<float> --------------------------------------------------------------

/// "(14, 6)" for a shape.
inline std::string shape_text(const py::array& a) {
  std::ostringstream out;
  out << '(';
  for (py::ssize_t k = 0; k < a.ndim(); ++k) out << (k > 0 ? ", " : "") << a.shape(k);
  out << (a.ndim() == 1 ? ",)" : ")");
  return out.str();
}

/// A 2-D array-like of real numbers as a row-major float image, always copied: the copy makes
/// strides, byte order and dtype irrelevant to C++, and is taken while the GIL is held, so the
/// caller may release it afterwards. `what` names the argument in errors ("Localizer.touch:
/// frame"); `expected` is the expected shape as text ("(14, 6)"); `rows`/`cols` >= 0 are
/// checked. Raises TypeError for a non-numeric dtype (complex, object, bool, str) and
/// ValueError for a wrong number of dimensions or a wrong shape.
inline image<float> to_image(py::handle obj, const std::string& what, const std::string& expected,
                             py::ssize_t rows = -1, py::ssize_t cols = -1) {
  py::array a;
  if (py::isinstance<py::array>(obj)) {
    a = py::reinterpret_borrow<py::array>(obj);
  } else if (py::isinstance<py::str>(obj) || py::isinstance<py::bytes>(obj) || obj.is_none()) {
    throw py::type_error(what + ": got " +
                         std::string(py::str(py::type::of(obj).attr("__name__"))) +
                         "; expected a 2-D numpy array of shape " + expected);
  } else {
    try {
      a = py::module_::import("numpy").attr("asarray")(obj);
    } catch (py::error_already_set& e) {
      throw py::type_error(what + ": cannot be read as an array (" + e.what() +
                           "); expected a 2-D numpy array of shape " + expected);
    }
  }
  const char kind = a.dtype().kind();
  if (kind != 'f' && kind != 'i' && kind != 'u')
    throw py::type_error(what + ": dtype " + std::string(py::str(a.dtype())) +
                         "; expected real numbers (a float or integer dtype) of shape " + expected +
                         " — convert it, e.g. with .astype(numpy.float32)" +
                         (kind == 'c' ? " after taking the real part or the magnitude" : ""));
  if (a.ndim() != 2)
    throw py::value_error(what + ": a " + std::to_string(a.ndim()) + "-D array of shape " +
                          shape_text(a) + "; expected a 2-D array of shape " + expected);
  if ((rows >= 0 && a.shape(0) != rows) || (cols >= 0 && a.shape(1) != cols))
    throw py::value_error(what + ": shape " + shape_text(a) + "; expected " + expected);
  // forcecast + c_style: numpy converts the dtype and gathers strided data into a new array.
  const auto c = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(a);
  if (!c) throw py::error_already_set();
  image<float> out(c.shape(0), c.shape(1));
  if (out.size() > 0)
    std::memcpy(out.data(), c.data(), static_cast<std::size_t>(out.size()) * sizeof(float));
  return out;
}

/// A row-major image as a new (rows, cols) numpy array that Python owns.
template <class T>
py::array_t<T> to_numpy(const image<T>& img) {
  py::array_t<T> out({img.rows(), img.cols()});
  if (img.size() > 0)
    std::memcpy(out.mutable_data(), img.data(), static_cast<std::size_t>(img.size()) * sizeof(T));
  return out;
}

/// Images of one size as a new (n, rows, cols) numpy array.
inline py::array_t<float> to_numpy(const std::vector<image<float>>& images, Eigen::Index rows,
                                   Eigen::Index cols) {
  py::array_t<float> out({static_cast<Eigen::Index>(images.size()), rows, cols});
  float* dst = out.mutable_data();
  for (const auto& img : images) {
    if (img.rows() != rows || img.cols() != cols)
      throw std::logic_error("to_numpy: images of different sizes");
    std::memcpy(dst, img.data(), static_cast<std::size_t>(img.size()) * sizeof(float));
    dst += img.size();
  }
  return out;
}

/// A 2-vector as a new numpy array of shape (2,).
inline py::array_t<double> vec2(double x, double y) {
  py::array_t<double> out(2);
  out.mutable_at(0) = x;
  out.mutable_at(1) = y;
  return out;
}

// ---- enums as strings ---------------------------------------------------------------------

/// The Python names of an enum's values: the names tacmap-evaluate and the C++ `to_string`
/// functions use, so one vocabulary serves the command line, the CSV files and Python.
template <class E>
using choices = std::initializer_list<std::pair<const char*, E>>;

template <class E>
std::string choice_list(choices<E> options) {
  std::string out;
  std::size_t k = 0;
  for (const auto& [name, value] : options) {
    out += (k == 0 ? "'" : (k + 1 == options.size() ? " or '" : ", '"));
    out += name;
    out += "'";
    ++k;
  }
  return out;
}

template <class E>
E parse_choice(const std::string& value, const std::string& what, choices<E> options) {
  for (const auto& [name, e] : options)
    if (value == name) return e;
  throw py::value_error(what + " = '" + value + "'; expected " + choice_list(options));
}

template <class E>
const char* choice_name(E value, choices<E> options) {
  for (const auto& [name, e] : options)
    if (e == value) return name;
  return "?";
}

/// A read-write property of enum member `member` of `Class`, as a string.
template <class Class, class E, class PyClass>
void enum_property(PyClass& cls, const char* name, E Class::*member, choices<E> options,
                   const char* doc) {
  const std::string type_name = py::str(cls.attr("__name__"));
  const std::string what = type_name + "." + name;
  const std::string full_doc =
      std::string(doc) + "\n\nOne of " + choice_list(options) + " (a str).";
  // The initializer_list's array lives as long as the call; copy the pairs for the lambdas.
  const std::vector<std::pair<const char*, E>> table(options.begin(), options.end());
  cls.def_property(
      name,
      [member, table](const Class& c) -> std::string {
        for (const auto& [n, e] : table)
          if (e == c.*member) return n;
        return "?";
      },
      [member, table, what](Class& c, const std::string& value) {
        for (const auto& [n, e] : table)
          if (value == n) {
            c.*member = e;
            return;
          }
        std::string list;
        for (std::size_t k = 0; k < table.size(); ++k)
          list += std::string(k == 0 ? "'" : (k + 1 == table.size() ? " or '" : ", '")) +
                  table[k].first + "'";
        throw py::value_error(what + " = '" + value + "'; expected " + list);
      },
      full_doc.c_str());
}

// ---- keyword constructors and reprs for the parameter structs ----------------------------

/// The keyword fields of LocalizerConfig (C++ localizer_config), in their documented order: one
/// list for LocalizerConfig and for LocalizationConfig, which derives from it, so that a field
/// bound on the first is a keyword of the second too.
inline std::vector<std::string> localizer_config_fields() {
  return {"model",
          "pairs",
          "shape",
          "features",
          "tau",
          "tempering",
          "motion_sigma_mm",
          "motion_k",
          "preprocessing",
          "confidence",
          "headings",
          "turn_sigma_rad",
          "prior_unknown",
          "unknown_evidence_weight",
          "unknown_support_margin",
          "unknown_model",
          "unknown_shadow_weight",
          "unknown_shadow_support_weight",
          "unknown_shadow_margin",
          "appearance",
          "appearance_switch",
          "lost_probability",
          "wide_probability",
          "wide_sigma_mm",
          "broad_probability",
          "broad_sigma_mm",
          "slip_recheck",
          "burst",
          "calibrate_sensor",
          "tracking",
          "tracking_headings",
          "working_mm_per_px",
          "pad_spread_mm"};
}

/// A read-write property `name` of `Class` for an optional parameter struct `P` (a bound
/// class): None when off. Reading gives a view into the configuration (as for its other nested
/// parameters: `config.tracking.epsilon = 1e-8` changes the configuration), or None. Assigning
/// takes None or False (off), True (`on`, the values turning it on means) or a `P`; anything
/// else is a TypeError naming the value.
template <class Class, class P, class PyClass>
void optional_params_property(PyClass& cls, const char* name, std::optional<P> Class::*member, P on,
                              const char* doc) {
  const std::string what = std::string(py::str(cls.attr("__name__"))) + "." + name;
  const std::string type_name = py::str(py::type::of<P>().attr("__name__"));
  const std::string full_doc = std::string(doc) + "\n\nNone, True or a " + type_name +
                               " (assign None or False to turn it off).";
  cls.def_property(
      name,
      [member](py::object self) -> py::object {
        Class& c = self.cast<Class&>();
        if (!(c.*member)) return py::none();
        return py::cast(&*(c.*member), py::return_value_policy::reference_internal, self);
      },
      [member, on, what, type_name](Class& c, const py::object& value) {
        if (value.is_none() || (py::isinstance<py::bool_>(value) && !value.cast<bool>()))
          c.*member = std::nullopt;
        else if (py::isinstance<py::bool_>(value))
          c.*member = on;
        else if (py::isinstance<P>(value))
          c.*member = value.cast<P>();
        else
          throw py::type_error(what + " = " + std::string(py::repr(value)) + " (a " +
                               std::string(py::str(py::type::of(value).attr("__name__"))) +
                               "); expected None (off), True (the defaults) or a " + type_name);
      },
      full_doc.c_str());
}

/// Gives a bound parameter struct `T` (default-constructible, with a `validate()` that throws
/// std::invalid_argument) a constructor taking any of `fields` as keywords — each set through
/// its property, so enum names and types are checked as on assignment — then validated; a
/// `__repr__` listing every field; and a class docstring ending in the fields' defaults, read
/// from a default-constructed T (so the documentation cannot drift from the C++ defaults).
template <class T, class PyClass>
void keyword_struct(PyClass& cls, std::vector<std::string> fields, const std::string& doc) {
  const std::string type_name = py::str(cls.attr("__name__"));
  cls.def(
      py::init([fields, type_name](const py::kwargs& kwargs) {
        py::object obj = py::cast(T{});
        for (const auto& [key, value] : kwargs) {
          const std::string name = py::str(key);
          bool known = false;
          for (const auto& f : fields) known = known || f == name;
          if (!known) {
            std::string list;
            for (std::size_t k = 0; k < fields.size(); ++k) list += (k > 0 ? ", " : "") + fields[k];
            throw py::type_error(type_name + ": unknown field '" + name + "'; expected " + list);
          }
          try {
            obj.attr(key) = value;
          } catch (py::error_already_set& e) {
            if (!e.matches(PyExc_TypeError)) throw;
            throw py::type_error(type_name + ": " + name + " = " + std::string(py::repr(value)) +
                                 " has the wrong type (" +
                                 std::string(py::str(py::type::of(value).attr("__name__"))) +
                                 "); expected " + name + "'s type, see help(tacmap." + type_name +
                                 "." + name + ")");
          }
        }
        T out = obj.cast<T>();
        out.validate();
        return out;
      }),
      ("Keyword constructor: any field of " + type_name +
       " (see the class documentation), the rest keep their defaults. Raises ValueError "
       "for an invalid value, naming it and what was expected.")
          .c_str());
  cls.def("__repr__", [fields, type_name](const py::object& self) {
    std::string out = type_name + "(";
    for (std::size_t k = 0; k < fields.size(); ++k)
      out += (k > 0 ? ", " : "") + fields[k] + "=" +
             std::string(py::repr(self.attr(fields[k].c_str())));
    return out + ")";
  });
  cls.def("validate", &T::validate,
          "Raises ValueError naming the first field that is out of range or contradicts "
          "another.");
  cls.def("__copy__", [](const T& self) { return T(self); });
  cls.def(
      "__deepcopy__", [](const T& self, const py::dict&) { return T(self); }, py::arg("memo"));
  const py::object defaults = py::cast(T{});
  std::string full = doc + "\n\nFields and their defaults:\n";
  for (const auto& f : fields)
    full += "    " + f + " = " + std::string(py::repr(defaults.attr(f.c_str()))) + "\n";
  cls.doc() = full;
}

}  // namespace tacmap::python
