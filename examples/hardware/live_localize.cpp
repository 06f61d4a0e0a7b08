// live_localize — localize a tactile sensor on a map while it touches the object, live.
//
// The paper's set-up (Luo et al., ICRA 2015, Sec. IV): a Weiss 14 x 6 tactile array (a WTS
// module, or DSA pads behind a DSACON32m controller) rides on a position source (a Phantom Omni;
// or a robot arm). Each frame the sensor sends is preprocessed (Sec. IV-A: frames of the lifted
// sensor are rejected), the pose read at the same moment gives the odometry since the last touch
// (Sec. III-B), and the Bayes filter (Table 1) prints the live estimate in map millimetres.
//
// Position sources: --omni (needs OpenHaptics), --poses <session log> (the poses of a recorded
// session, one per frame), or --scripted (a zig-zag sweep over the map written in this file — it
// shows how little a `position_source` needs). Without hardware, --emulate starts an emulated
// sensor on a pseudo-terminal that presses the map wherever the position source says the sensor
// is; the real device classes then talk to it through the real serial port code. That is how
// CTest runs this example.
//
// Run:  live_localize --weiss /dev/ttyACM0 --omni --map object.pgm --calibration ...
//       live_localize --emulate --scripted --frames 20 --expect-error-mm 3
// Build with -DTACMAP_BUILD_HARDWARE_EXAMPLES=ON, in Release for real-time rates.
#include "tacmap/devices/position_source.hpp"
#include "tacmap/devices/weiss/dsacon32m.hpp"
#include "tacmap/devices/weiss/emulator.hpp"
#include "tacmap/devices/weiss/wts.hpp"
#include "tacmap/io/image_io.hpp"
#include "tacmap/io/session_log.hpp"
#include "tacmap/tacmap.hpp"

#if defined(TACMAP_HAVE_PHANTOM_OMNI)
#include "tacmap/devices/phantom_omni_hdapi.hpp"
#endif

#include <cerrno>
#include <chrono>
#include <cmath>
#include <concepts>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#ifndef TACMAP_DEMO_MAP
#define TACMAP_DEMO_MAP "data/sessions/replay_demo_map.pgm"
#endif

