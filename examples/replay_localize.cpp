// replay_localize — localize a recorded touch session offline, through the same filter a live
// session uses.
//
// The problem (Luo et al., ICRA 2015, Sec. IV): a 14 x 6 tactile array rides on a Phantom Omni
// and explores an object in seven steps, taking several readings at each place; the camera image
// of the object is the map. A session log (include/tacmap/io/SESSION_FORMAT.md) holds what the
// devices said, as they said it: raw tactile frames and the Omni's poses in its own frame. Its
// header names the map, the map's scale, the sensor geometry and the device -> map calibration.
//
// Replay: poses give the odometry between frames (odometry_between, Sec. III-B); a
// `tacmap::localizer` preprocesses each frame (Sec. IV-A: frames of the lifted sensor are
// rejected), matches accepted ones against the map (classic SIFT) and fuses them in the
// Bayes filter (Table 1), starting from a uniform belief. The sensor's true position is unknown to
// the filter; the check compares the estimate with where the calibrated poses put the sensor.
//
// Noise in the committed demo session: device poses jitter by 0.25 mm per axis, taxel counts by
// 60 counts (1.5 % of full scale), the pressing force changes from touch to touch, and the device
// frame is turned 0.3 rad against the map. The session was made by this program's --generate
// mode (deterministic), so its provenance is this file.
//
// Run: replay_localize [session-file]       exit status 0 when the final error is below 3 mm
//                                           and no later touch is off by 2.5 mm or more
//      replay_localize --generate <folder>  (re)write replay_demo.session and its map there
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "tacmap/devices/position_source.hpp"
#include "tacmap/io/image_io.hpp"
#include "tacmap/io/session_log.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/tacmap.hpp"

#ifndef TACMAP_DEMO_SESSION
#define TACMAP_DEMO_SESSION "data/sessions/replay_demo.session"
#endif

namespace {

namespace fs = std::filesystem;
using grid_t = tacmap::planar_grid<float>;

// ---- the demo session's generator ---------------------------------------------------------

/// splitmix64: the same numbers on every platform (std:: distributions are not).
struct rng {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30U)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27U)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31U);
  }
  double uniform() { return static_cast<double>(next() >> 11U) * 0x1.0p-53; }
  double normal() {  // Box-Muller
    const double u = 1.0 - uniform();
    return std::sqrt(-2.0 * std::log(u)) * std::cos(2.0 * std::numbers::pi * uniform());
  }
};

/// A synthetic object: smooth blobs and raised bars, quantised to 8 bits like the PGM on disk.
tacmap::image<float> make_map(rng& r) {
  tacmap::image<float> map = tacmap::image<float>::Zero(120, 120);
  for (int blob = 0; blob < 14; ++blob) {
    const double cx = 120.0 * r.uniform(), cy = 120.0 * r.uniform(), s = 4.0 + 8.0 * r.uniform();
    for (Eigen::Index y = 0; y < map.rows(); ++y)
      for (Eigen::Index x = 0; x < map.cols(); ++x) {
        const double dx = static_cast<double>(x) - cx, dy = static_cast<double>(y) - cy;
        map(y, x) += static_cast<float>(std::exp(-(dx * dx + dy * dy) / (2.0 * s * s)));
      }
  }
  for (int bar = 0; bar < 10; ++bar) {
    const auto y = static_cast<Eigen::Index>(100.0 * r.uniform());
    const auto x = static_cast<Eigen::Index>(100.0 * r.uniform());
    const auto h = static_cast<Eigen::Index>(3.0 + 17.0 * r.uniform());
    const auto w = static_cast<Eigen::Index>(3.0 + 17.0 * r.uniform());
    map.block(y, x, h, w) += 1.0F;
  }
  map /= map.maxCoeff();
  return (map * 255.0F).round() / 255.0F;
}

