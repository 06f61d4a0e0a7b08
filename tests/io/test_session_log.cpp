// Session logs: the documented format, round trips, crash survival (a child process that dies
// mid-session), and clear errors for every kind of damaged log.
#include <doctest/doctest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "tacmap/io/session_log.hpp"

namespace test_session_log {

namespace {

namespace fs = std::filesystem;
using tacmap::sensor_pose;
using tacmap::session_header;
using tacmap::session_log_error;
using tacmap::session_reader;
using tacmap::session_recorder;
using tacmap::tactile_frame;

/// A fresh temporary folder, removed with its contents at scope exit.
struct temp_dir {
  fs::path path;
  temp_dir() {
    std::string pattern = (fs::temp_directory_path() / "tacmap-session-XXXXXX").string();
    REQUIRE(::mkdtemp(pattern.data()) != nullptr);
    path = pattern;
  }
  ~temp_dir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  temp_dir(const temp_dir&) = delete;
  temp_dir& operator=(const temp_dir&) = delete;
};

tacmap::taxel_geometry small_geometry() { return {.rows = 3, .cols = 2, .pitch_mm = 3.4}; }

session_header full_header() {
  session_header h;
  h.geometry = small_geometry();
  h.map_file = "maps/gecko map.pgm";
  h.mm_per_px = 3.4 / 3.0;
  h.calibration = tacmap::map_calibration::horizontal(0.25, {12.5, -3.0}, 1.01);
  h.extra = {{"source", "unit test"}, {"operator", "tacmap"}, {"empty_value", ""}};
  return h;
}

tactile_frame frame_with(float base, std::uint32_t seq, long long t_ns) {
  tactile_frame f;
  f.geometry = small_geometry();
  f.counts.resize(3, 2);
  f.counts << base, 0.1F, 4095.0F, 1e-7F, 3.0F * base, 0.0F;
  f.sequence = seq;
  f.timestamp = tacmap::detail::session_time_point(t_ns);
  return f;
}

sensor_pose pose_with(double x, long long t_ns) {
  return {tacmap::detail::session_time_point(t_ns), x, -1.0 / 3.0, 1e-300, -3.14159};
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_text(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out << text;
}

/// The session_log_error a reader throws over `text` (construction or reading all records).
session_log_error error_for(const std::string& text, tacmap::session_read_options options = {}) {
  std::istringstream in(text);
  try {
    session_reader r(in, "test.session", {}, options);
    (void)r.read_all();
  } catch (const session_log_error& e) {
    return e;
  }
  FAIL("no session_log_error for: " << text);
  return session_log_error("", 0, "");
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

const std::string good_header = "tacmap-session 1\ngeometry 3 2 3.4\n";

}  // namespace

TEST_CASE("session log: the file is exactly the documented text format") {
  temp_dir dir;
  const fs::path file = dir.path / "doc.session";
  {
    session_header h;
    h.geometry = small_geometry();
    h.map_file = "gecko.pgm";
    h.mm_per_px = 0.5;
    h.calibration = tacmap::map_calibration::horizontal();
    h.extra = {{"source", "unit test"}};
    session_recorder rec(file, h);
    tactile_frame f = frame_with(12.0F, 7, 1000);
    rec.record(f);
    rec.record(sensor_pose{tacmap::detail::session_time_point(2500), 12.5, -3.25, 40.0, 0.01});
  }
  CHECK(read_text(file) ==
        "tacmap-session 1\n"
        "geometry 3 2 3.4\n"
        "map gecko.pgm\n"
        "mm_per_px 0.5\n"
        "calibration 1 0 0 0 0 1 0 0 0 1\n"
        "source unit test\n"
        "frame 1000 7 12 0.1 4095 1e-07 36 0\n"
        "pose 2500 12.5 -3.25 40 0.01\n");
}

TEST_CASE("session log: round trip of header, frames and poses, bit for bit") {
  temp_dir dir;
  const fs::path file = dir.path / "round.session";
  std::vector<tacmap::session_record> written;
  {
    session_recorder rec(file, full_header());
    written.emplace_back(frame_with(1234.5F, 0, 1'718'000'000'000'000'000LL));
    written.emplace_back(pose_with(0.1, 1'718'000'000'000'000'001LL));
    written.emplace_back(pose_with(-2.5e10, -42));
    // The largest timestamp a log may hold, 2^62 ns (larger ones are refused: see below).
    written.emplace_back(frame_with(std::numeric_limits<float>::denorm_min(), 4'294'967'295U,
                                    std::int64_t{1} << 62));
    for (const auto& r : written) rec.record(r);
    CHECK(rec.records() == 4);
  }
  session_reader reader(file);
  CHECK(reader.header() == full_header());
  CHECK(reader.header().value("source") == "unit test");
  CHECK(reader.header().value("missing") == std::nullopt);
  CHECK(reader.map_path() == dir.path / "maps/gecko map.pgm");
  const auto read = reader.read_all();
  REQUIRE(read.size() == written.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    CAPTURE(i);
    REQUIRE(read[i].index() == written[i].index());
    if (const auto* f = std::get_if<tactile_frame>(&read[i])) {
      const auto& w = std::get<tactile_frame>(written[i]);
      CHECK(f->geometry == w.geometry);
      CHECK((f->counts == w.counts).all());
      CHECK(f->sequence == w.sequence);
      CHECK(f->timestamp == w.timestamp);
    } else {
      CHECK(std::get<sensor_pose>(read[i]) == std::get<sensor_pose>(written[i]));
    }
  }
  CHECK(reader.stats().frames == 2);
  CHECK(reader.stats().poses == 2);
  CHECK_FALSE(reader.next());
  CHECK_FALSE(reader.next());
}

TEST_CASE("session log: a header-only session reads as no records") {
  temp_dir dir;
  const fs::path file = dir.path / "empty.session";
  { session_recorder rec(file, session_header{}); }
  session_reader reader(file);
  CHECK_FALSE(reader.header().geometry);
  CHECK(reader.map_path().empty());
  CHECK_FALSE(reader.next());
}

TEST_CASE("session log: everything recorded survives the process aborting mid-session") {
  temp_dir dir;
  const fs::path file = dir.path / "crash.session";
  constexpr int written_before_crash = 25;
  const pid_t child = ::fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    rlimit no_core{0, 0};
    ::setrlimit(RLIMIT_CORE, &no_core);
    ::signal(SIGABRT, SIG_DFL);  // doctest's crash handler must not report the child's abort
    try {
      session_recorder rec(file, full_header());
      for (int i = 0; i < written_before_crash; ++i) {
        if (i % 2 == 0)
          rec.record(frame_with(static_cast<float>(i), static_cast<std::uint32_t>(i), i));
        else
          rec.record(pose_with(i, i));
      }
      std::abort();  // no destructor, no fclose: only what record() already flushed survives
    } catch (...) {
      ::_exit(2);  // never return into the test runner from the child
    }
  }
  int status = 0;
  REQUIRE(::waitpid(child, &status, 0) == child);
  REQUIRE(WIFSIGNALED(status));
  CHECK(WTERMSIG(status) == SIGABRT);
  session_reader reader(file);
  const auto records = reader.read_all();
  REQUIRE(records.size() == written_before_crash);
  for (int i = 0; i < written_before_crash; ++i) {
    if (i % 2 == 0)
      CHECK(std::get<tactile_frame>(records[static_cast<std::size_t>(i)]).sequence ==
            static_cast<std::uint32_t>(i));
    else
      CHECK(std::get<sensor_pose>(records[static_cast<std::size_t>(i)]).x_mm == i);
  }
}

TEST_CASE("session log: a recorder killed at a random moment loses nothing it reported written") {
  temp_dir dir;
  const fs::path file = dir.path / "killed.session";
  int pipe_fds[2];
  REQUIRE(::pipe(pipe_fds) == 0);
  const pid_t child = ::fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    ::close(pipe_fds[0]);
    try {
      session_recorder rec(file, full_header());
      for (std::uint32_t i = 0;; ++i) {
        rec.record(frame_with(1.0F, i, static_cast<long long>(i)));
        const char tick = 'r';
        if (::write(pipe_fds[1], &tick, 1) != 1) ::_exit(3);  // the parent is gone
      }
    } catch (...) {
      ::_exit(2);
    }
  }
  ::close(pipe_fds[1]);
  // Let the child report 200 records, then kill it without warning while it keeps writing.
  int reported = 0;
  char tick = 0;
  while (reported < 200 && ::read(pipe_fds[0], &tick, 1) == 1) ++reported;
  ::kill(child, SIGKILL);
  int status = 0;
  REQUIRE(::waitpid(child, &status, 0) == child);
  while (::read(pipe_fds[0], &tick, 1) == 1) ++reported;  // ticks sent before the kill landed
  ::close(pipe_fds[0]);
  CHECK(WIFSIGNALED(status));
  session_reader reader(file, {.accept_truncated_tail = true});
  std::uint32_t expected = 0;
  while (auto f = reader.next_frame()) {
    REQUIRE(f->sequence == expected);  // in order, none missing, none damaged
    ++expected;
  }
  CHECK(static_cast<int>(expected) >= reported);
}

TEST_CASE("session log: a cut-off last line is an error naming it, or dropped on request") {
  temp_dir dir;
  const fs::path file = dir.path / "cut.session";
  {
    session_recorder rec(file, full_header());
    rec.record(pose_with(1.0, 1));
    rec.record(frame_with(5.0F, 1, 2));
    rec.record(pose_with(2.0, 3));
  }
  std::string text = read_text(file);
  text.resize(text.size() - 6);  // the process died while writing the last pose
  write_text(file, text);
  const std::size_t last_line = 11;  // 8 header lines + 3 records

  std::vector<double> seen;
  try {
    session_reader strict(file);
    while (auto r = strict.next())
      if (auto* p = std::get_if<sensor_pose>(&*r)) seen.push_back(p->x_mm);
    FAIL("a cut-off line was accepted");
  } catch (const session_log_error& e) {
    CHECK(e.line() == last_line);
    CHECK(contains(e.what(), "line 11"));
    CHECK(contains(e.what(), "cut off"));
    CHECK(contains(e.what(), "accept_truncated_tail"));
  }
  CHECK(seen == std::vector<double>{1.0});  // the complete records came first

  session_reader lenient(file, {.accept_truncated_tail = true});
  CHECK(lenient.read_all().size() == 2);
  CHECK(lenient.stats().truncated_line == last_line);
  CHECK(lenient.stats().truncated_bytes > 0);
}

TEST_CASE("session log: a corrupt field is named with its line, and the reader can skip past it") {
  const std::string text = good_header +
                           "pose 10 1 2 3 0\n"
                           "pose 20 1 12.x 3 0\n"
                           "pose 30 4 5 6 0\n";
  std::istringstream in(text);
  session_reader reader(in, "walk.session");
  CHECK(reader.next_pose()->x_mm == 1.0);
  try {
    (void)reader.next();
    FAIL("a corrupt field was accepted");
  } catch (const session_log_error& e) {
    CHECK(e.line() == 4);
    CHECK(e.field() == "field 4 (y_mm)");
    CHECK(contains(e.what(), "session log walk.session, line 4, field 4 (y_mm): '12.x'"));
    CHECK(contains(e.what(), "not a decimal number"));
  }
  CHECK(reader.next_pose()->x_mm == 4.0);  // the next record is fine
  CHECK_FALSE(reader.next());
}

TEST_CASE("session log: corrupt records of every kind name line and field") {
  struct example {
    std::string body;
    std::uint64_t line;
    std::string expected;
  };
  const std::vector<example> examples = {
      {"pose 10 1 2 3\n", 3, "a pose record with 4 values; expected 5"},
      {"pose 10 1 2 3 4 5\n", 3, "a pose record with 6 values"},
      {"pose x 1 2 3 4\n", 3, "field 2 (t_ns): 'x'"},
      {"pose 99999999999999999999 1 2 3 4\n", 3, "not an integer in range"},
      {"pose 1 1e999 2 3 4\n", 3, "field 3 (x_mm)"},
      {"frame 1 2 1 2 3 4 5\n", 3, "5 taxel values; expected 6 (geometry 3 x 2)"},
      {"frame 1 -2 1 2 3 4 5 6\n", 3, "field 3 (seq)"},
      {"frame 1 2 1 2 3 -4 5 6\n", 3, "field 7 (taxel (1, 1)): taxel (1, 1) = -4"},
      {"frame 1 2 1 2 3 0x4 5 6\n", 3, "field 7 (taxel (1, 1)): '0x4'"},
      {"pose 1 2 3 4 5\nposer 1 2 3 4 5\n", 4, "'poser' is not a record type"},
      {"pose 1 2 3 4 5\nmap other.pgm\n", 4, "header lines such as 'map ...' go before"},
      {"pose 1 2 3 4 5\n\n", 4, "the line is empty"},
      {"pose 1 2 3 4 5\n\x01\x02 zz\n", 4, "'\\x01\\x02' is not a record type"},
  };
  for (const auto& ex : examples) {
    CAPTURE(ex.body);
    const session_log_error e = error_for(good_header + ex.body);
    CHECK(e.line() == ex.line);
    CHECK(contains(e.what(), ex.expected));
    CHECK(contains(e.what(), "line " + std::to_string(ex.line)));
  }
}

TEST_CASE("session log: impossible timestamps are refused when reading and when writing") {
  // |t_ns| <= 2^62 (146 years): two such timestamps always differ by less than 2^63 ns.
  for (const std::string t : {"4611686018427387905", "-4611686018427387905", "9223372036854775807",
                              "-9223372036854775808"}) {
    CAPTURE(t);
    const session_log_error e = error_for(good_header + "pose 1 0 0 0 0\npose " + t + " 0 0 0 0\n");
    CHECK(e.line() == 4);
    CHECK(e.field() == "field 2 (t_ns)");
    CHECK(contains(e.what(), "line 4, field 2 (t_ns): t_ns = " + t));
    CHECK(contains(e.what(), "expected |t_ns| <= 2^62"));
    const session_log_error f = error_for(good_header + "frame " + t + " 0 1 2 3 4 5 6\n");
    CHECK(contains(f.what(), "t_ns = " + t + " in this frame record"));
  }
  std::istringstream in(good_header + "pose 4611686018427387904 0 0 0 0\n" +
                        "frame -4611686018427387904 0 1 2 3 4 5 6\n");
  session_reader edge(in, "edge.session");
  CHECK(edge.read_all().size() == 2);  // the bounds themselves are times

  temp_dir dir;
  const fs::path file = dir.path / "far.session";
  {
    session_recorder rec(file, full_header());
    CHECK_THROWS_WITH_AS(rec.record(pose_with(1.0, std::numeric_limits<long long>::max())),
                         doctest::Contains("pose timestamp 9223372036854775807 ns"),
                         std::invalid_argument);
    CHECK_THROWS_AS(rec.record(frame_with(1.0F, 3, std::numeric_limits<long long>::min())),
                    std::invalid_argument);
    rec.record(pose_with(2.0, 4));
  }
  session_reader reader(file);  // nothing of the refused records was written
  CHECK(reader.read_all().size() == 1);
}

TEST_CASE("session log: NaN and infinity are refused when writing and when reading") {
  const session_log_error pose_nan = error_for(good_header + "pose 1 2 nan 4 5\n");
  CHECK(pose_nan.field() == "field 4 (y_mm)");
  CHECK(contains(pose_nan.what(), "y_mm = nan"));
  CHECK(contains(pose_nan.what(), "expected a finite number"));
  const session_log_error frame_inf = error_for(good_header + "frame 1 2 1 inf 3 4 5 6\n");
  CHECK(contains(frame_inf.what(), "taxel (0, 1)"));
  CHECK(contains(error_for(good_header + "pose 1 2 3 4 -NaN\n").what(), "yaw_rad"));

  temp_dir dir;
  const fs::path file = dir.path / "nan.session";
  {
    session_recorder rec(file, full_header());
    rec.record(pose_with(1.0, 1));
    CHECK_THROWS_AS(rec.record(pose_with(std::nan(""), 2)), std::invalid_argument);
    tactile_frame f = frame_with(1.0F, 3, 3);
    f.counts(1, 0) = std::numeric_limits<float>::quiet_NaN();
    CHECK_THROWS_AS(rec.record(f), std::invalid_argument);
    rec.record(pose_with(2.0, 4));
  }
  session_reader reader(file);  // the refused records left no trace: the log stays valid
  const auto records = reader.read_all();
  REQUIRE(records.size() == 2);
  CHECK(std::get<sensor_pose>(records[1]).x_mm == 2.0);
}

TEST_CASE("session log: an empty file, a foreign file and unknown versions") {
  const session_log_error empty = error_for("");
  CHECK(empty.line() == 1);
  CHECK(contains(empty.what(), "the file is empty"));
  CHECK(contains(error_for("P5\n120 120\n").what(), "not a tacmap session log"));
  CHECK(contains(error_for("tacmap-session\n").what(), "exactly 'tacmap-session <version>'"));
  const session_log_error newer = error_for("tacmap-session 2\npose 1 2 3 4 5\n");
  CHECK(newer.line() == 1);
  CHECK(contains(newer.what(), "format version 2 is newer"));
  CHECK(contains(error_for("tacmap-session one\n").what(), "'one' is not a format version"));
  CHECK(contains(error_for("tacmap-session 0\n").what(), "not a format version"));
  CHECK(contains(error_for("tacmap-session 1").what(), "ends inside its header line"));
}

TEST_CASE("session log: header errors name the line") {
  struct example {
    std::string text;
    std::uint64_t line;
    std::string expected;
  };
  const std::vector<example> examples = {
      {"tacmap-session 1\nmap a.pgm\nmap b.pgm\n", 3, "'map' appears a second time"},
      {"tacmap-session 1\ngeometry 3 2\n", 2, "has 2 values; expected 3"},
      {"tacmap-session 1\ngeometry 0 2 3.4\n", 2, "expected rows, cols > 0"},
      {"tacmap-session 1\ngeometry 70000 70000 1\n", 2, "at most 65536 taxels"},
      {"tacmap-session 1\ngeometry 3 2 -1\n", 2, "pitch > 0 mm"},
      {"tacmap-session 1\nmm_per_px 0\n", 2, "mm_per_px = 0"},
      {"tacmap-session 1\ncalibration 1 0 0 1 0 0 0 0 0 1\n", 2, "not orthonormal"},
      {"tacmap-session 1\ncalibration 1 0 0 0 0 1 0 0 0\n", 2, "expected 10"},
      {"tacmap-session 1\nMap a.pgm\n", 2, "'Map' is neither a header key"},
      {"tacmap-session 1\nmap\n", 2, "map file name '' is empty"},
      {"tacmap-session 1\nframe 1 2 3\n", 2, "the header has no 'geometry' line"},
  };
  for (const auto& ex : examples) {
    CAPTURE(ex.text);
    const session_log_error e = error_for(ex.text);
    CHECK(e.line() == ex.line);
    CHECK(contains(e.what(), ex.expected));
  }
}

TEST_CASE("session log: tolerant where other tools differ (CRLF, tabs, '+', exponents)") {
  const std::string text =
      "tacmap-session 1\r\n"
      "geometry\t3 2 3.4\r\n"
      "map  spaced name.pgm  \r\n"
      "pose +10 +1.5 1E3 -0 2.5e-3\r\n";
  std::istringstream in(text);
  session_reader reader(in, "windows.session", "/data");
  CHECK(reader.header().geometry == small_geometry());
  CHECK(reader.header().map_file == "spaced name.pgm");
  CHECK(reader.map_path() == fs::path("/data/spaced name.pgm"));
  const auto p = reader.next_pose();
  REQUIRE(p);
  CHECK(p->timestamp == tacmap::detail::session_time_point(10));
  CHECK(p->x_mm == 1.5);
  CHECK(p->y_mm == 1000.0);
  CHECK(p->yaw_rad == 0.0025);
  CHECK(contains(error_for(good_header + "pose +-1 1 2 3 4\n").what(), "field 2 (t_ns)"));
}

TEST_CASE("session log: a line longer than the limit is refused before it is buffered whole") {
  const std::string text =
      good_header + "pose 1 0 0 0 0\npose " + std::string(5000, '1') + " 2 3 4 5\npose 7 1 2 3 4\n";
  const session_log_error e = error_for(text, {.max_line_bytes = 1024});
  CHECK(e.line() == 4);
  CHECK(contains(e.what(), "longer than 1024 bytes"));
  // Skipping the long line resumes at the next one, not in the middle of the long one.
  std::istringstream in(text);
  session_reader reader(in, "long.session", {}, {.max_line_bytes = 1024});
  CHECK(reader.next_pose()->x_mm == 0.0);
  CHECK_THROWS_AS(reader.next(), session_log_error);
  const auto p = reader.next_pose();
  REQUIRE(p);
  CHECK(p->x_mm == 1.0);
  CHECK(reader.stats().lines == 5);
}

TEST_CASE("session log: as a position source and a frame source") {
  const std::string text = good_header +
                           "frame 1 0 1 2 3 4 5 6\n"
                           "pose 2 1 0 0 0\n"
                           "frame 3 1 1 2 3 4 5 6\n"
                           "frame 4 2 1 2 3 4 5 6\n"
                           "pose 5 2 0 0 0\n";
  {
    std::istringstream in(text);
    session_reader poses(in);
    CHECK(poses.next_pose(std::chrono::milliseconds(5))->x_mm == 1.0);
    CHECK(poses.next_pose()->x_mm == 2.0);
    CHECK_FALSE(poses.next_pose());
    CHECK(poses.stats().frames_skipped == 3);
  }
  {
    std::istringstream in(text);
    session_reader frames(in);
    std::vector<std::uint32_t> seqs;
    while (auto f = frames.next_frame()) seqs.push_back(f->sequence);
    CHECK(seqs == std::vector<std::uint32_t>{0, 1, 2});
    CHECK(frames.stats().poses_skipped == 2);
    CHECK(frames.stats().lines == 7);
  }
}

TEST_CASE("session recorder: refuses to overwrite, to mix geometries and bad headers") {
  temp_dir dir;
  const fs::path file = dir.path / "keep.session";
  { session_recorder rec(file, full_header()); }
  try {
    session_recorder again(file, full_header());
    FAIL("an existing recording was overwritten");
  } catch (const session_log_error& e) {
    CHECK(contains(e.what(), "already exists"));
    CHECK(contains(e.what(), "overwrite"));
  }
  CHECK_NOTHROW(session_recorder(file, full_header(), {.overwrite = true}));
  CHECK_THROWS_AS(session_recorder(dir.path / "no/such/folder/x.session", full_header()),
                  session_log_error);

  session_recorder rec(dir.path / "mix.session", full_header());
  tactile_frame other;  // the default 14 x 6 array
  const std::string m = [&] {
    try {
      rec.record(other);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  }();
  CHECK(contains(m, "differs from the session's 3 x 2"));
  session_recorder no_geometry(dir.path / "nogeo.session", session_header{});
  CHECK_THROWS_AS(no_geometry.record(other), std::invalid_argument);

  session_header bad = full_header();
  bad.extra.emplace_back("pose", "x");
  CHECK_THROWS_AS(session_recorder(dir.path / "bad1.session", bad), std::invalid_argument);
  bad = full_header();
  bad.extra.emplace_back("note", "two\nlines");
  CHECK_THROWS_AS(session_recorder(dir.path / "bad2.session", bad), std::invalid_argument);
  bad = full_header();
  bad.extra.emplace_back("source", "again");
  CHECK_THROWS_AS(session_recorder(dir.path / "bad3.session", bad), std::invalid_argument);
  bad = full_header();
  bad.map_file = " lead.pgm";
  CHECK_THROWS_AS(session_recorder(dir.path / "bad4.session", bad), std::invalid_argument);
  CHECK_FALSE(fs::exists(dir.path / "bad1.session"));  // validated before the file is created
}

TEST_CASE("session recorder: moves keep recording into the same file, and close is explicit") {
  temp_dir dir;
  const fs::path file = dir.path / "moved.session";
  session_recorder a(file, full_header());
  a.record(pose_with(1.0, 1));
  session_recorder b(std::move(a));
  b.record(pose_with(2.0, 2));
  CHECK(b.records() == 2);
  b.close();
  CHECK_FALSE(b.is_open());
  CHECK_THROWS_AS(b.record(pose_with(3.0, 3)), session_log_error);
  session_reader reader(file);
  CHECK(reader.read_all().size() == 2);
  CHECK_THROWS_AS(session_reader(dir.path / "missing.session"), session_log_error);
  try {
    session_reader folder(dir.path);
    FAIL("a folder was read as a session log");
  } catch (const session_log_error& e) {
    CHECK(contains(e.what(), "is a folder"));
  }
}

}  // namespace test_session_log
