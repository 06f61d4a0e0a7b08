// tacmap: touch protocols — where a sensor touched an object, in which orders, with what
// odometry (the paper's Sec. IV experiment: 7 touch locations on the gecko, visited in 22
// sequences in different orders, the Phantom Omni's positions as odometry).
//
// A protocol is a folder of small text files (the format is specified in data/README.md):
//   protocol.txt   manifest, `key = value` lines: the map image, its scale, how the map becomes
//                  a relief, the names of the two tables below, and how the data was made
//   locations.txt  one touch location per line: `location x_mm y_mm` (sensor centre, map frame)
//   sequences.txt  one step per line: `sequence step location true_dx_mm true_dy_mm
//                  measured_dx_mm measured_dy_mm` (the move from the previous step's location)
// '#' starts a comment; blank lines are ignored; fields are separated by spaces or tabs.
// Numbers are read with std::from_chars (locale-independent) and written with std::to_chars.
//
// Errors are std::invalid_argument whose message names the FILE, the LINE and the FIELD, what
// was found and what was expected, e.g.
//   load_locations: data/gecko/locations.txt:9: field 'x_mm' = 'nan' is not finite; ...
#pragma once

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "tacmap/image.hpp"
#include "tacmap/io/image_io.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"
#include "tacmap/sim/tactile_simulator.hpp"
#include "tacmap/tactile/frame.hpp"

namespace tacmap {

/// One touch location: the sensor centre in the map frame (mm); the sensor is not rotated
/// (theta = 0, rows along the map's y axis), as in the paper.
struct touch_location {
  double x_mm = 0.0;
  double y_mm = 0.0;
  [[nodiscard]] map_pose pose() const { return {x_mm, y_mm, 0.0}; }
  friend bool operator==(const touch_location&, const touch_location&) = default;
};

/// One step of a sequence: the location touched and the move that brought the sensor there
/// from the previous step's location (zero for the first step).
struct protocol_step {
  std::size_t location = 0;    ///< index into touch_protocol::locations
  odometry true_motion{};      ///< the exact displacement (ground truth)
  odometry measured_motion{};  ///< what the arm reported: truth plus odometry noise
};

/// A sequence of touches, in order.
using touch_sequence = std::vector<protocol_step>;

/// The sequence that visits `locations` in `order`: each move's true displacement, and a measured
/// one with N(0, sigma^2) noise per axis drawn from `noise` (x first, then y). `round` is applied
/// to every stored value (e.g. to the precision a data file keeps).
template <class Rng, class Round = std::identity>
[[nodiscard]] touch_sequence sequence_visiting(const std::vector<touch_location>& locations,
                                               const std::vector<std::size_t>& order,
                                               double sigma_mm, Rng& noise, Round round = {}) {
  touch_sequence seq;
  for (std::size_t k = 0; k < order.size(); ++k) {
    protocol_step step;
    step.location = order[k];
    if (k > 0) {
      const touch_location& from = locations[order[k - 1]];
      const touch_location& to = locations[order[k]];
      step.true_motion = {round(to.x_mm - from.x_mm), round(to.y_mm - from.y_mm)};
      const double nx = sigma_mm * noise.normal();
      const double ny = sigma_mm * noise.normal();
      step.measured_motion = {round(step.true_motion.dx_mm + nx),
                              round(step.true_motion.dy_mm + ny)};
    }
    seq.push_back(step);
  }
  return seq;
}

/// A whole protocol: the map, its relief, the touch locations and the sequences.
struct touch_protocol {
  std::string map_file;          ///< the map image, relative to the manifest's folder
  image<float> map;              ///< the visual map, intensities in [0, 1]
  double mm_per_px = 3.4 / 3.0;  ///< the map's scale
  relief_params relief{};        ///< how the map becomes a relief (the gecko: 4 mm binary)
  std::string locations_file = "locations.txt";
  std::string sequences_file = "sequences.txt";
  std::vector<touch_location> locations;
  std::vector<touch_sequence> sequences;
  int readings_per_location = 1;   ///< frames taken at each touch (the paper: 20)
  double odometry_sigma_mm = 0.0;  ///< per-axis noise of measured_motion (documentation)
  std::uint64_t seed = 0;          ///< the seed the data was generated from (documentation)

