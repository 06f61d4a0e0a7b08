// tacmap: a Weiss DSACON32m tactile controller (the DSA 9205 pads: 14 x 6 cells at 3.4 mm,
// e.g. on the SCHUNK SDH hand) on RS232 or USB.
//
//   tacmap::weiss::dsacon32m_device pads("/dev/ttyUSB0");
//   pads.start_periodic();
//   tacmap::tactile_frame f = pads.next_frame(std::chrono::milliseconds(500));
//
// Power-up: the controller prints ESC[5n three times about 7 s after power-on and accepts
// commands only after about 8 s. Opening therefore sends "stop acquisition" (framerate 0) until
// it is acknowledged (within `powerup_timeout`), lets the line settle and flushes the input.
// In push mode frames (id 00) may precede a command's reply; they are queued, not lost.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "tacmap/devices/weiss/device_base.hpp"

namespace tacmap::weiss {

/// A DSACON32m controller with its DSA 9205 pads on RS232 or USB (usage and power-up handling:
/// the file comment). Frames, streaming, statistics and reconnection: `detail::device_base`.
class dsacon32m_device : public detail::device_base {
 public:
  /// Opens the controller at `path`, waits for it to be ready (see above), and reads the sensor
  /// and matrix configuration. Frames are taken from matrix `options.matrix_index`.
  explicit dsacon32m_device(std::string path, device_options options = {})
      : device_base(std::move(path), options, protocol_family::dsacon32m) {
    if (options_.powerup_retry <= std::chrono::milliseconds(0))
      tacmap::detail::fail<std::invalid_argument>(
          "dsacon32m_device: powerup_retry = ", options_.powerup_retry.count(),
          " ms; expected > 0 (the interval between stop commands while the controller boots)");
    open_port(std::chrono::milliseconds(0));
    initialize();
  }

  /// Controller information (01h): serial, firmware, state flags.
  dsacon32m_controller_info controller_info() {
    const auto data =
        checked(command(dsacon32m_command::controller_info, {}, "query controller configuration"),
                "query controller configuration");
    return decode("controller information", [&] { return parse_dsacon32m_controller_info(data); });
  }

  /// Sensor information (02h): number of matrices, serial.
  dsacon32m_sensor_info sensor_info() {
    const auto data =
        checked(command(dsacon32m_command::sensor_info, {}, "query sensor configuration"),
                "query sensor configuration");
    return decode("sensor information", [&] { return parse_dsacon32m_sensor_info(data); });
  }

  /// Matrix configuration (0Bh) of matrix `index`.
  dsacon32m_matrix_info query_matrix_info(std::uint16_t index) {
    if (index > 0xFF)
      tacmap::detail::fail<std::invalid_argument>("dsacon32m_device::query_matrix_info: index ",
                                                  index, "; expected 0..255 (a u8 on the wire)");
    const auto i = static_cast<std::uint8_t>(index);
    const auto data = checked(
        command(dsacon32m_command::matrix_info, std::span(&i, 1), "query matrix configuration"),
        "query matrix configuration");
    return decode("matrix information", [&] { return parse_dsacon32m_matrix_info(data); });
  }

  /// All matrices as read when (re)connecting.
  const std::vector<dsacon32m_matrix_info>& matrices() const noexcept { return details_; }

  /// One frame (configure acquisition with enable on, framerate 0). Not during push mode.
  tactile_frame read_single_frame() {
    if (streaming_)
      tacmap::detail::fail<device_error>("DSACON32m at ", path_,
                                         ": read_single_frame() during periodic acquisition; "
                                         "call stop_periodic() first, or use next_frame()");
    discard_frames();
    configure(enable_flags(), 0, "configure data acquisition (single frame)");
    tactile_frame f =
        await_frame(clock::now() + options_.command_timeout, "single frame",
                    "the controller acknowledged the request but sent no frame — check the "
                    "sensor matrix connection");
    if (options_.stop_after_single_frame) {
      configure(stop_flags(), 0, "configure data acquisition (stop)");
      discard_frames();  // what old firmware streamed meanwhile
    }
    return f;
  }

  /// Starts push mode: the controller streams at its highest rate (about 30 fps) whenever
  /// `framerate` > 0. Restarts acquisition if it was running.
  void start_periodic(std::uint16_t framerate = 30) {
    if (framerate == 0)
      tacmap::detail::fail<std::invalid_argument>(
          "dsacon32m_device::start_periodic: framerate 0 would request a single frame; pass "
          "> 0 (the controller then streams at its highest rate), or use read_single_frame()");
    if (streaming_) stop_periodic();
    discard_frames();
    configure(enable_flags(), framerate, "configure data acquisition (start)");
    framerate_ = framerate;
    streaming_ = true;
  }