namespace {

namespace fs = std::filesystem;
namespace weiss = tacmap::weiss;
using namespace std::chrono_literals;
using grid_t = tacmap::planar_grid<float>;

const char* const usage =
    "usage: live_localize (--weiss PATH | --emulate) (--omni [NAME] | --poses LOG | --scripted)\n"
    "                     [--family wts|dsacon32m] [--tool-offset X Y Z] [--map FILE.pgm]\n"
    "                     [--mm-per-px S]\n"
    "                     [--calibration UX UY UZ VX VY VZ ROT TX TY SCALE] [--frames N]\n"
    "                     [--period-ms P] [--record LOG] [--expect-error-mm E]\n"
    "                     [--accept-truncated-tail]\n"
    "  --weiss PATH      the tactile sensor's serial port, e.g. /dev/ttyACM0\n"
    "  --emulate         an emulated sensor pressing the map where the position source says\n"
    "  --family F        wts (default) or dsacon32m\n"
    "  --omni [NAME]     a Phantom Omni through OpenHaptics (default device without NAME)\n"
    "  --tool-offset X Y Z  Omni: gimbal centre -> sensor centre in the stylus frame (mm)\n"
    "  --poses LOG       the poses of a recorded session, one per frame (its calibration too)\n"
    "  --scripted        a zig-zag sweep over the map, one map pixel per frame\n"
    "  --map FILE.pgm    the visual map (default: the demo session's map)\n"
    "  --mm-per-px S     the map's scale (default 3.4/3, or the session's)\n"
    "  --calibration ... device frame -> map frame (default: the session's, else the table plane)\n"
    "  --accept-truncated-tail  --poses: read a log whose last line a crash cut off, without\n"
    "                    that line (default: refuse it)\n"
    "  --frames N        stop after N frames, 1 .. 1000000000 (default: when the position\n"
    "                    source ends)\n"
    "  --period-ms P     WTS frame period, 1 .. 65535 ms (default 20 ms)\n"
    "  --record LOG      record frames and poses as a session log (replay_localize reads it)\n"
    "  --expect-error-mm E  exit 1 unless the final estimate is within E mm of the calibrated\n"
    "                    pose (for tests with a known calibration)\n";

struct config {
  std::string weiss_path;
  weiss::protocol_family family = weiss::protocol_family::wts;
  bool emulate = false;
  enum class source { none, omni, poses, scripted } pose_source = source::none;
  std::string omni_name;
  Eigen::Vector3d tool_offset_mm = Eigen::Vector3d::Zero();
  fs::path poses_file;
  fs::path map = TACMAP_DEMO_MAP;
  std::optional<double> mm_per_px;
  std::optional<tacmap::map_calibration> calibration;
  long frames = -1;
  int period_ms = 20;
  fs::path record;
  std::optional<double> expect_error_mm;
  bool accept_truncated_tail = false;
};

[[noreturn]] void bad_usage(const std::string& why) {
  std::fprintf(stderr, "live_localize: %s\n%s", why.c_str(), usage);
  std::exit(2);
}

/// A whole number in [lo, hi]: "3.7", "1e30" and "-5" are refused, never truncated or wrapped.
long integer(const char* text, const char* option, long lo, long hi) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text, &end, 10);
  if (end == text || *end != '\0' || errno == ERANGE || v < lo || v > hi)
    bad_usage(std::string(option) + " expects a whole number in " + std::to_string(lo) + " .. " +
              std::to_string(hi) + ", got '" + text + "'");
  return v;
}

double number(const char* text, const char* option) {
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || !std::isfinite(v))
    bad_usage(std::string(option) + " expects a number, got '" + text + "'");
  return v;
}

config parse(int argc, char** argv) {
  config c;
  const auto value = [&](int& i) -> const char* {
    if (i + 1 >= argc) bad_usage(std::string(argv[i]) + " needs a value");
    return argv[++i];
  };
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(usage, stdout);
      std::exit(0);
    } else if (a == "--weiss") {
      c.weiss_path = value(i);
    } else if (a == "--emulate") {
      c.emulate = true;
    } else if (a == "--family") {
      const std::string f = value(i);
      if (f == "wts")
        c.family = weiss::protocol_family::wts;
      else if (f == "dsacon32m")
        c.family = weiss::protocol_family::dsacon32m;
      else
        bad_usage("--family is wts or dsacon32m, not '" + f + "'");
    } else if (a == "--omni") {
      c.pose_source = config::source::omni;
      if (i + 1 < argc && argv[i + 1][0] != '-') c.omni_name = argv[++i];
    } else if (a == "--tool-offset") {
      for (int k = 0; k < 3; ++k) c.tool_offset_mm(k) = number(value(i), "--tool-offset");
    } else if (a == "--poses") {
      c.pose_source = config::source::poses;
      c.poses_file = value(i);
    } else if (a == "--scripted") {
      c.pose_source = config::source::scripted;
    } else if (a == "--map") {
      c.map = value(i);
    } else if (a == "--mm-per-px") {
      c.mm_per_px = number(value(i), "--mm-per-px");
    } else if (a == "--calibration") {
      std::array<double, 10> v{};
      for (double& x : v) x = number(value(i), "--calibration");
      tacmap::map_calibration cal;
      cal.plane_axes << v[0], v[1], v[2], v[3], v[4], v[5];
      cal.rotation_rad = v[6];
      cal.translation_mm = {v[7], v[8]};
      cal.scale = v[9];
      c.calibration = cal;
    } else if (a == "--frames") {
      c.frames = integer(value(i), "--frames", 1, 1'000'000'000);
    } else if (a == "--period-ms") {
      // The WTS start-periodic command carries the period as a u16 in ms.
      c.period_ms = static_cast<int>(integer(value(i), "--period-ms", 1, 65535));
    } else if (a == "--accept-truncated-tail") {
      c.accept_truncated_tail = true;
    } else if (a == "--record") {
      c.record = value(i);
    } else if (a == "--expect-error-mm") {
      c.expect_error_mm = number(value(i), "--expect-error-mm");
    } else {
      bad_usage("unknown argument '" + a + "'");
    }
  }
  if (c.emulate == !c.weiss_path.empty())
    bad_usage("give exactly one of --weiss PATH and --emulate");
  if (c.pose_source == config::source::none)
    bad_usage("give a position source: --omni, --poses LOG or --scripted");