  [[nodiscard]] pixel_size map_size() const { return {map.cols(), map.rows()}; }
  /// The relief in mm the simulator presses on.
  [[nodiscard]] image<float> relief_mm() const { return relief_from_image(map, relief); }
};

namespace detail::protocol_io {

struct text_line {
  std::size_t number = 0;  // 1-based, as editors show it
  std::vector<std::string_view> fields;
};

/// The data lines of a text: comments ('#' to the end of the line) removed, blank lines
/// skipped, each remaining line split into whitespace-separated fields.
inline std::vector<text_line> data_lines(std::string_view text) {
  std::vector<text_line> lines;
  std::size_t number = 0;
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    ++number;
    std::string_view line = text.substr(start, end - start);
    if (const std::size_t hash = line.find('#'); hash != std::string_view::npos)
      line = line.substr(0, hash);
    text_line parsed{number, {}};
    std::size_t at = 0;
    while (at < line.size()) {
      while (at < line.size() && (line[at] == ' ' || line[at] == '\t' || line[at] == '\r')) ++at;
      const std::size_t field_start = at;
      while (at < line.size() && !(line[at] == ' ' || line[at] == '\t' || line[at] == '\r')) ++at;
      if (at > field_start) parsed.fields.push_back(line.substr(field_start, at - field_start));
    }
    if (!parsed.fields.empty()) lines.push_back(std::move(parsed));
    if (end == text.size()) break;
    start = end + 1;
  }
  return lines;
}

/// Where an error is: "who: file:line: field 'name'".
struct location_in_file {
  const char* who;
  const std::string* file;
  std::size_t line;
};

inline double parse_double(const location_in_file& at, const char* field, std::string_view token) {
  std::string_view digits = token;
  if (!digits.empty() && digits.front() == '+') digits.remove_prefix(1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (ec != std::errc{} || end != digits.data() + digits.size())
    fail(at.who, ": ", *at.file, ":", at.line, ": field '", field, "' = '", token,
         "' is not a number; expected a decimal number such as 12.5");
  if (!std::isfinite(value))
    fail(at.who, ": ", *at.file, ":", at.line, ": field '", field, "' = '", token,
         "' is not finite; expected a finite number");
  return value;
}

inline std::uint64_t parse_index(const location_in_file& at, const char* field,
                                 std::string_view token) {
  std::uint64_t value = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc{} || end != token.data() + token.size())
    fail(at.who, ": ", *at.file, ":", at.line, ": field '", field, "' = '", token,
         "' is not a whole number >= 0; expected an index such as 3");
  return value;
}

/// A number with a fixed count of decimals, never "-0.000".
inline std::string fixed(double value, int decimals) {
  const double scale = std::pow(10.0, decimals);
  if (std::round(value * scale) == 0.0) value = 0.0;
  char buffer[64];
  const auto [end, ec] =
      std::to_chars(buffer, buffer + sizeof buffer, value, std::chars_format::fixed, decimals);
  TACMAP_ASSERT(ec == std::errc{}, "to_chars buffer too small");
  return {buffer, end};
}

/// The shortest text that reads back as exactly `value`.
inline std::string shortest(double value) {
  char buffer[64];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
  TACMAP_ASSERT(ec == std::errc{}, "to_chars buffer too small");
  return {buffer, end};
}

inline std::string read_text(const std::filesystem::path& path, const char* who) {
  std::string text = image_io::read_file(path, who);
  if (data_lines(text).empty())
    fail(who, ": ", path.string(),
         " is empty (no data lines, only comments or blanks); "
         "expected the table described in data/README.md");
  return text;
}

inline constexpr double footprint_tolerance_mm = 1e-6;  // as tactile_simulator::fits

}  // namespace detail::protocol_io

