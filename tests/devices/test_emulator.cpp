// The emulator itself: its pty path, option checks, the default pattern, and that a broken
// render callback is reported instead of crashing or hanging.
#include <doctest/doctest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <string>

#include "tacmap/devices/weiss/wts.hpp"
#include "weiss_test_support.hpp"

namespace test_emulator {

using namespace weiss_test;

TEST_CASE("emulator: a stable symlink to a pty, removed on destruction") {
  std::string path;
  {
    w::emulator emu;
    path = emu.path();
    struct stat st {};
    REQUIRE(::lstat(path.c_str(), &st) == 0);
    CHECK(S_ISLNK(st.st_mode));
    REQUIRE(::stat(path.c_str(), &st) == 0);
    CHECK(S_ISCHR(st.st_mode));
    std::array<char, 128> target{};
    const ssize_t n = ::readlink(path.c_str(), target.data(), target.size() - 1);
    REQUIRE(n > 0);
    CHECK(std::string(target.data()).rfind("/dev/pts/", 0) == 0);
    CHECK(emu.error().empty());
  }
  struct stat st {};
  CHECK(::lstat(path.c_str(), &st) != 0);  // cleaned up
}

TEST_CASE("emulator: options are checked, the default pattern moves") {
  w::emulator_options o;
  o.matrix_count = 2;  // a WTS module has one matrix
  CHECK_THROWS_AS(w::emulator{o}, std::invalid_argument);
  o = {};
  o.res_x = 0;
  CHECK_THROWS_AS(w::emulator{o}, std::invalid_argument);

  const w::render_request a{0, 6, 14, 1};
  const w::render_request b{8, 6, 14, 1};
  const auto ca = w::moving_pattern(a);
  const auto cb = w::moving_pattern(b);
  REQUIRE(ca.size() == 84);
  CHECK(ca != cb);
  CHECK(*std::max_element(ca.begin(), ca.end()) <= w::max_cell_value);
  // The blob centre is on row frame/4: row 0 at frame 0, row 2 at frame 8.
  CHECK(std::max_element(ca.begin(), ca.end()) - ca.begin() < 6);
  const auto peak_b = static_cast<std::size_t>(std::max_element(cb.begin(), cb.end()) - cb.begin());
  CHECK(peak_b / 6 == 2);
}

TEST_CASE("emulator: a broken render callback is reported, and the host times out cleanly") {
  w::emulator_options o;
  o.render = [](const w::render_request&) { return std::vector<std::uint16_t>(5, 0); };
  w::emulator emu(o);
  w::wts_device dev(emu.path(), fast_options());  // queries work: no frame rendered yet
  CHECK_THROWS_AS(dev.read_single_frame(), tacmap::device_error);
  for (int i = 0; i < 100 && emu.error().empty(); ++i) std::this_thread::sleep_for(5ms);
  CHECK(emu.error().find("render returned 5 cells") != std::string::npos);
}

}  // namespace test_emulator