#if !defined(TACMAP_HAVE_PHANTOM_OMNI)
  if (c.pose_source == config::source::omni)
    bad_usage("--omni needs OpenHaptics: install it and reconfigure (CMake looks for HD/hd.h)");
#endif
  if (c.emulate && c.pose_source == config::source::omni)
    bad_usage("--emulate presses where a known position source says; use --scripted or --poses");
  return c;
}

/// A position source written for this example: the sensor sweeps the map in a zig-zag, one map
/// pixel per frame. Anything with `next_pose(timeout) -> std::optional<sensor_pose>` will do.
class sweep_source {
 public:
  sweep_source(const grid_t& grid, tacmap::map_calibration calibration)
      : grid_(grid), calibration_(std::move(calibration)) {}

  /// The window (top-left map pixel) of step k: a triangle wave across, a slower one down.
  static tacmap::grid_cell window(const grid_t& grid, long k) {
    const auto triangle = [](long x, long amplitude) {
      const long t = x % (2 * amplitude);
      return t < amplitude ? t : 2 * amplitude - t;
    };
    const long cols = std::min<long>(40, static_cast<long>(grid.cols()) - 1);
    const long rows = std::min<long>(20, static_cast<long>(grid.rows()) - 1);
    return {triangle(k / 4, rows) + std::min<Eigen::Index>(30, grid.rows() - 1 - rows),
            triangle(k, cols) + std::min<Eigen::Index>(20, grid.cols() - 1 - cols)};
  }

  std::optional<tacmap::sensor_pose> next_pose(std::chrono::milliseconds /*timeout*/) {
    const Eigen::Vector3d p =
        calibration_.to_device_mm(grid_.state_mm(grid_.index(window(grid_, step_++))), 0.0);
    return tacmap::sensor_pose{tacmap::sensor_pose::clock::now(), p.x(), p.y(), p.z(), 0.0};
  }

 private:
  grid_t grid_;
  tacmap::map_calibration calibration_;
  long step_ = 0;
};
static_assert(tacmap::position_source<sweep_source>);

/// Raw counts of the 14 x 6 array pressed on the map with its window's top-left pixel at
/// `at` (each taxel averages the map pixels it covers), in the emulator's wire order.
std::vector<std::uint16_t> press(const tacmap::image<float>& map, const tacmap::taxel_geometry& g,
                                 double mm_per_px, tacmap::grid_cell at) {
  const double px_per_taxel = g.pitch_mm / mm_per_px;
  std::vector<std::uint16_t> cells;
  for (Eigen::Index i = 0; i < g.rows; ++i)
    for (Eigen::Index j = 0; j < g.cols; ++j) {
      const auto r0 =
          at.row + static_cast<Eigen::Index>(std::floor(static_cast<double>(i) * px_per_taxel));
      const auto c0 =
          at.col + static_cast<Eigen::Index>(std::floor(static_cast<double>(j) * px_per_taxel));
      const auto n = std::max<Eigen::Index>(1, static_cast<Eigen::Index>(std::floor(px_per_taxel)));
      const double v =
          map.block(std::min(r0, map.rows() - n), std::min(c0, map.cols() - n), n, n).mean();
      cells.push_back(static_cast<std::uint16_t>(std::lround(150.0 + 3700.0 * v)));
    }
  return cells;
}

