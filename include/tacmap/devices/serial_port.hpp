// tacmap: a raw POSIX serial port (termios) for tactile-sensor adapters, and `device_error`.
//
// Sensors such as the Weiss WTS modules (USB CDC-ACM, /dev/ttyACM*) and the DSACON32m (RS232 or
// USB) speak binary packets at 115200 8N1 without flow control, so the port is put in raw mode
// (cfmakeraw): no echo, no line editing, no CR/LF translation — every byte passes unchanged.
// Reads wait with poll() so that every call is bounded by a timeout; nothing here can hang.
// POSIX only (Linux, macOS).
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>

#include "tacmap/image.hpp"  // detail::fail

namespace tacmap {

/// A device could not be opened, stopped answering, went away, or sent something unusable.
/// The message names the device path and what to do.
class device_error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

namespace detail {

inline speed_t baud_constant(unsigned baud) {
  switch (baud) {
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 38400:
      return B38400;
    case 57600:
      return B57600;
    case 115200:
      return B115200;
    case 230400:
      return B230400;
#ifdef B460800
    case 460800:
      return B460800;
#endif
#ifdef B921600
    case 921600:
      return B921600;
#endif
    default:
      break;
  }
  fail<std::invalid_argument>("serial_port: baud rate ", baud,
                              " is not a standard rate; use 9600, 19200, 38400, 57600, 115200 "
                              "(Weiss sensors), 230400, 460800 or 921600");
}

inline int poll_timeout_ms(std::chrono::steady_clock::duration remaining) {
  if (remaining <= std::chrono::steady_clock::duration::zero()) return 0;
  const auto ms = std::chrono::ceil<std::chrono::milliseconds>(remaining).count();
  return static_cast<int>(std::min<std::chrono::milliseconds::rep>(ms, 1000 * 60 * 60));
}

/// The error for a failed open(), saying what to do for the common causes.
inline device_error serial_open_error(const std::string& path, int err) {
  std::string message = "cannot open serial port " + path + ": " + std::strerror(err);
  switch (err) {
    case ENOENT:
    case ENODEV:
    case ENXIO:
      message +=
          " — the device is not there. Is the sensor plugged in and powered? Check the "
          "cable and list candidates with `ls /dev/ttyACM* /dev/ttyUSB*`";
      break;
    case EACCES:
    case EPERM:
      message +=
          " — no permission. Add yourself to the dialout group with "
          "`sudo usermod -aG dialout $USER`, then log out and in again";
      break;
    case EBUSY:
      message += " — the port is in use by another program (close it, or find it with `fuser " +
                 path + "`)";
      break;
    default:
      message += " (errno " + std::to_string(err) + ")";
      break;
  }
  return device_error(message);
}

}  // namespace detail

/// A serial port in raw 8N1 mode without flow control. Move-only; closes on destruction.
/// Not thread-safe: use it from one thread at a time.
class serial_port {
 public:
  using clock = std::chrono::steady_clock;

  serial_port() noexcept = default;

  /// Opens `path` (e.g.\ /dev/ttyACM0) raw at `baud`, 8N1, no flow control, and discards any
  /// stale input. Throws device_error saying what to do when the device is missing, not
  /// permitted, busy, or not a tty.
  explicit serial_port(std::string path, unsigned baud = 115200) : path_(std::move(path)) {
    const speed_t speed = detail::baud_constant(baud);
    // O_NONBLOCK: open must not wait for a modem carrier, and reads are driven by poll().
    fd_ = ::open(path_.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) throw detail::serial_open_error(path_, errno);
    try {
      configure(speed);
    } catch (...) {
      close();
      throw;
    }
  }

  serial_port(const serial_port&) = delete;
  serial_port& operator=(const serial_port&) = delete;
  serial_port(serial_port&& other) noexcept
      : fd_(std::exchange(other.fd_, -1)), path_(std::move(other.path_)) {}
  serial_port& operator=(serial_port&& other) noexcept {
    if (this != &other) {
      close();
      fd_ = std::exchange(other.fd_, -1);
      path_ = std::move(other.path_);
    }
    return *this;
  }
  ~serial_port() { close(); }

  bool is_open() const noexcept { return fd_ >= 0; }
  const std::string& path() const noexcept { return path_; }
  int native_handle() const noexcept { return fd_; }

  void close() noexcept {
    if (fd_ >= 0) {
      (void)::ioctl(fd_, TIOCNXCL);  // give up exclusivity, so the port can be reopened
      ::close(fd_);
      fd_ = -1;
    }
  }

