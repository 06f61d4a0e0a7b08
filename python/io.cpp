// tacmap's Python module: files — session logs (record by record, as frames and poses) and
// map images (binary PGM always; PNG and JPEG where tacmap::image_file was found).
#include "bindings.hpp"
// (bindings.hpp first: it defines TACMAP_ASSERT for the tacmap headers below.)

#include "tacmap/io/image_io.hpp"
#include "tacmap/io/session_log.hpp"
#if TACMAP_PYTHON_HAVE_IMAGE_FILE
#include "tacmap/io/image_file.hpp"
#endif

namespace tacmap::python {

namespace {

py::dict stats_of(const session_read_stats& s) {
  py::dict d;
  d["lines"] = s.lines;
  d["frames"] = s.frames;
  d["poses"] = s.poses;
  d["frames_skipped"] = s.frames_skipped;
  d["poses_skipped"] = s.poses_skipped;
  d["truncated_line"] = s.truncated_line;
  d["truncated_bytes"] = s.truncated_bytes;
  return d;
}

constexpr const char* reader_doc =
    R"doc(Reads a session log record by record (C++ tacmap::session_reader;
format: include/tacmap/io/SESSION_FORMAT.md). Streaming: the file is never loaded whole.

Iterating yields the records in file order: Frame (raw counts as a numpy view, timestamp_ns,
sequence) and Pose (the sensor centre in the device frame, timestamp_ns)::

    log = tacmap.SessionReader("data/sessions/replay_demo.session")
    h = log.header                     # geometry, map_file, mm_per_px, calibration, extra
    for record in log:
        if isinstance(record, tacmap.Frame): ...
        else: ...                      # a tacmap.Pose

A log that breaks the format raises SessionLogError (a RuntimeError) naming the file, the line
and the field; after an error about one record the reader stands after that line, so catching
it and iterating on skips the bad record.)doc";

}  // namespace