/// The raw counts of a 14 x 6 array pressed on the map window with top-left pixel (row, col):
/// each taxel averages the 3 x 3 map pixels it covers (3.4 mm taxels on a 3.4/3 mm map).
tacmap::tactile_frame press(const tacmap::image<float>& map, tacmap::grid_cell at, double force,
                            rng& r) {
  tacmap::tactile_frame f;
  for (Eigen::Index i = 0; i < 14; ++i)
    for (Eigen::Index j = 0; j < 6; ++j) {
      const double v = map.block(at.row + 3 * i, at.col + 3 * j, 3, 3).mean();
      const double counts = 150.0 + 3700.0 * force * v + 60.0 * r.normal();
      f.counts(i, j) = static_cast<float>(std::round(std::clamp(counts, 0.0, 4095.0)));
    }
  return f;
}

/// A lifted sensor: only noise.
tacmap::tactile_frame lifted(rng& r) {
  tacmap::tactile_frame f;
  for (float& v : f.counts.reshaped())
    v = static_cast<float>(std::round(std::abs(15.0 * r.normal())));
  return f;
}

int generate(const fs::path& folder) {
  rng r{2015};
  const tacmap::image<float> map = make_map(r);
  fs::create_directories(folder);
  tacmap::write_pgm(folder / "replay_demo_map.pgm", map);
  const grid_t grid({.width = 120, .height = 120}, 3.4 / 3.0, {.width = 18, .height = 42});

  tacmap::session_header header;
  header.geometry = tacmap::taxel_geometry{};  // 14 x 6 at 3.4 mm
  header.map_file = "replay_demo_map.pgm";
  header.mm_per_px = grid.mm_per_px();
  header.calibration = tacmap::map_calibration::horizontal(0.3, {60.0, 70.0});
  header.extra = {{"source", "simulated by examples/replay_localize.cpp --generate"},
                  {"device", "Phantom Omni (simulated), Weiss 14 x 6 array (simulated)"}};
  tacmap::session_recorder log(folder / "replay_demo.session", header, {.overwrite = true});
  const tacmap::map_calibration& cal = *header.calibration;

  // Seven places (window top-left pixels), as in the paper's exploration (Fig. 5).
  const std::vector<tacmap::grid_cell> places = {{30, 20}, {24, 28}, {29, 38}, {41, 34},
                                                 {44, 43}, {52, 31}, {43, 37}};
  // Where the Omni must be for the sensor centre to sit over map point m.
  const auto device_at = [&](const Eigen::Vector2d& m, double height) {
    return cal.to_device_mm(m, height);
  };
  const auto centre = [&](tacmap::grid_cell c) {
    return Eigen::Vector2d(grid.state_mm(grid.index(c)));
  };

  // Each place: three readings while pressing, then (except after the last) four frames with
  // the sensor lifted 8 mm while the Omni moves to the next place. Frames at 30 fps, poses at
  // 100 Hz, on one clock.
  constexpr std::int64_t touch_frames = 3;
  constexpr std::int64_t move_frames = 4;
  constexpr std::int64_t frame_ns = 33'333'333;
  constexpr std::int64_t pose_ns = 10'000'000;
  constexpr std::int64_t start_ns = 5'000'000'000'000;
  constexpr std::int64_t place_ns = (touch_frames + move_frames) * frame_ns;
  const auto places_count = static_cast<std::int64_t>(places.size());
  const std::int64_t frame_count = places_count * (touch_frames + move_frames) - move_frames;
  const auto device_position = [&](std::int64_t t) {  // where the Omni is at time t
    const std::int64_t since_start = t - start_ns;
    const std::int64_t place = std::min(since_start / place_ns, places_count - 1);
    const auto i = static_cast<std::size_t>(place);
    const std::int64_t since = since_start - place * place_ns;
    if (since < touch_frames * frame_ns || i + 1 == places.size())
      return device_at(centre(places[i]), 0.0);
    const double s = static_cast<double>(since - touch_frames * frame_ns) /
                     static_cast<double>(move_frames * frame_ns);
    return device_at((1.0 - s) * centre(places[i]) + s * centre(places[i + 1]), 8.0);
  };
  std::vector<double> force(places.size());
  for (double& f : force) f = 0.75 + 0.25 * r.uniform();
  std::int64_t pose_t = start_ns;
  for (std::int64_t n = 0; n < frame_count; ++n) {
    const std::int64_t frame_t = start_ns + n * frame_ns;
    for (; pose_t <= frame_t; pose_t += pose_ns) {
      // Jittered, and rounded to 1 um / 10 urad as a device would report them.
      const auto um = [](double v) { return std::round(v * 1000.0) / 1000.0; };
      const Eigen::Vector3d p = device_position(pose_t);
      log.record(tacmap::sensor_pose{tacmap::detail::session_time_point(pose_t),
                                     um(p.x() + 0.25 * r.normal()), um(p.y() + 0.25 * r.normal()),
                                     um(p.z() + 0.25 * r.normal()),
                                     std::round(0.002 * r.normal() * 1e5) / 1e5});
    }
    const auto place = static_cast<std::size_t>(n / (touch_frames + move_frames));
    const bool touching = n % (touch_frames + move_frames) < touch_frames;
    tacmap::tactile_frame f = touching ? press(map, places[place], force[place], r) : lifted(r);
    f.timestamp = tacmap::detail::session_time_point(frame_t);
    f.sequence = static_cast<std::uint32_t>(n);
    log.record(f);
  }
  std::printf("wrote %s (%llu records) and its map\n", log.path().string().c_str(),
              static_cast<unsigned long long>(log.records()));
  return 0;
}

