// tacmap's command-line tools: one parse step with one exit-code scheme, and the check that every
// floating-point option is a finite number.
//
// Exit status of every tool (also in each tool's --help footer, `exit_status_footer`):
//   0  the run completed (and passed its gate, where it has one)
//   1  the run completed but failed its gate (tacmap-evaluate: a success rate below
//      --min-success-rate; tacmap-calibrate: no usable temperature)
//   2  it did not run: a usage error (unknown option, a value out of range or not a number, a
//      missing argument) or an input it cannot use (an unreadable file, a bad map)
// CLI11 on its own exits with its error class's code (105 for a value out of range, 109 for an
// extra argument, ...); `parse` maps every usage error to 2.
#pragma once

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <string>

namespace tacmap_tools {

inline constexpr int exit_gate_failed = 1;
inline constexpr int exit_usage = 2;

inline constexpr const char* exit_status_footer =
    "Exit status: 0 the run completed (and passed its gate); 1 it completed but failed its gate; "
    "2 it did not run: a usage error (unknown option, value out of range or not a finite number) "
    "or an input it cannot use.";

/// Refuses NaN and infinity in every floating-point option. CLI11's validators (Range,
/// PositiveNumber, NonNegativeNumber) compare with < and >, which are all false for NaN, so
/// `--min-success-rate nan` or `--odometry-noise nan` passed them and silently disabled what
/// they set. Throws CLI::ValidationError naming the option and the value.
inline void check_finite_options(const CLI::App& app) {
  for (const CLI::Option* o : app.get_options()) {
    if (o->get_type_name().rfind("FLOAT", 0) != 0) continue;
    for (const std::string& result : o->results()) {
      std::string::size_type begin = 0;
      while (begin <= result.size()) {  // a delimited option may still hold "1,nan"
        std::string::size_type end = result.find(',', begin);
        if (end == std::string::npos) end = result.size();
        const std::string item = result.substr(begin, end - begin);
        char* stop = nullptr;
        errno = 0;
        const double v = std::strtod(item.c_str(), &stop);
        if (!item.empty() && stop == item.c_str() + item.size() && !std::isfinite(v))
          throw CLI::ValidationError(o->get_name(), "'" + item +
                                                        "' is not a finite number; expected a "
                                                        "finite value in the option's range");
        begin = end + 1;
      }
    }
  }
}

/// Parses the command line: nothing to go on with, or the exit status to return now (0 after
/// --help, `exit_usage` after a usage error, whose message CLI11 has printed). Also installs
/// `exit_status_footer` in the help.
inline std::optional<int> parse(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
    check_finite_options(app);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);  // prints help, or the error and "Run with --help ..."
    return code == 0 ? 0 : exit_usage;
  }
  return std::nullopt;
}

}  // namespace tacmap_tools
