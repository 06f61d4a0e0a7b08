// The protocol loader's error messages: each names the FILE, the LINE and the FIELD.
#include <doctest/doctest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "tacmap/sim/protocol.hpp"
#include "test_support.hpp"

namespace test_protocol {

using tacmap_test::message_of;

namespace {

// A scratch folder per test case, removed afterwards.
struct scratch {
  std::filesystem::path dir;
  explicit scratch(const std::string& name)
      : dir(std::filesystem::temp_directory_path() /
            ("tacmap_sim_" + name + "_" +
             std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()))) {
    std::filesystem::create_directories(dir);
  }
  ~scratch() {
    std::error_code ignored;
    std::filesystem::remove_all(dir, ignored);
  }
  scratch(const scratch&) = delete;
  scratch& operator=(const scratch&) = delete;

  std::filesystem::path write(const std::string& name, const std::string& text) const {
    std::ofstream(dir / name, std::ios::binary) << text;
    return dir / name;
  }
};

bool contains(const std::string& text, const std::string& part) {
  const bool found = text.find(part) != std::string::npos;
  if (!found) MESSAGE("'", part, "' not in: ", text);
  return found;
}

constexpr tacmap::pixel_size paper_map{.width = 120, .height = 120};
constexpr double s = 3.4 / 3.0;

const std::string good_locations =
    "# header\n0 40.0 50.0\n1 60.0 70.5   # a comment\n\n2 80.0 30.0\n";

tacmap::image<float> small_map() { return tacmap::image<float>::Constant(120, 120, 0.2F); }

std::string manifest(const std::string& extra = "") {
  return "format = tacmap-protocol 1\nmap = map.pgm\nmm_per_px = 1.1333333333333333\n"
         "locations = locations.txt\nsequences = sequences.txt\n" +
         extra;
}

}  // namespace

TEST_CASE("locations: a good table reads back, comments and blanks skipped") {
  scratch tmp("locations_good");
  const auto path = tmp.write("locations.txt", good_locations);
  const auto locs = tacmap::load_locations(path, paper_map, s);
  REQUIRE(locs.size() == 3);
  CHECK(locs[1] == tacmap::touch_location{60.0, 70.5});
  CHECK(locs[2].pose().theta_rad == 0.0);
  // format_locations is the inverse of load_locations.
  const auto again =
      tacmap::load_locations(tmp.write("again.txt", tacmap::format_locations(locs)), paper_map, s);
  CHECK(again == locs);
}

TEST_CASE("locations: errors name the file, the line and the field") {
  scratch tmp("locations_bad");
  const auto check = [&](const std::string& text, const std::string& line_part,
                         const std::string& detail) {
    const auto path = tmp.write("loc.txt", text);
    const std::string msg = message_of([&] { (void)tacmap::load_locations(path, paper_map, s); });
    CHECK(contains(msg, path.string()));
    CHECK(contains(msg, line_part));
    CHECK(contains(msg, detail));
  };
  check("", "loc.txt", "is empty");
  check("# only a comment\n\n", "loc.txt", "is empty");
  check("0 40 50\n1 60 70 9\n", "loc.txt:2:", "found 4 fields; expected 3 fields");
  check("0 40 50\n1 60\n", "loc.txt:2:", "found 2 fields");
  check("0 40 50\n\n1 sixty 70\n", "loc.txt:3:", "field 'x_mm' = 'sixty' is not a number");
  check("0 40 50\n1 60 70mm\n", "loc.txt:2:", "field 'y_mm' = '70mm' is not a number");
  check("0 40 nan\n", "loc.txt:1:", "field 'y_mm' = 'nan' is not finite");
  check("0 inf 50\n", "loc.txt:1:", "field 'x_mm' = 'inf' is not finite");
  check("0 40 50\n2 60 70\n", "loc.txt:2:", "field 'location' = 2; expected 1");
  check("-1 40 50\n", "loc.txt:1:", "field 'location' = '-1' is not a whole number");
  // Off the map: the 20.4 mm wide footprint centred at x = 5 starts at -5.2 mm.
  check("0 40 50\n1 5 50\n", "loc.txt:2:", "field 'x_mm' = 5 puts the 20.4 mm wide");
  check("0 40 50\n1 40 120\n", "loc.txt:2:", "field 'y_mm' = 120 puts the 47.6 mm tall");
  const std::string missing =
      message_of([&] { (void)tacmap::load_locations(tmp.dir / "nope.txt", paper_map, s); });
  CHECK(contains(missing, "nope.txt"));
  CHECK(contains(missing, "cannot open"));
}