/// The live loop, for any tactile device and any position source.
template <class Sensor, tacmap::position_source Source>
int run(Sensor& sensor, Source& source, const config& c, const tacmap::image<float>& map,
        double mm_per_px, const tacmap::map_calibration& calibration) {
  const tacmap::taxel_geometry geometry = sensor.geometry();
  const tacmap::pixel_size window = tacmap::tactile_window(geometry, mm_per_px);
  const grid_t grid({.width = map.cols(), .height = map.rows()}, mm_per_px, window);
  tacmap::bayes_filter filter(
      grid, tacmap::odometry_gaussian({.sigma_mm = 1.0, .k = 8}),
      tacmap::ncc_likelihood<float>(map, window, {.tau = 0.1, .tempering = 1.0}));
  tacmap::preprocess_params pre;
  pre.mm_per_px = mm_per_px;

  std::optional<tacmap::session_recorder> recorder;
  if (!c.record.empty()) {
    tacmap::session_header h;
    h.geometry = geometry;
    const fs::path folder = fs::absolute(c.record).parent_path();
    h.map_file = fs::relative(fs::absolute(c.map), folder).generic_string();
    h.mm_per_px = mm_per_px;
    h.calibration = calibration;
    h.extra = {{"source", "examples/hardware/live_localize"}};
    recorder.emplace(c.record, h);
  }

  std::printf("frame  accepted  MAP (mm)          pose on map (mm)  error (mm)  entropy\n");
  std::optional<tacmap::sensor_pose> last_touch;
  double error_mm = -1.0;
  long used = 0;
  for (long n = 0; c.frames < 0 || n < c.frames; ++n) {
    const tacmap::tactile_frame frame = sensor.next_frame(1000ms);
    std::optional<tacmap::sensor_pose> pose = source.next_pose(100ms);
    if (!pose) {
      std::printf("the position source has ended\n");
      break;
    }
    // A replayed pose happens now, in this session: put it on this session's clock.
    if constexpr (std::same_as<Source, tacmap::session_reader>)
      pose->timestamp = tacmap::sensor_pose::clock::now();
    if (recorder) {
      recorder->record(frame);
      recorder->record(*pose);
    }
    const tacmap::preprocessed_frame p = tacmap::preprocess(frame, pre);
    if (!p.accepted()) {
      std::printf("%5u  no (%s)\n", frame.sequence, p.reason().c_str());
      continue;
    }
    if (last_touch)
      filter.predict(tacmap::odometry_between(*last_touch, *pose, calibration).control());
    filter.update(p.pixels);
    last_touch = pose;
    ++used;
    const auto e = filter.estimate();
    const Eigen::Vector2d on_map = calibration.to_map_mm(*pose);
    error_mm = (e.map_mm - on_map).norm();
    std::printf("%5u  yes       (%6.1f, %6.1f)  (%6.1f, %6.1f)  %9.2f  %7.2f\n", frame.sequence,
                e.map_mm.x(), e.map_mm.y(), on_map.x(), on_map.y(), error_mm, e.entropy_nats);
  }
  if (c.expect_error_mm) {
    if (used == 0 || !(error_mm < *c.expect_error_mm)) {
      std::printf("FAILED: final error %.2f mm after %ld touches, expected below %.2f mm\n",
                  error_mm, used, *c.expect_error_mm);
      return 1;
    }
    std::printf("localized: final error %.2f mm after %ld touches\n", error_mm, used);
  }
  return 0;
}

template <class Source>
int with_sensor(const config& c, Source& source, const tacmap::image<float>& map, double mm_per_px,
                const tacmap::map_calibration& calibration, const std::string& path) {
  weiss::device_options options;
  if (c.family == weiss::protocol_family::wts) {
    weiss::wts_device sensor(path, options);
    sensor.start_periodic(std::chrono::milliseconds(c.period_ms));
    return run(sensor, source, c, map, mm_per_px, calibration);
  }
  weiss::dsacon32m_device sensor(path, options);
  sensor.start_periodic();
  return run(sensor, source, c, map, mm_per_px, calibration);
}

