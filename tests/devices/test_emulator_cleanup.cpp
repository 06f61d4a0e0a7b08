// The emulator's temporary folders: made in TMPDIR (or emulator_options::temp_dir), and those of
// processes killed by a signal, which never ran the destructor, removed when the next emulator
// starts, while folders of live emulators are never touched.
#include <doctest/doctest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <utime.h>

#include <array>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "tacmap/devices/weiss/emulator.hpp"

namespace test_emulator_cleanup {

namespace {

namespace fs = std::filesystem;
namespace w = tacmap::weiss;

/// A private folder for one test case, removed with everything in it.
struct scratch {
  fs::path path;
  scratch() {
    std::string t = (fs::temp_directory_path() / "tacmap-emu-test-XXXXXX").string();
    REQUIRE(::mkdtemp(t.data()) != nullptr);
    path = t;
  }
  ~scratch() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  scratch(const scratch&) = delete;
  scratch& operator=(const scratch&) = delete;
};

std::size_t emulator_folders(const fs::path& dir) {
  std::size_t n = 0;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().rfind("tacmap-weiss-", 0) == 0) ++n;
  return n;
}

/// Forks a child that makes an emulator (in `temp_dir`, or with TMPDIR = `tmpdir_env`), sends
/// its folder back through a pipe and then waits to be killed. Returns the child's pid and the
/// folder.
std::pair<pid_t, std::string> child_with_emulator(const std::string& temp_dir,
                                                  const std::string& tmpdir_env = {}) {
  std::array<int, 2> fds{};
  REQUIRE(::pipe(fds.data()) == 0);
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    ::close(fds[0]);
    // The default actions, as in a program without handlers (doctest installs its own).
    for (const int sig : {SIGTERM, SIGINT, SIGHUP}) ::signal(sig, SIG_DFL);
    if (!tmpdir_env.empty()) ::setenv("TMPDIR", tmpdir_env.c_str(), 1);
    try {
      w::emulator_options o;
      o.temp_dir = temp_dir;
      w::emulator emu(o);
      const std::string folder = emu.folder() + "\n";
      if (::write(fds[1], folder.data(), folder.size()) < 0) ::_exit(3);
      for (;;) ::pause();
    } catch (...) {
      ::_exit(4);
    }
  }
  ::close(fds[1]);
  std::string folder;
  char c = 0;
  while (::read(fds[0], &c, 1) == 1 && c != '\n') folder += c;
  ::close(fds[0]);
  return {pid, folder};
}

int kill_and_wait(pid_t pid, int sig) {
  REQUIRE(::kill(pid, sig) == 0);
  int status = 0;
  REQUIRE(::waitpid(pid, &status, 0) == pid);
  return WIFSIGNALED(status) ? WTERMSIG(status) : -1;
}

}  // namespace

TEST_CASE(
    "emulator folders: a process killed by any signal leaves one, the next start removes it") {
  for (const int sig : {SIGKILL, SIGTERM, SIGINT, SIGHUP}) {
    CAPTURE(sig);
    scratch dir;
    const auto [pid, folder] = child_with_emulator(dir.path.string());
    REQUIRE(!folder.empty());
    CHECK(fs::path(folder).parent_path() == dir.path);
    CHECK(fs::exists(fs::path(folder) / "lock"));
    CHECK(kill_and_wait(pid, sig) == sig);
    CHECK(fs::is_directory(folder));  // no destructor ran: left behind
    {
      w::emulator_options o;
      o.temp_dir = dir.path.string();
      const w::emulator next(o);
      CHECK(!fs::exists(folder));              // the dead process's folder is gone
      CHECK(fs::is_directory(next.folder()));  // and the new one is there
      CHECK(emulator_folders(dir.path) == 1);
    }
    CHECK(emulator_folders(dir.path) == 0);  // the destructor removes its own
  }
}

TEST_CASE(
    "emulator folders: a live emulator's folder is never removed, in this process or another") {
  scratch dir;
  w::emulator_options o;
  o.temp_dir = dir.path.string();
  const w::emulator mine(o);
  const auto [pid, theirs] = child_with_emulator(dir.path.string());
  REQUIRE(!theirs.empty());
  CHECK(w::remove_stale_emulator_dirs(dir.path.string()) == 0);
  {
    const w::emulator another(o);  // starting one reaps nothing alive
    CHECK(emulator_folders(dir.path) == 3);
  }
  CHECK(fs::is_directory(mine.folder()));
  CHECK(fs::is_directory(theirs));
  CHECK(kill_and_wait(pid, SIGKILL) == SIGKILL);
  CHECK(w::remove_stale_emulator_dirs(dir.path.string()) == 1);
  CHECK(!fs::exists(theirs));
  CHECK(fs::is_directory(mine.folder()));
}

TEST_CASE("emulator folders: TMPDIR is honoured, then /tmp") {
  scratch dir;
  const auto [pid, folder] = child_with_emulator("", dir.path.string());
  REQUIRE(!folder.empty());
  CHECK(fs::path(folder).parent_path() == dir.path);
  CHECK(kill_and_wait(pid, SIGTERM) == SIGTERM);
  CHECK(w::remove_stale_emulator_dirs(dir.path.string()) == 1);
  CHECK(w::emulator_temp_dir("/somewhere") == "/somewhere");
  // A temp folder that cannot be written is named in the error.
  w::emulator_options o;
  o.temp_dir = (dir.path / "missing").string();
  CHECK_THROWS_WITH_AS(w::emulator{o}, doctest::Contains("cannot make a folder in '"),
                       tacmap::device_error);
}

TEST_CASE("emulator folders: lockless folders (older tacmap) go once old, other names stay") {
  scratch dir;
  const fs::path old_dir = dir.path / "tacmap-weiss-OLD123";
  const fs::path new_dir = dir.path / "tacmap-weiss-NEW456";
  const fs::path other = dir.path / "someone-else";
  for (const auto& p : {old_dir, new_dir, other}) fs::create_directory(p);
  ::symlink("/dev/null", (old_dir / "tty").c_str());
  const utimbuf long_ago{::time(nullptr) - 7200, ::time(nullptr) - 7200};  // 2 h > the 1 h grace
  REQUIRE(::utime(old_dir.c_str(), &long_ago) == 0);
  REQUIRE(::utime(other.c_str(), &long_ago) == 0);
  CHECK(w::remove_stale_emulator_dirs(dir.path.string()) == 1);
  CHECK(!fs::exists(old_dir));
  CHECK(fs::is_directory(new_dir));  // may be an emulator between mkdtemp and its lock
  CHECK(fs::is_directory(other));
}

}  // namespace test_emulator_cleanup