/// Reads a locations table (`location x_mm y_mm`, locations numbered 0, 1, 2, ... in order)
/// and checks that a `sensor` centred at each location (theta = 0) lies wholly on a map of
/// `map` pixels at `mm_per_px`. Throws std::invalid_argument naming file, line and field.
[[nodiscard]] inline std::vector<touch_location> load_locations(const std::filesystem::path& path,
                                                                pixel_size map, double mm_per_px,
                                                                const taxel_geometry& sensor = {}) {
  using namespace detail::protocol_io;
  constexpr const char* who = "load_locations";
  sensor.validate();
  const std::string text = read_text(path, who);
  const std::string file = path.string();
  const double half_w = 0.5 * static_cast<double>(sensor.cols) * sensor.pitch_mm;
  const double half_h = 0.5 * static_cast<double>(sensor.rows) * sensor.pitch_mm;
  const double width = static_cast<double>(map.width) * mm_per_px;
  const double height = static_cast<double>(map.height) * mm_per_px;
  std::vector<touch_location> locations;
  for (const text_line& line : data_lines(text)) {
    const location_in_file at{who, &file, line.number};
    if (line.fields.size() != 3)
      detail::fail(who, ": ", file, ":", line.number, ": found ", line.fields.size(),
                   " fields; expected 3 fields 'location x_mm y_mm'");
    const std::uint64_t id = parse_index(at, "location", line.fields[0]);
    if (id != locations.size())
      detail::fail(who, ": ", file, ":", line.number, ": field 'location' = ", id, "; expected ",
                   locations.size(),
                   " (locations are numbered 0, 1, 2, ... in "
                   "the order of the lines)");
    const touch_location loc{parse_double(at, "x_mm", line.fields[1]),
                             parse_double(at, "y_mm", line.fields[2])};
    constexpr double tol = footprint_tolerance_mm;
    if (loc.x_mm - half_w < -tol || loc.x_mm + half_w > width + tol)
      detail::fail(who, ": ", file, ":", line.number, ": field 'x_mm' = ", loc.x_mm, " puts the ",
                   2 * half_w, " mm wide sensor footprint at x in [", loc.x_mm - half_w, ", ",
                   loc.x_mm + half_w, "] mm, off the map's extent [0, ", width, "] mm (", map.width,
                   " px at ", mm_per_px, " mm per px); expected ", half_w,
                   " <= x_mm <= ", width - half_w);
    if (loc.y_mm - half_h < -tol || loc.y_mm + half_h > height + tol)
      detail::fail(who, ": ", file, ":", line.number, ": field 'y_mm' = ", loc.y_mm, " puts the ",
                   2 * half_h, " mm tall sensor footprint at y in [", loc.y_mm - half_h, ", ",
                   loc.y_mm + half_h, "] mm, off the map's extent [0, ", height, "] mm (",
                   map.height, " px at ", mm_per_px, " mm per px); expected ", half_h,
                   " <= y_mm <= ", height - half_h);
    locations.push_back(loc);
  }
  return locations;
}