  /// Reads what is available, waiting at most `timeout` for the first byte. Returns the number
  /// of bytes read, 0 on timeout. Throws device_error if the device hung up (unplugged, or the
  /// other end of a pseudo-terminal closed); the port is closed then.
  std::size_t read_some(std::span<std::uint8_t> buffer, std::chrono::milliseconds timeout) {
    require_open("read from");
    if (buffer.empty()) return 0;
    const auto deadline = clock::now() + timeout;
    for (;;) {
      pollfd p{fd_, POLLIN, 0};
      const int ready = ::poll(&p, 1, detail::poll_timeout_ms(deadline - clock::now()));
      if (ready < 0) {
        if (errno == EINTR) continue;
        throw io_error("poll", errno);
      }
      if (ready == 0) return 0;
      if ((p.revents & POLLIN) == 0 && (p.revents & (POLLHUP | POLLERR | POLLNVAL)) != 0)
        throw hangup();
      const ssize_t n = ::read(fd_, buffer.data(), buffer.size());
      if (n > 0) return static_cast<std::size_t>(n);
      if (n == 0) throw hangup();  // POLLIN with nothing to read: end of file
      if (errno == EINTR || errno == EAGAIN || errno == EWOULDBLOCK) {
        if (clock::now() >= deadline) return 0;
        continue;
      }
      if (errno == EIO || errno == ENXIO || errno == ENODEV) throw hangup();
      throw io_error("read", errno);
    }
  }

  /// Writes all of `bytes`, waiting at most `timeout` in total for the port to accept them.
  void write_all(std::span<const std::uint8_t> bytes,
                 std::chrono::milliseconds timeout = std::chrono::milliseconds(1000)) {
    require_open("write to");
    const auto deadline = clock::now() + timeout;
    std::size_t done = 0;
    while (done < bytes.size()) {
      const ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
      if (n > 0) {
        done += static_cast<std::size_t>(n);
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK) {
        if (errno == EIO || errno == ENXIO || errno == ENODEV || errno == EPIPE) throw hangup();
        throw io_error("write", errno);
      }
      const auto remaining = deadline - clock::now();
      pollfd p{fd_, POLLOUT, 0};
      const int ready = remaining > clock::duration::zero()
                            ? ::poll(&p, 1, detail::poll_timeout_ms(remaining))
                            : 0;
      if (ready < 0 && errno != EINTR) throw io_error("poll", errno);
      if (ready == 0)
        detail::fail<device_error>(
            "serial port ", path_, ": could not write ", bytes.size() - done, " of ", bytes.size(),
            " bytes within ", timeout.count(),
            " ms; the device is not reading — check that it is powered and not stalled");
      if ((p.revents & (POLLHUP | POLLERR | POLLNVAL)) != 0) throw hangup();
    }
  }

  /// Discards bytes received but not yet read (tcflush TCIFLUSH).
  void discard_input() {
    require_open("flush");
    if (::tcflush(fd_, TCIFLUSH) != 0) throw io_error("tcflush", errno);
  }

 private:
  void configure(speed_t speed) {
    if (!::isatty(fd_))
      detail::fail<device_error>("serial port ", path_,
                                 ": not a terminal device; pass a serial port such as "
                                 "/dev/ttyACM0 or /dev/ttyUSB0");
    termios tio{};
    if (::tcgetattr(fd_, &tio) != 0) throw io_error("tcgetattr", errno);
    ::cfmakeraw(&tio);
    tio.c_cflag |= static_cast<tcflag_t>(CLOCAL | CREAD);  // ignore modem lines, enable receiver
    tio.c_cflag &= ~static_cast<tcflag_t>(CSTOPB | PARENB | CSIZE);
    tio.c_cflag |= static_cast<tcflag_t>(CS8);  // 8N1
#ifdef CRTSCTS
    tio.c_cflag &= ~static_cast<tcflag_t>(CRTSCTS);  // no hardware flow control
#endif
    tio.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);  // no software flow control
    tio.c_cc[VMIN] = 0;  // reads never block: poll() provides the timeouts
    tio.c_cc[VTIME] = 0;
    if (::cfsetispeed(&tio, speed) != 0 || ::cfsetospeed(&tio, speed) != 0)
      throw io_error("cfsetspeed", errno);
    if (::tcsetattr(fd_, TCSANOW, &tio) != 0) throw io_error("tcsetattr", errno);
    // Exclusive use: a second program reading the same port would steal half the packets.
    (void)::ioctl(fd_, TIOCEXCL);
    (void)::tcflush(fd_, TCIOFLUSH);
  }

  void require_open(const char* what) const {
    if (fd_ < 0)
      detail::fail<device_error>("serial port ", path_.empty() ? "(none)" : path_, ": cannot ",
                                 what,
                                 " a closed port; open it (or reconnect) "
                                 "first");
  }

  device_error io_error(const char* call, int err) const {
    return device_error("serial port " + path_ + ": " + call + " failed: " + std::strerror(err) +
                        " (errno " + std::to_string(err) + ")");
  }

  /// The device went away: close our end so the caller can reopen cleanly.
  device_error hangup() {
    close();
    return device_error("serial port " + path_ +
                        ": the device disconnected (hang-up). Check the cable and power, then "
                        "reconnect once it is back");
  }

  int fd_ = -1;
  std::string path_;
};

}  // namespace tacmap