TEST_CASE("sequences: errors name the file, the line and the field") {
  scratch tmp("sequences_bad");
  const auto locs = tacmap::load_locations(tmp.write("l.txt", good_locations), paper_map, s);
  // Location 0 -> 1 moves by (20, 20.5).
  const std::string ok = "0 0 0 0 0 0 0\n0 1 1 20 20.5 20.3 20.1\n1 0 2 0 0 0 0\n";
  const auto seqs = tacmap::load_sequences(tmp.write("ok.txt", ok), locs);
  REQUIRE(seqs.size() == 2);
  CHECK(seqs[0].size() == 2);
  CHECK(seqs[0][1].location == 1);
  CHECK(seqs[0][1].measured_motion.dx_mm == 20.3);
  CHECK(seqs[1][0].location == 2);
  CHECK(
      tacmap::load_sequences(tmp.write("again.txt", tacmap::format_sequences(seqs)), locs).size() ==
      2);

  const auto check = [&](const std::string& text, const std::string& line_part,
                         const std::string& detail) {
    const auto path = tmp.write("seq.txt", text);
    const std::string msg = message_of([&] { (void)tacmap::load_sequences(path, locs); });
    CHECK(contains(msg, path.string()));
    CHECK(contains(msg, line_part));
    CHECK(contains(msg, detail));
  };
  check("  \n# nothing\n", "seq.txt", "is empty");
  check("0 0 0 0 0 0\n", "seq.txt:1:", "found 6 fields; expected 7");
  check("0 0 0 0 0 0 0\n0 1 1 20 20.5 x 20\n",
        "seq.txt:2:", "field 'measured_dx_mm' = 'x' is not a number");
  check("0 0 0 0 0 0 0\n0 1 1 20 20.5 20 NaN\n",
        "seq.txt:2:", "field 'measured_dy_mm' = 'NaN' is not finite");
  check("0 0 0 0 0 0 0\n0 1 7 20 20.5 20 20\n", "seq.txt:2:", "field 'location' = 7");
  check("0 0 0 0 0 0 0\n0 2 1 20 20.5 20 20\n", "seq.txt:2:", "field 'step' = 2; expected 1");
  check("0 0 0 0 0 0 0\n2 0 1 0 0 0 0\n", "seq.txt:2:", "field 'sequence' = 2");
  check("1 0 0 0 0 0 0\n", "seq.txt:1:", "field 'sequence' = 1; expected 0");
  check("0 1 0 0 0 0 0\n", "seq.txt:1:", "field 'step' = 1; expected 0");
  check("0 0 0 0 0 0 0\n0 1 1 25 20.5 20 20\n", "seq.txt:2:", "field 'true_dx_mm' = 25");
  check("0 0 0 0 0 0 0\n0 1 1 20 -20.5 20 20\n", "seq.txt:2:", "field 'true_dy_mm' = -20.5");
  check("0 0 0 1 0 0 0\n", "seq.txt:1:", "field 'true_dx_mm' = 1");
  check("0 0 0 0 0 0.5 0\n", "seq.txt:1:", "'measured_dx_mm measured_dy_mm' = 0.5 0");
}

TEST_CASE("manifest: a whole protocol loads; errors name the file, the line and the key") {
  scratch tmp("manifest");
  tacmap::write_pgm(tmp.dir / "map.pgm", small_map());
  tmp.write("locations.txt", good_locations);
  tmp.write("sequences.txt", "0 0 2 0 0 0 0\n0 1 0 -40 20 -39.5 20.2\n");
  const auto p = tacmap::load_protocol(tmp.write("protocol.txt", manifest("seed = 77\n")));
  CHECK(p.map_size() == paper_map);
  CHECK(p.locations.size() == 3);
  CHECK(p.sequences.size() == 1);
  CHECK(p.seed == 77);
  CHECK(p.readings_per_location == 1);
  CHECK(p.relief.kind == tacmap::relief_kind::binary);
  // format_manifest is the inverse of the manifest parser.
  const auto again = tacmap::load_protocol(tmp.write("again.txt", tacmap::format_manifest(p)));
  CHECK(again.seed == 77);
  CHECK(again.mm_per_px == p.mm_per_px);

  const auto check = [&](const std::string& text, const std::string& line_part,
                         const std::string& detail) {
    const auto path = tmp.write("bad.txt", text);
    const std::string msg = message_of([&] { (void)tacmap::load_protocol(path); });
    CHECK(contains(msg, line_part));
    CHECK(contains(msg, detail));
  };
  check("", "bad.txt", "is empty");
  check(manifest("colour: red\n"), "bad.txt:6:", "expected a line 'key = value'");
  check(manifest("colour = red\n"), "bad.txt:6:", "unknown key 'colour'");
  check(manifest("seed = 1\nseed = 2\n"),
        "bad.txt:7:", "key 'seed' is given again (first on line 6)");
  check(
      "format = tacmap-protocol 1\nmap = map.pgm\nlocations = locations.txt\n"
      "sequences = sequences.txt\n",
      "bad.txt", "key 'mm_per_px' is missing");
  check("format = tacmap-protocol 2\n", "bad.txt:1:", "field 'format' = 'tacmap-protocol 2'");
  check(manifest("relief = bumpy\n"), "bad.txt:6:", "field 'relief' = 'bumpy'");
  check(manifest("relief_height_mm = nan\n"),
        "bad.txt:6:", "field 'relief_height_mm' = 'nan' is not finite");
  check(manifest("readings_per_location = 2.5\n"),
        "bad.txt:6:", "field 'readings_per_location' = 2.5");
  check(manifest("seed = -3\n"), "bad.txt:6:", "field 'seed' = '-3' is not a whole number");
  check("format = tacmap-protocol 1\nmap = map.pgm\nmm_per_px = 0\n",
        "bad.txt:3:", "field 'mm_per_px' = 0");
  check("format = tacmap-protocol 1\nmap = missing.pgm\nmm_per_px = 1\n", "missing.pgm",
        "cannot open");
  // A location off this map (a 60 px map at 1.1333 mm per px is 68 mm tall).
  tacmap::write_pgm(tmp.dir / "small.pgm", tacmap::image<float>::Zero(60, 120));
  check(
      "format = tacmap-protocol 1\nmap = small.pgm\nmm_per_px = 1.1333333333333333\n"
      "locations = locations.txt\nsequences = sequences.txt\n",
      "locations.txt:2:", "field 'y_mm' = 50 puts the 47.6 mm tall sensor footprint");
}

}  // namespace test_protocol