/// Reads a sequences table (`sequence step location true_dx_mm true_dy_mm measured_dx_mm
/// measured_dy_mm`). Sequences are numbered 0, 1, 2, ..., their steps 0, 1, 2, ... in line order;
/// a step's true motion must equal the move between the two locations (within 1e-3 mm), and the
/// first step's motions are zero. Throws std::invalid_argument naming file, line and field.
[[nodiscard]] inline std::vector<touch_sequence> load_sequences(
    const std::filesystem::path& path, const std::vector<touch_location>& locations) {
  using namespace detail::protocol_io;
  constexpr const char* who = "load_sequences";
  const std::string text = read_text(path, who);
  const std::string file = path.string();
  std::vector<touch_sequence> sequences;
  constexpr double tolerance_mm = 1e-3;
  for (const text_line& line : data_lines(text)) {
    const location_in_file at{who, &file, line.number};
    if (line.fields.size() != 7)
      detail::fail(who, ": ", file, ":", line.number, ": found ", line.fields.size(),
                   " fields; expected 7 fields 'sequence step location true_dx_mm true_dy_mm "
                   "measured_dx_mm measured_dy_mm'");
    const std::uint64_t seq = parse_index(at, "sequence", line.fields[0]);
    const std::uint64_t step = parse_index(at, "step", line.fields[1]);
    const std::uint64_t loc = parse_index(at, "location", line.fields[2]);
    const bool continues = !sequences.empty() && seq + 1 == sequences.size();
    if (!continues) {
      if (seq != sequences.size())
        detail::fail(who, ": ", file, ":", line.number, ": field 'sequence' = ", seq, "; expected ",
                     sequences.empty() ? "0" : "the current sequence or the next, ",
                     sequences.empty() ? ""
                                       : std::to_string(sequences.size() - 1) + " or " +
                                             std::to_string(sequences.size()),
                     " (sequences are numbered 0, 1, 2, ... in line order)");
      if (step != 0)
        detail::fail(who, ": ", file, ":", line.number, ": field 'step' = ", step,
                     "; expected 0 (sequence ", seq, " starts here, with step 0)");
      sequences.emplace_back();
    }
    touch_sequence& current = sequences.back();
    if (step != current.size())
      detail::fail(who, ": ", file, ":", line.number, ": field 'step' = ", step, "; expected ",
                   current.size(),
                   " (steps of a sequence are numbered 0, 1, 2, ... in line "
                   "order)");
    if (loc >= locations.size())
      detail::fail(who, ": ", file, ":", line.number, ": field 'location' = ", loc,
                   "; expected a location of the locations table, 0 .. ",
                   locations.size() == 0 ? 0 : locations.size() - 1);
    protocol_step s;
    s.location = static_cast<std::size_t>(loc);
    s.true_motion = {parse_double(at, "true_dx_mm", line.fields[3]),
                     parse_double(at, "true_dy_mm", line.fields[4])};
    s.measured_motion = {parse_double(at, "measured_dx_mm", line.fields[5]),
                         parse_double(at, "measured_dy_mm", line.fields[6])};
    double expect_dx = 0.0;
    double expect_dy = 0.0;
    if (step > 0) {
      const touch_location& from = locations[current.back().location];
      expect_dx = locations[s.location].x_mm - from.x_mm;
      expect_dy = locations[s.location].y_mm - from.y_mm;
    } else if (s.measured_motion.dx_mm != 0.0 || s.measured_motion.dy_mm != 0.0) {
      detail::fail(who, ": ", file, ":", line.number,
                   ": fields 'measured_dx_mm measured_dy_mm' "
                   "= ",
                   s.measured_motion.dx_mm, " ", s.measured_motion.dy_mm,
                   "; expected 0 0 on a sequence's first step (there is no move before it)");
    }
    if (std::abs(s.true_motion.dx_mm - expect_dx) > tolerance_mm)
      detail::fail(who, ": ", file, ":", line.number,
                   ": field 'true_dx_mm' = ", s.true_motion.dx_mm, "; expected ", expect_dx,
                   step > 0 ? " (the x move between the two locations)"
                            : " (a sequence's first step has no move)");
    if (std::abs(s.true_motion.dy_mm - expect_dy) > tolerance_mm)
      detail::fail(who, ": ", file, ":", line.number,
                   ": field 'true_dy_mm' = ", s.true_motion.dy_mm, "; expected ", expect_dy,
                   step > 0 ? " (the y move between the two locations)"
                            : " (a sequence's first step has no move)");
    current.push_back(s);
  }
  return sequences;
}