void bind_io(py::module_& m) {
  // ---- SessionLogError, with the line and field of the problem ----
  static py::exception<session_log_error> session_error(m, "SessionLogError", PyExc_RuntimeError);
  session_error.doc() =
      "A session log could not be read: the message names the file, the line (1-based) and "
      "the field, what was found and what was expected. Attributes: line (0 when the problem "
      "is not about one line) and field.";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const session_log_error& e) {
      py::object error = py::handle(session_error.ptr())(e.what());
      error.attr("line") = e.line();
      error.attr("field") = e.field();
      PyErr_SetObject(session_error.ptr(), error.ptr());
    }
  });

  // ---- SessionHeader ----
  py::class_<session_header>(m, "SessionHeader",
                             "The header of a session log: what a reader needs to interpret "
                             "the records (C++ tacmap::session_header). Read-only.")
      .def_readonly("version", &session_header::version, "The format version, as read.")
      .def_readonly("geometry", &session_header::geometry,
                    "The taxel layout of every frame (TaxelGeometry), or None.")
      .def_readonly("map_file", &session_header::map_file,
                    "The map image, relative to the log's folder ('' when none).")
      .def_readonly("mm_per_px", &session_header::mm_per_px, "The map's scale, or None.")
      .def_readonly("calibration", &session_header::calibration,
                    "Device frame -> map frame (MapCalibration), or None.")
      .def_property_readonly(
          "extra",
          [](const session_header& h) {
            py::dict d;
            for (const auto& [k, v] : h.extra) d[py::str(k)] = v;
            return d;
          },
          "Other header keys, in file order (a dict of str).")
      .def("__repr__", [](const session_header& h) {
        std::string out = "SessionHeader(version=" + std::to_string(h.version);
        if (h.geometry)
          out += ", geometry=" + std::to_string(h.geometry->rows) + "x" +
                 std::to_string(h.geometry->cols);
        if (!h.map_file.empty()) out += ", map_file='" + h.map_file + "'";
        return out + ")";
      });

  // ---- SessionReader ----
  py::class_<session_reader>(m, "SessionReader", reader_doc)
      .def(py::init([](const std::filesystem::path& path, bool accept_truncated_tail) {
             session_read_options options;
             options.accept_truncated_tail = accept_truncated_tail;
             return std::make_unique<session_reader>(path, options);
           }),
           py::arg("path"), py::kw_only(), py::arg("accept_truncated_tail") = false,
           "Opens `path` and reads the header. Raises SessionLogError when the file cannot be "
           "opened or its header is not valid. accept_truncated_tail: drop a last line cut "
           "off by a crash (reported in stats) instead of raising.")
      .def_property_readonly(
          "header", [](const session_reader& r) { return r.header(); },
          "The SessionHeader (a copy).")
      .def_property_readonly(
          "map_path",
          [](const session_reader& r) -> py::object {
            const auto p = r.map_path();
            if (p.empty()) return py::none();
            return py::str(p.string());
          },
          "The map file resolved against the log's folder (str), or None when the header names "
          "none.")
      .def_property_readonly("name", &session_reader::name, "The log's name in messages.")
      .def_property_readonly(
          "stats", [](const session_reader& r) { return stats_of(r.stats()); },
          "What the reader has seen so far: a dict of lines, frames, poses, frames_skipped, "
          "poses_skipped, truncated_line, truncated_bytes.")
      .def("__iter__", [](py::object self) { return self; })
      .def(
          "__next__",
          [](session_reader& r) -> session_record {
            auto record = r.next();
            if (!record) throw py::stop_iteration();
            return std::move(*record);
          },
          "The next record (Frame or Pose) in file order.")
      .def("next", &session_reader::next,
           "The next record (Frame or Pose) in file order, or None at the end of the log.")
      .def(
          "next_frame", [](session_reader& r) { return r.next_frame(); },
          "The next Frame (poses in between are skipped and counted in stats), or None at "
          "the end.")
      .def(
          "next_pose", [](session_reader& r) { return r.next_pose(); },
          "The next Pose (frames in between are skipped and counted in stats), or None at "
          "the end.")
      .def("read_all", &session_reader::read_all, "All remaining records, a list.");

  // ---- images ----
  m.def(
      "read_pgm", [](const std::filesystem::path& path) { return to_numpy(read_pgm(path)); },
      py::arg("path"),
      "Reads a binary PGM file (P5, maxval 1..65535) into intensities in [0, 1] (value / "
      "maxval): a float32 array (rows, cols), row 0 at the top. Raises ValueError naming the "
      "file when it cannot be read or is not a whole binary PGM.");
  m.def(
      "write_pgm",
      [](const std::filesystem::path& path, const py::object& img, const std::string& comment) {
        write_pgm(path, to_image(img, "write_pgm: image", "(rows, cols)"), comment);
      },
      py::arg("path"), py::arg("image"), py::arg("comment") = "",
      "Writes `image` (intensities in [0, 1]) as a binary 8-bit PGM; `comment` (one line) "
      "goes into the header.");
  m.def(
      "rescale",
      [](const py::object& img, double from_mm_per_px, double to_mm_per_px) {
        image<float> src = to_image(img, "rescale: image", "(rows, cols)");
        image<float> out;
        {
          const py::gil_scoped_release release;
          out = rescale(src, from_mm_per_px, to_mm_per_px);
        }
        return to_numpy(out);
      },
      py::arg("image"), py::arg("from_mm_per_px"), py::arg("to_mm_per_px"),
      "`image`, sampled at from_mm_per_px, resampled to to_mm_per_px so that it covers the "
      "same physical extent: each side becomes round(side x from / to) px. Shrinking averages "
      "areas (no aliasing); enlarging interpolates bilinearly. A new float32 array.");
#if TACMAP_PYTHON_HAVE_IMAGE_FILE
  m.def(
      "load_image",
      [](const std::filesystem::path& path) {
        image<float> out;
        {
          const py::gil_scoped_release release;
          out = load_image(path);
        }
        return to_numpy(out);
      },
      py::arg("path"),
      "Reads an image file (PNG, JPEG or binary PGM) into grey intensities in [0, 1]: a "
      "float32 array (rows, cols). Colour becomes grey with ITU-R BT.601 luma on the stored "
      "values; alpha and colour profiles are ignored. The map's scale (mm per px) is not in "
      "the file: give it to the Localizer, or rescale. Raises ValueError naming the path when "
      "the file cannot be opened or decoded (truncated, corrupt, or another format).");
  m.attr("has_image_file") = true;
#else
  m.attr("has_image_file") = false;
#endif
}

}  // namespace tacmap::python
