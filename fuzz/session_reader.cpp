// Fuzz target: the session log reader — arbitrary bytes as a session file.
//
// Besides "no crash, no sanitizer report, only session_log_error", it checks properties:
//  * a header that reads writes back (format_session_header) to text that reads to the same
//    header — the writer accepts everything the reader does;
//  * every record that reads writes back to one line that reads to the same record, bit for bit;
//  * after an error about one record the reader goes on (skipping it) and never loops.
// The input's size parity picks whether a cut-off last line is accepted, to cover both paths.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>
#include <variant>

#include "fuzz_check.hpp"
#include "tacmap/io/session_log.hpp"

namespace {

bool same(const tacmap::session_record& a, const tacmap::session_record& b) {
  if (a.index() != b.index()) return false;
  if (const auto* fa = std::get_if<tacmap::tactile_frame>(&a)) {
    const auto& fb = std::get<tacmap::tactile_frame>(b);
    return fa->geometry == fb.geometry && fa->sequence == fb.sequence &&
           fa->timestamp == fb.timestamp && fa->counts.rows() == fb.counts.rows() &&
           fa->counts.cols() == fb.counts.cols() && (fa->counts == fb.counts).all();
  }
  return std::get<tacmap::sensor_pose>(a) == std::get<tacmap::sensor_pose>(b);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::istringstream in(text);
  tacmap::session_read_options options;
  options.accept_truncated_tail = (size % 2U) == 1U;
  options.max_line_bytes = 1U << 16U;
  try {
    tacmap::session_reader reader(in, "fuzz", {}, options);
    const std::string header = tacmap::detail::format_session_header(reader.header());
    {
      std::istringstream again(header);
      tacmap::session_reader back(again);
      TACMAP_FUZZ_CHECK(back.header() == reader.header());
      TACMAP_FUZZ_CHECK(!back.next().has_value());
    }
    std::uint64_t calls = 0;  // each next() consumes a line: calls <= lines, no endless loop
    for (;;) {
      std::optional<tacmap::session_record> record;
      ++calls;
      try {
        record = reader.next();
      } catch (const tacmap::session_log_error& e) {
        TACMAP_FUZZ_CHECK(e.line() > 0 && e.line() <= reader.stats().lines);
        TACMAP_FUZZ_CHECK(calls <= reader.stats().lines);
        continue;
      }
      if (!record) break;
      TACMAP_FUZZ_CHECK(calls <= reader.stats().lines);
      std::string line = header;
      if (const auto* f = std::get_if<tacmap::tactile_frame>(&*record)) {
        TACMAP_FUZZ_CHECK(f->counts.allFinite() && (f->counts >= 0.0F).all());
        tacmap::detail::format_session_frame(line, *f);
      } else {
        TACMAP_FUZZ_CHECK(std::get<tacmap::sensor_pose>(*record).finite());
        tacmap::detail::format_session_pose(line, std::get<tacmap::sensor_pose>(*record));
      }
      std::istringstream again(line);
      tacmap::session_reader back(again);
      const auto copy = back.next();
      TACMAP_FUZZ_CHECK(copy.has_value() && same(*copy, *record));
      TACMAP_FUZZ_CHECK(!back.next().has_value());
    }
    // The end is final.
    TACMAP_FUZZ_CHECK(!reader.next().has_value());
  } catch (const tacmap::session_log_error& e) {
    TACMAP_FUZZ_CHECK(e.line() > 0);  // header errors always name a line
  }
  return 0;
}