  /// Stops push mode. Frames already received stay available to next_frame().
  void stop_periodic() {
    configure(stop_flags(), 0, "configure data acquisition (stop)");
    streaming_ = false;
  }

  /// Loop (06h). The controller echoes the payload; whether a status word leads the echo is
  /// unconfirmed, so both forms are accepted.
  void ping(std::span<const std::uint8_t> payload = default_ping) {
    const auto echo = command(dsacon32m_command::loop, payload, "loop");
    const auto same = [&](std::span<const std::uint8_t> s) {
      return std::equal(s.begin(), s.end(), payload.begin(), payload.end());
    };
    const bool plain = same(echo);
    const bool with_status =
        echo.size() >= 2 && echo[0] == 0 && echo[1] == 0 && same(std::span(echo).subspan(2));
    if (!plain && !with_status)
      tacmap::detail::fail<device_error>("DSACON32m at ", path_, ": loop (06h) echoed ",
                                         echo.size(), " bytes that differ from the ",
                                         payload.size(),
                                         " sent; the line corrupts data — check the cable");
  }

 private:
  static constexpr std::array<std::uint8_t, 4> default_ping = {0x54, 0x41, 0x43, 0x4D};

  std::uint8_t rle_flag() const noexcept {
    return options_.rle ? dsacon32m_command::flag_rle : std::uint8_t{0};
  }
  std::uint8_t enable_flags() const noexcept {
    return static_cast<std::uint8_t>(dsacon32m_command::flag_enable |
                                     dsacon32m_command::flag_internal_trigger | rle_flag());
  }
  std::uint8_t stop_flags() const noexcept {
    return static_cast<std::uint8_t>(dsacon32m_command::flag_internal_trigger | rle_flag());
  }

  static std::vector<std::uint8_t> configure_payload(std::uint8_t flags, std::uint16_t rate) {
    std::vector<std::uint8_t> p{flags};
    detail::put_u16(p, rate);
    return p;
  }

  void configure(std::uint8_t flags, std::uint16_t rate, std::string_view what) {
    checked(command(dsacon32m_command::configure_acquisition, configure_payload(flags, rate), what),
            what);
  }

  void initialize() override {
    power_up();
    streaming_ = false;
    const dsacon32m_sensor_info sensor = sensor_info();
    if (sensor.matrix_count == 0)
      tacmap::detail::fail<device_error>("DSACON32m at ", path_,
                                         ": the controller reports no sensor matrix; check "
                                         "that the tactile pads are connected to it");
    std::vector<dsacon32m_matrix_info> details;
    std::vector<matrix_info> matrices;
    for (std::uint16_t i = 0; i < sensor.matrix_count; ++i) {
      details.push_back(query_matrix_info(i));
      matrices.push_back(details.back().matrix);
    }
    set_matrices(std::move(matrices), options_.matrix_index);
    details_ = std::move(details);
  }

  /// Sends "stop acquisition" until acknowledged or `powerup_timeout` passes, then drains and
  /// flushes the line (the banner, late acknowledgements of earlier attempts, stray frames).
  void power_up() {
    const auto payload = configure_payload(stop_flags(), 0);
    const auto start = clock::now();
    const auto deadline = start + options_.powerup_timeout;
    int attempts = 0;
    for (;;) {
      ++attempts;
      while (parser_.pop_command()) ++stats_.unexpected_replies;
      send(dsacon32m_command::configure_acquisition, payload);
      const auto reply = await_reply(dsacon32m_command::configure_acquisition,
                                     std::min(clock::now() + options_.powerup_retry, deadline));
      if (reply) {
        checked(reply->payload, "configure data acquisition (stop, at power-up)");
        break;
      }
      if (clock::now() >= deadline)
        tacmap::detail::fail<device_error>(
            "DSACON32m at ", path_, ": no answer to 'stop acquisition' after ", attempts,
            " attempts over ", options_.powerup_timeout.count(),
            " ms. The controller needs about 8 s after power-on; check its power supply and "
            "cable, that it is a DSACON32m, and that the port runs at 115200 baud");
    }
    drain_for(options_.powerup_settle);
    port_.discard_input();
    parser_.reset();
  }

  void resume_streaming() override { start_periodic(framerate_); }

  std::vector<dsacon32m_matrix_info> details_;
  std::uint16_t framerate_ = 30;
};

}  // namespace tacmap::weiss
