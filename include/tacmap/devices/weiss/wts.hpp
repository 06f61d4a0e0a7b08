// tacmap: a Weiss WTS tactile sensor module (e.g. the WTS 0614-34A, the paper's 14 x 6 array
// with 3.4 mm cells) on its USB virtual COM port.
//
//   tacmap::weiss::wts_device sensor("/dev/ttyACM0");
//   sensor.start_periodic(std::chrono::milliseconds(20));
//   tacmap::tactile_frame f = sensor.next_frame(std::chrono::milliseconds(500));
//
// Every reply starts with a u16 status; a non-zero status becomes a device_error naming it.
// Streamed frames (id 00) carry no status and are CRC-checked (public drivers skip that check).
#pragma once

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "tacmap/devices/weiss/device_base.hpp"

namespace tacmap::weiss {

/// What a WTS module says about itself (38h and 50h).
struct wts_identity {
  std::string sensor_type;  ///< e.g. "WTS 0614-34A"
  wts_system_info system;   ///< type, hardware revision, firmware, serial number
};

/// A WTS tactile module on its USB virtual COM port (usage: the file comment). Frames,
/// streaming, statistics and reconnection: `detail::device_base`.
class wts_device : public detail::device_base {
 public:
  /// Opens the module at `path`, stops any acquisition a previous program left running, and
  /// reads the matrix geometry (30h). Throws device_error if the port cannot be opened or the
  /// module does not answer within `options.command_timeout`.
  explicit wts_device(std::string path, device_options options = {})
      : device_base(std::move(path), options, protocol_family::wts) {
    open_port(std::chrono::milliseconds(0));
    initialize();
  }

  /// Sensor type string and system information.
  wts_identity identity() {
    wts_identity id;
    const auto type =
        checked(command(wts_command::sensor_type, {}, "get sensor type"), "get sensor type");
    id.sensor_type.assign(type.begin(), type.end());
    const auto sys = checked(command(wts_command::system_info, {}, "get system information"),
                             "get system information");
    id.system = decode("system information", [&] { return parse_wts_system_info(sys); });
    return id;
  }

  /// Queries the matrix information (30h) again and updates `geometry()`.
  matrix_info query_matrix_info() {
    const auto data = checked(command(wts_command::matrix_info, {}, "get matrix information"),
                              "get matrix information");
    matrix_info m = decode("matrix information", [&] { return parse_wts_matrix_info(data); });
    set_matrices({m}, 0);
    return m;
  }

  /// Reads one frame (20h). Not while periodic acquisition runs (the module refuses it).
  tactile_frame read_single_frame() {
    if (streaming_)
      tacmap::detail::fail<device_error>("WTS at ", path_,
                                         ": read_single_frame() during periodic acquisition; "
                                         "call stop_periodic() first, or use next_frame()");
    const std::uint8_t flags = options_.rle ? frame_flag_rle : std::uint8_t{0};
    const auto data =
        checked(command(wts_command::read_single_frame, std::span(&flags, 1), "read single frame"),
                "read single frame");
    auto f = to_frame(data, clock::now());
    if (!f)
      tacmap::detail::fail<device_error>(
          "WTS at ", path_, ": the single frame is corrupt: ", stats_.last_corrupt_frame);
    return std::move(*f);
  }

  /// Starts periodic acquisition (21h) with one frame every `period` (1..65535 ms); frames then
  /// come from next_frame(). Restarts acquisition if it was running.
  void start_periodic(std::chrono::milliseconds period) {
    if (period.count() < 1 || period.count() > 0xFFFF)
      tacmap::detail::fail<std::invalid_argument>(
          "wts_device::start_periodic: period = ", period.count(),
          " ms; expected 1..65535 ms (a u16 on the wire)");
    if (streaming_) stop_periodic();
    discard_frames();
    std::vector<std::uint8_t> payload{options_.rle ? frame_flag_rle : std::uint8_t{0}};
    detail::put_u16(payload, static_cast<std::uint16_t>(period.count()));
    checked(command(wts_command::start_periodic, payload, "start periodic acquisition"),
            "start periodic acquisition");
    period_ = period;
    streaming_ = true;
  }

  /// Stops periodic acquisition (22h). Frames already received stay available to next_frame().
  void stop_periodic() {
    checked(command(wts_command::stop_periodic, {}, "stop periodic acquisition"),
            "stop periodic acquisition");
    streaming_ = false;
  }

  /// Loop (06h): the module echoes `payload` after a status word; throws unless it does.
  void ping(std::span<const std::uint8_t> payload = default_ping) {
    const auto echo = checked(command(wts_command::loop, payload, "loop"), "loop");
    if (!std::equal(echo.begin(), echo.end(), payload.begin(), payload.end()))
      tacmap::detail::fail<device_error>("WTS at ", path_, ": loop (06h) echoed ", echo.size(),
                                         " bytes that differ from the ", payload.size(),
                                         " sent; the line corrupts data — check the cable");
  }

  std::chrono::milliseconds period() const noexcept { return period_; }

 private:
  static constexpr std::array<std::uint8_t, 4> default_ping = {0x54, 0x41, 0x43, 0x4D};

  void initialize() override {
    // A previous program may have left acquisition running; its frames would crowd the queue.
    // Stopping is harmless when nothing runs, so its status is not checked.
    (void)command(wts_command::stop_periodic, {}, "stop periodic acquisition");
    streaming_ = false;
    discard_frames();
    query_matrix_info();
  }

  void resume_streaming() override { start_periodic(period_); }

  std::chrono::milliseconds period_{0};
};

}  // namespace tacmap::weiss