int live(const config& c) {
  const tacmap::image<float> map = tacmap::read_pgm(c.map);
  std::optional<tacmap::session_reader> log;
  const tacmap::session_read_options read_options{.accept_truncated_tail = c.accept_truncated_tail};
  if (c.pose_source == config::source::poses) log.emplace(c.poses_file, read_options);
  double mm_per_px = 3.4 / 3.0;
  if (log && log->header().mm_per_px) mm_per_px = *log->header().mm_per_px;
  if (c.mm_per_px) mm_per_px = *c.mm_per_px;
  tacmap::map_calibration calibration = tacmap::map_calibration::horizontal();
  if (log && log->header().calibration) calibration = *log->header().calibration;
  if (c.calibration) calibration = *c.calibration;
  calibration.validate();
  const tacmap::taxel_geometry geometry{};  // the emulated sensor: the paper's 14 x 6 array
  const grid_t grid({.width = map.cols(), .height = map.rows()}, mm_per_px,
                    tacmap::tactile_window(geometry, mm_per_px));

  // Where the emulated sensor presses at frame k: the window under pose k of the source.
  std::unique_ptr<weiss::emulator> emulated;
  if (c.emulate) {
    std::function<tacmap::grid_cell(std::uint32_t)> window_at;
    if (c.pose_source == config::source::scripted) {
      window_at = [grid](std::uint32_t k) { return sweep_source::window(grid, k); };
    } else {
      std::vector<tacmap::grid_cell> windows;  // read the log's poses once more, ahead
      tacmap::session_reader ahead(c.poses_file, read_options);
      while (auto p = ahead.next_pose()) {
        const auto s =
            grid.nearest_state(calibration.to_map_mm(*p).x(), calibration.to_map_mm(*p).y());
        windows.push_back(s ? grid.cell(*s) : tacmap::grid_cell{0, 0});
      }
      if (windows.empty()) windows.push_back({0, 0});
      window_at = [windows](std::uint32_t k) {
        return windows[std::min<std::size_t>(k, windows.size() - 1)];
      };
    }
    weiss::emulator_options o;
    o.family = c.family;
    o.render = [&map, geometry, mm_per_px, window_at](const weiss::render_request& r) {
      return press(map, geometry, mm_per_px, window_at(r.frame_index));
    };
    emulated = std::make_unique<weiss::emulator>(o);
    std::printf("emulated %s on %s\n", std::string(weiss::family_name(c.family)).c_str(),
                emulated->path().c_str());
  }
  const std::string path = c.emulate ? emulated->path() : c.weiss_path;

  switch (c.pose_source) {
    case config::source::scripted: {
      sweep_source source(grid, calibration);
      return with_sensor(c, source, map, mm_per_px, calibration, path);
    }
    case config::source::poses:
      return with_sensor(c, *log, map, mm_per_px, calibration, path);
    case config::source::omni: {
#if defined(TACMAP_HAVE_PHANTOM_OMNI)
      tacmap::phantom_omni_options o;
      o.device_name = c.omni_name;
      o.tool_offset_mm = c.tool_offset_mm;
      o.calibration = calibration;
      tacmap::phantom_omni omni(o);
      return with_sensor(c, omni, map, mm_per_px, calibration, path);
#else
      return 2;
#endif
    }
    case config::source::none:
      break;
  }
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  const config c = parse(argc, argv);
  try {
    return live(c);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "live_localize: %s\n", e.what());
    if (std::string_view(e.what()).find("accept_truncated_tail") != std::string_view::npos)
      std::fprintf(stderr,
                   "live_localize: give --accept-truncated-tail to use the records before it\n");
    return 2;
  }
}