// ---- the replay ---------------------------------------------------------------------------

int replay(const fs::path& file, bool accept_truncated_tail) {
  tacmap::session_reader log(file, {.accept_truncated_tail = accept_truncated_tail});
  const tacmap::session_header& h = log.header();
  if (!h.geometry || !h.mm_per_px || !h.calibration || h.map_file.empty()) {
    std::fprintf(stderr,
                 "%s: the header needs geometry, map, mm_per_px and calibration lines to replay "
                 "a localization\n",
                 file.string().c_str());
    return 2;
  }
  const tacmap::image<float> map = tacmap::read_pgm(log.map_path());
  // The whole pipeline in one object, with the library's defaults (classic SIFT, latent
  // appearance, a motion floor): preprocessing, motion, the measurement model, the verdict.
  // (`config.model = tacmap::measurement_kind::ncc` gives the NCC baseline: 0.45 mm final error
  // on this session, whose taxels average the map exactly; the defaults 0.94 mm.)
  tacmap::localizer loc(map, *h.mm_per_px, {}, *h.geometry);

  std::printf("session %s: %lld x %lld taxels, map %s (%lld x %lld px at %.4f mm/px)\n",
              file.string().c_str(), static_cast<long long>(h.geometry->rows),
              static_cast<long long>(h.geometry->cols), h.map_file.c_str(),
              static_cast<long long>(map.cols()), static_cast<long long>(map.rows()), *h.mm_per_px);
  std::printf(
      "frame  t (s)   moved (mm)     estimate (mm)     truth (mm)        error (mm)  entropy\n");
  std::optional<tacmap::sensor_pose> at_last_frame;
  std::optional<tacmap::sensor_pose::clock::time_point> t0;
  int touches = 0, rejected = 0;
  double error_mm = -1.0, worst_tracking_mm = 0.0;
  // One touch: the frame with the pose sampled nearest to it in time.
  const auto touch = [&](const tacmap::tactile_frame& frame, const tacmap::sensor_pose& pose) {
    if (!t0) t0 = frame.timestamp;
    // The odometry since the previous frame: the arm moved whether or not this frame is a touch.
    tacmap::odometry moved{};
    if (at_last_frame) {
      const tacmap::pose_change d = tacmap::odometry_between(*at_last_frame, pose, *h.calibration);
      moved = {.dx_mm = d.dx_mm, .dy_mm = d.dy_mm};
    }
    at_last_frame = pose;
    const tacmap::touch_result r = loc.touch(frame, moved);
    if (!r.accepted()) {
      ++rejected;  // the sensor was lifted: nothing to match
      return;
    }
    ++touches;
    const Eigen::Vector2d truth = h.calibration->to_map_mm(pose);
    error_mm = (r.position_mm - truth).norm();
    // Once converged (three touches) the filter must *track*: right after each move the estimate
    // rests on the odometry, so a wrong calibration or sign shows up as an error of several mm.
    if (touches > 3) worst_tracking_mm = std::max(worst_tracking_mm, error_mm);
    const double t = std::chrono::duration<double>(
                         tacmap::checked_elapsed(*t0, frame.timestamp, "replay: frame time"))
                         .count();
    std::printf("%5u  %5.2f  %9.2f   (%6.1f, %6.1f)  (%6.1f, %6.1f)  %9.2f  %7.2f\n",
                frame.sequence, t, std::hypot(moved.dx_mm, moved.dy_mm), r.position_mm.x(),
                r.position_mm.y(), truth.x(), truth.y(), error_mm, r.entropy_nats);
  };
  // Frames and poses come from two devices at their own rates: a frame waits for the next pose
  // to see which of the two around it is nearer in time.
  std::optional<tacmap::tactile_frame> waiting;
  std::optional<tacmap::sensor_pose> before;
  while (auto record = log.next()) {
    if (auto* frame = std::get_if<tacmap::tactile_frame>(&*record)) {
      if (waiting && before) touch(*waiting, *before);
      if (waiting && !before) ++rejected;  // a frame before any pose: nowhere to put it
      waiting = std::move(*frame);
      continue;
    }
    const auto& pose = std::get<tacmap::sensor_pose>(*record);
    if (waiting) {
      const auto gap = [&](const tacmap::sensor_pose& q) {
        return std::chrono::abs(
            tacmap::checked_elapsed(waiting->timestamp, q.timestamp, "replay: frame-pose gap"));
      };
      touch(*waiting, before && gap(*before) <= gap(pose) ? *before : pose);
      waiting.reset();
    }
    before = pose;
  }
  if (waiting && before) touch(*waiting, *before);
  if (log.stats().truncated_line != 0)
    std::printf("dropped line %llu (%zu bytes), cut off by a crash while it was written\n",
                static_cast<unsigned long long>(log.stats().truncated_line),
                log.stats().truncated_bytes);
  std::printf("%d touches used, %d frames rejected (sensor lifted, or no pose), %llu poses\n",
              touches, rejected, static_cast<unsigned long long>(log.stats().poses));
  if (touches < 5 || error_mm < 0.0 || error_mm >= 3.0 || worst_tracking_mm >= 2.5) {
    std::printf(
        "FAILED: final error %.2f mm (expected below 3 mm), worst error while tracking "
        "%.2f mm (expected below 2.5 mm), after %d touches\n",
        error_mm, worst_tracking_mm, touches);
    return 1;
  }
  std::printf("localized: final error %.2f mm, worst while tracking %.2f mm\n", error_mm,
              worst_tracking_mm);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc == 3 && std::string(argv[1]) == "--generate") return generate(argv[2]);
    // --accept-truncated-tail: a log whose last line was cut off by a crash is replayed without
    // that line (session_read_options::accept_truncated_tail); without it, such a log is refused.
    std::vector<std::string> args(argv + 1, argv + argc);
    const auto tail = std::find(args.begin(), args.end(), "--accept-truncated-tail");
    const bool accept_truncated_tail = tail != args.end();
    if (accept_truncated_tail) args.erase(tail);
    if (args.size() > 1 || (args.size() == 1 && args[0].starts_with('-'))) {
      std::fprintf(stderr,
                   "usage: replay_localize [--accept-truncated-tail] [session-file]\n"
                   "       replay_localize --generate <folder>\n"
                   "  --accept-truncated-tail  replay a log whose last line a crash cut off,\n"
                   "                           without that line (default: refuse the log)\n");
      return 2;
    }
    return replay(args.size() == 1 ? fs::path(args[0]) : fs::path(TACMAP_DEMO_SESSION),
                  accept_truncated_tail);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "replay_localize: %s\n", e.what());
    if (std::string_view(e.what()).find("accept_truncated_tail") != std::string_view::npos)
      std::fprintf(stderr,
                   "replay_localize: give --accept-truncated-tail to use the records before it\n");
    return 2;
  }
}
