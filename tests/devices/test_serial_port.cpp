// serial_port: error messages that say what to do, raw mode, bounded reads, hang-up detection.
// A pseudo-terminal made here stands in for the device.
#include <doctest/doctest.h>
#include <fcntl.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "tacmap/devices/serial_port.hpp"

namespace test_serial_port {

using namespace std::chrono_literals;
using clock_type = std::chrono::steady_clock;

namespace {

/// A pty pair: the test writes the "device" side through `master`.
struct pty {
  int master = -1;
  std::string slave;
  pty() {
    master = ::posix_openpt(O_RDWR | O_NOCTTY);
    REQUIRE(master >= 0);
    REQUIRE(::grantpt(master) == 0);
    REQUIRE(::unlockpt(master) == 0);
    std::array<char, 128> name{};
    REQUIRE(::ptsname_r(master, name.data(), name.size()) == 0);
    slave = name.data();
  }
  ~pty() {
    if (master >= 0) ::close(master);
  }
  void close_master() {
    ::close(master);
    master = -1;
  }
};

}  // namespace

TEST_CASE("serial_port: a missing device names the path and how to find the right one") {
  try {
    tacmap::serial_port port("/dev/ttyACM_does_not_exist_42");
    FAIL("opening a missing device must throw");
  } catch (const tacmap::device_error& e) {
    const std::string m = e.what();
    CHECK(m.find("/dev/ttyACM_does_not_exist_42") != std::string::npos);
    CHECK(m.find("ls /dev/ttyACM*") != std::string::npos);
    CHECK(m.find("cable") != std::string::npos);
  }
}

TEST_CASE("serial_port: permission and other errno values give their fix or strerror") {
  const std::string denied = tacmap::detail::serial_open_error("/dev/ttyACM0", EACCES).what();
  CHECK(denied.find("/dev/ttyACM0") != std::string::npos);
  CHECK(denied.find("sudo usermod -aG dialout $USER") != std::string::npos);
  CHECK(denied.find("log out and in again") != std::string::npos);
  const std::string other = tacmap::detail::serial_open_error("/dev/ttyS9", EMFILE).what();
  CHECK(other.find(std::strerror(EMFILE)) != std::string::npos);
  CHECK(other.find("errno " + std::to_string(EMFILE)) != std::string::npos);

  // A real EACCES where the test is not root (root bypasses file permissions).
  char name[] = "/tmp/tacmap-serial-XXXXXX";
  const int fd = ::mkstemp(name);
  REQUIRE(fd >= 0);
  ::close(fd);
  ::chmod(name, 0);
  if (::geteuid() != 0) {
    CHECK_THROWS_WITH_AS(tacmap::serial_port{name}, doctest::Contains("dialout"),
                         tacmap::device_error);
  } else {
    // Root opens it; it is not a tty, which is refused with its own message.
    CHECK_THROWS_WITH_AS(tacmap::serial_port{name}, doctest::Contains("not a terminal"),
                         tacmap::device_error);
  }
  ::unlink(name);
  CHECK_THROWS_AS(tacmap::serial_port("/dev/null", 12345), std::invalid_argument);
}

TEST_CASE("serial_port: raw 8N1 on a pty, bounded reads, write-all, move-only") {
  pty p;
  tacmap::serial_port port(p.slave);
  REQUIRE(port.is_open());
  termios tio{};
  REQUIRE(::tcgetattr(port.native_handle(), &tio) == 0);
  CHECK((tio.c_lflag & ICANON) == 0);  // raw: no line editing
  CHECK((tio.c_lflag & ECHO) == 0);
  CHECK((tio.c_oflag & OPOST) == 0);  // no output translation
  CHECK((tio.c_cflag & CSIZE) == CS8);
  CHECK((tio.c_cflag & PARENB) == 0);
  CHECK((tio.c_cflag & CSTOPB) == 0);
  CHECK(cfgetospeed(&tio) == B115200);

  // Timeout: nothing to read returns 0 after about the timeout, not before, not much later.
  std::array<std::uint8_t, 64> buf{};
  auto t0 = clock_type::now();
  CHECK(port.read_some(buf, 60ms) == 0);
  const auto waited = clock_type::now() - t0;
  CHECK(waited >= 55ms);
  CHECK(waited < 1000ms);

  // Binary bytes pass unchanged both ways (CR, LF, XON/XOFF, ^C would be eaten by a cooked tty).
  const std::vector<std::uint8_t> bytes{0x0D, 0x0A, 0x11, 0x13, 0x03, 0x00, 0xFF, 0xAA};
  REQUIRE(::write(p.master, bytes.data(), bytes.size()) == static_cast<ssize_t>(bytes.size()));
  std::vector<std::uint8_t> got;
  t0 = clock_type::now();
  while (got.size() < bytes.size() && clock_type::now() - t0 < 1s) {
    const std::size_t n = port.read_some(buf, 100ms);
    got.insert(got.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n));
  }
  CHECK(got == bytes);
  port.write_all(bytes);
  std::array<std::uint8_t, 64> back{};
  std::size_t total = 0;
  t0 = clock_type::now();
  while (total < bytes.size() && clock_type::now() - t0 < 1s) {
    const ssize_t n = ::read(p.master, back.data() + total, back.size() - total);
    if (n > 0) total += static_cast<std::size_t>(n);
  }
  CHECK(std::vector<std::uint8_t>(back.begin(),
                                  back.begin() + static_cast<std::ptrdiff_t>(total)) == bytes);

  // Move-only RAII.
  static_assert(!std::is_copy_constructible_v<tacmap::serial_port>);
  tacmap::serial_port moved = std::move(port);
  CHECK(moved.is_open());
  CHECK_FALSE(port.is_open());  // NOLINT(bugprone-use-after-move): the moved-from state is defined
  CHECK_THROWS_WITH_AS(port.read_some(buf, 1ms), doctest::Contains("closed port"),
                       tacmap::device_error);

  // Hang-up: the other end goes away -> a clear error, and the port is closed.
  p.close_master();
  CHECK_THROWS_WITH_AS(moved.read_some(buf, 500ms), doctest::Contains("disconnected"),
                       tacmap::device_error);
  CHECK_FALSE(moved.is_open());
}

}  // namespace test_serial_port