/// Reads a protocol manifest (`protocol.txt`) and everything it names: the map image (binary
/// PGM), the locations and the sequences (paths relative to the manifest's folder). Locations
/// are checked against the map for a `sensor` of the given geometry. Throws
/// std::invalid_argument naming the file, line and field (or key) of the first problem.
[[nodiscard]] inline touch_protocol load_protocol(const std::filesystem::path& manifest,
                                                  const taxel_geometry& sensor = {}) {
  using namespace detail::protocol_io;
  constexpr const char* who = "load_protocol";
  const std::string text = read_text(manifest, who);
  const std::string file = manifest.string();
  struct entry {
    std::string value;
    std::size_t line;
  };
  std::map<std::string, entry, std::less<>> keys;
  static constexpr std::string_view known[] = {"format",
                                               "map",
                                               "mm_per_px",
                                               "relief",
                                               "relief_threshold",
                                               "relief_height_mm",
                                               "relief_edge_smoothing_px",
                                               "locations",
                                               "sequences",
                                               "readings_per_location",
                                               "odometry_sigma_mm",
                                               "seed"};
  for (const text_line& line : data_lines(text)) {
    if (line.fields.size() < 3 || line.fields[1] != "=")
      detail::fail(who, ": ", file, ":", line.number, ": found '", line.fields[0],
                   line.fields.size() > 1 ? " ..." : "", "'; expected a line 'key = value'");
    const std::string_view key = line.fields[0];
    if (std::find(std::begin(known), std::end(known), key) == std::end(known))
      detail::fail(who, ": ", file, ":", line.number, ": unknown key '", key,
                   "'; expected one of format, map, mm_per_px, relief, relief_threshold, "
                   "relief_height_mm, relief_edge_smoothing_px, locations, sequences, "
                   "readings_per_location, odometry_sigma_mm, seed");
    if (const auto it = keys.find(key); it != keys.end())
      detail::fail(who, ": ", file, ":", line.number, ": key '", key,
                   "' is given again (first "
                   "on line ",
                   it->second.line, "); expected each key once");
    std::string value(line.fields[2]);
    for (std::size_t i = 3; i < line.fields.size(); ++i) {
      value += ' ';  // appended piecewise: `" " + std::string` trips GCC 12's -Wrestrict at -O2
      value += line.fields[i];
    }
    keys.emplace(std::string(key), entry{std::move(value), line.number});
  }
  const auto required = [&](const char* key) -> const entry& {
    const auto it = keys.find(std::string_view(key));
    if (it == keys.end())
      detail::fail(who, ": ", file, ": key '", key, "' is missing; expected a line '", key,
                   " = ...' (see data/README.md)");
    return it->second;
  };
  const auto number = [&](const char* key, double fallback) {
    const auto it = keys.find(std::string_view(key));
    if (it == keys.end()) return fallback;
    return parse_double({who, &file, it->second.line}, key, it->second.value);
  };

  touch_protocol p;
  if (const entry& format = required("format"); format.value != "tacmap-protocol 1")
    detail::fail(who, ": ", file, ":", format.line, ": field 'format' = '", format.value,
                 "'; expected 'tacmap-protocol 1' (the only version this tacmap reads)");
  const std::filesystem::path folder = manifest.parent_path();
  p.map_file = required("map").value;
  p.map = read_pgm(folder / p.map_file);
  {
    const entry& scale = required("mm_per_px");
    p.mm_per_px = parse_double({who, &file, scale.line}, "mm_per_px", scale.value);
    if (!(p.mm_per_px > 0.0))
      detail::fail(who, ": ", file, ":", scale.line, ": field 'mm_per_px' = ", p.mm_per_px,
                   "; expected the map's scale, > 0 millimetres per pixel");
  }
  if (const auto it = keys.find(std::string_view("relief")); it != keys.end()) {
    if (it->second.value == "binary")
      p.relief.kind = relief_kind::binary;
    else if (it->second.value == "continuous")
      p.relief.kind = relief_kind::continuous;
    else
      detail::fail(who, ": ", file, ":", it->second.line, ": field 'relief' = '", it->second.value,
                   "'; expected 'binary' or 'continuous'");
  }
  p.relief.threshold = static_cast<float>(number("relief_threshold", p.relief.threshold));
  p.relief.height_mm = number("relief_height_mm", p.relief.height_mm);
  p.relief.edge_smoothing_px = number("relief_edge_smoothing_px", p.relief.edge_smoothing_px);
  if (p.relief.edge_smoothing_px < 0.0)
    detail::fail(who, ": ", file, ":",
                 keys.find(std::string_view("relief_edge_smoothing_px"))->second.line,
                 ": field 'relief_edge_smoothing_px' = ", p.relief.edge_smoothing_px,
                 "; expected a Gaussian sigma >= 0 in map pixels");
  const double readings = number("readings_per_location", 1.0);
  if (!(readings >= 1.0 && readings <= 1e6 && readings == std::round(readings)))
    detail::fail(who, ": ", file, ":",
                 keys.find(std::string_view("readings_per_location"))->second.line,
                 ": field 'readings_per_location' = ", readings,
                 "; expected a whole number of frames per touch >= 1 (the paper: 20)");
  p.readings_per_location = static_cast<int>(readings);
  p.odometry_sigma_mm = number("odometry_sigma_mm", 0.0);
  if (p.odometry_sigma_mm < 0.0)
    detail::fail(who, ": ", file, ":",
                 keys.find(std::string_view("odometry_sigma_mm"))->second.line,
                 ": field 'odometry_sigma_mm' = ", p.odometry_sigma_mm,
                 "; expected a standard deviation >= 0 in millimetres");
  if (const auto it = keys.find(std::string_view("seed")); it != keys.end())
    p.seed = parse_index({who, &file, it->second.line}, "seed", it->second.value);
  p.locations_file = required("locations").value;
  p.sequences_file = required("sequences").value;
  p.locations = load_locations(folder / p.locations_file, p.map_size(), p.mm_per_px, sensor);
  p.sequences = load_sequences(folder / p.sequences_file, p.locations);
  return p;
}

