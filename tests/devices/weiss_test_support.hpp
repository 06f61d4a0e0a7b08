// Helpers shared by the Weiss device tests: short timeouts and an identifiable frame pattern.
#pragma once

#include <doctest/doctest.h>

#include <chrono>
#include <cstdint>
#include <vector>

#include "tacmap/devices/weiss/device_base.hpp"
#include "tacmap/devices/weiss/emulator.hpp"

namespace weiss_test {

using namespace std::chrono_literals;
namespace w = tacmap::weiss;

/// Device options with timeouts short enough for tests (every wait stays well under 1 s).
inline w::device_options fast_options() {
  w::device_options o;
  o.command_timeout = 300ms;
  o.idle_flush = 30ms;
  o.powerup_timeout = 2000ms;
  o.powerup_retry = 40ms;
  o.powerup_settle = 20ms;
  return o;
}

/// The default moving blob, with cell 0 carrying the frame index (mod 4096) so that a test
/// can tell exactly which frames arrived.
inline std::vector<std::uint16_t> indexed_pattern(const w::render_request& r) {
  std::vector<std::uint16_t> cells = w::moving_pattern(r);
  cells.at(0) = static_cast<std::uint16_t>(r.frame_index & 0x0FFFU);
  return cells;
}

inline std::uint32_t frame_number(const tacmap::tactile_frame& f) {
  return static_cast<std::uint32_t>(f.counts(0, 0));
}

/// Checks a frame's counts against the cells the emulator rendered (x fastest, matrix `m`).
inline void check_counts(const tacmap::tactile_frame& f, const std::vector<std::uint16_t>& cells,
                         std::size_t res_x, std::size_t res_y, std::size_t m = 0) {
  REQUIRE(f.counts.rows() == static_cast<Eigen::Index>(res_y));
  REQUIRE(f.counts.cols() == static_cast<Eigen::Index>(res_x));
  REQUIRE(cells.size() >= (m + 1) * res_x * res_y);
  std::size_t mismatches = 0;
  for (std::size_t y = 0; y < res_y; ++y)
    for (std::size_t x = 0; x < res_x; ++x)
      if (f.counts(static_cast<Eigen::Index>(y), static_cast<Eigen::Index>(x)) !=
          static_cast<float>(cells[m * res_x * res_y + y * res_x + x]))
        ++mismatches;
  CHECK(mismatches == 0);
  CHECK_NOTHROW(f.validate());
}

/// Frames until `count` arrived (each within `timeout`).
template <class Device>
std::vector<tacmap::tactile_frame> collect(Device& d, std::size_t count,
                                           std::chrono::milliseconds timeout = 500ms) {
  std::vector<tacmap::tactile_frame> frames;
  for (std::size_t i = 0; i < count; ++i) frames.push_back(d.next_frame(timeout));
  return frames;
}

/// Frame numbers are consecutive except for the listed number of gaps of one frame each.
inline std::size_t missing_frames(const std::vector<tacmap::tactile_frame>& frames) {
  std::size_t missing = 0;
  for (std::size_t i = 1; i < frames.size(); ++i) {
    const std::uint32_t a = frame_number(frames[i - 1]);
    const std::uint32_t b = frame_number(frames[i]);
    REQUIRE(b > a);
    missing += b - a - 1;
  }
  return missing;
}

}  // namespace weiss_test