/// The manifest text of `p` (the inverse of load_protocol's manifest parsing).
[[nodiscard]] inline std::string format_manifest(const touch_protocol& p,
                                                 std::string_view header_comment = {}) {
  using detail::protocol_io::shortest;
  std::string out;
  if (!header_comment.empty()) out += "# " + std::string(header_comment) + "\n";
  out += "# tacmap touch protocol manifest: key = value (format: data/README.md)\n";
  out += "format = tacmap-protocol 1\n";
  out += "map = " + p.map_file + "\n";
  out += "mm_per_px = " + shortest(p.mm_per_px) + "\n";
  out += std::string("relief = ") +
         (p.relief.kind == relief_kind::binary ? "binary" : "continuous") + "\n";
  out += "relief_threshold = " + shortest(static_cast<double>(p.relief.threshold)) + "\n";
  out += "relief_height_mm = " + shortest(p.relief.height_mm) + "\n";
  out += "relief_edge_smoothing_px = " + shortest(p.relief.edge_smoothing_px) + "\n";
  out += "locations = " + p.locations_file + "\n";
  out += "sequences = " + p.sequences_file + "\n";
  out += "readings_per_location = " + std::to_string(p.readings_per_location) + "\n";
  out += "odometry_sigma_mm = " + shortest(p.odometry_sigma_mm) + "\n";
  out += "seed = " + std::to_string(p.seed) + "\n";
  return out;
}

/// The locations table of `locations` (4 decimals, i.e. 0.1 um).
[[nodiscard]] inline std::string format_locations(const std::vector<touch_location>& locations) {
  using detail::protocol_io::fixed;
  std::string out =
      "# tacmap touch locations: sensor centre in the map frame (x right, y down), "
      "mm\n# location x_mm y_mm\n";
  for (std::size_t i = 0; i < locations.size(); ++i)
    out += std::to_string(i) + " " + fixed(locations[i].x_mm, 4) + " " +
           fixed(locations[i].y_mm, 4) + "\n";
  return out;
}

/// The sequences table of `sequences` (4 decimals).
[[nodiscard]] inline std::string format_sequences(const std::vector<touch_sequence>& sequences) {
  using detail::protocol_io::fixed;
  std::string out =
      "# tacmap touch sequences: the move (mm, map frame) from the previous step's "
      "location, true and as measured\n"
      "# sequence step location true_dx_mm true_dy_mm measured_dx_mm "
      "measured_dy_mm\n";
  for (std::size_t s = 0; s < sequences.size(); ++s)
    for (std::size_t k = 0; k < sequences[s].size(); ++k) {
      const protocol_step& step = sequences[s][k];
      out += std::to_string(s) + " " + std::to_string(k) + " " + std::to_string(step.location) +
             " " + fixed(step.true_motion.dx_mm, 4) + " " + fixed(step.true_motion.dy_mm, 4) + " " +
             fixed(step.measured_motion.dx_mm, 4) + " " + fixed(step.measured_motion.dy_mm, 4) +
             "\n";
    }
  return out;
}

}  // namespace tacmap
