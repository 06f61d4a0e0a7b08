// tacmap: refusing a preparation that cannot fit in memory, before allocating it (issue 14,
// "Bad input").
//
// A map handed over at the camera's resolution can need more memory for its precomputed
// features than the machine has: classic SIFT per window keeps 3 x 128 floats for each of
// 640 x 480 windows (about 1.4 GB), and with 36 headings 36 times that. Allocating it would end
// in std::bad_alloc after minutes of work, or in the out-of-memory killer taking the robot's
// process down. The models therefore work out what they will need first and refuse with the
// figure, the memory available and what to change.
//
// "Available" is the smallest of what Linux reports as available to new allocations without
// swapping (/proc/meminfo's MemAvailable) and the limit of the process's control group (cgroup
// v2 memory.max minus memory.current, or v1 memory.limit_in_bytes minus usage): a container is
// often given far less than the machine has. Elsewhere, or where neither can be read, nothing is
// refused (the figure cannot be checked). Read once per preparation, never per touch.
#pragma once

#include <cstdint>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>

namespace tacmap {

/// Thrown when a model's preparation would need more memory than is available. The message names
/// the model, what it would allocate, both figures and what to change; the figures are fields,
/// so a caller can, e.g., retry at a coarser scale.
class insufficient_memory : public std::runtime_error {
 public:
  insufficient_memory(const std::string& message, std::uint64_t needed, std::uint64_t available)
      : std::runtime_error(message), needed_bytes(needed), available_bytes(available) {}
  std::uint64_t needed_bytes;     ///< what the preparation would allocate
  std::uint64_t available_bytes;  ///< what the system reported as available
};

namespace detail {

/// A byte count for messages: "1.43 GB", "512 MB", "12 KB", "17 bytes" (powers of 1000).
inline std::string bytes_text(std::uint64_t bytes) {
  std::ostringstream out;
  out.precision(3);
  const auto b = static_cast<double>(bytes);
  if (b >= 1e9)
    out << b / 1e9 << " GB";
  else if (b >= 1e6)
    out << b / 1e6 << " MB";
  else if (b >= 1e3)
    out << b / 1e3 << " KB";
  else
    out << bytes << " bytes";
  return out.str();
}

/// The first unsigned integer in a file (a cgroup limit or usage), or nothing when the file is
/// missing, unreadable or says "max".
inline std::optional<std::uint64_t> read_unsigned(const char* path) {
  std::ifstream in(path);
  std::uint64_t value = 0;
  if (in >> value) return value;
  return std::nullopt;
}

/// MemAvailable from /proc/meminfo, in bytes.
inline std::optional<std::uint64_t> meminfo_available() {
  std::ifstream in("/proc/meminfo");
  std::string key;
  std::uint64_t kib = 0;
  std::string unit;
  while (in >> key >> kib >> unit)
    if (key == "MemAvailable:") return kib * 1024;
  return std::nullopt;
}

}  // namespace detail

/// Memory a new allocation can take without swapping, bytes: the smallest of /proc/meminfo's
/// MemAvailable and the process's cgroup headroom (see the file comment). Nothing when it cannot
/// be told (not Linux, or nothing readable).
[[nodiscard]] inline std::optional<std::uint64_t> available_memory_bytes() {
  std::optional<std::uint64_t> least = detail::meminfo_available();
  const auto take = [&least](std::optional<std::uint64_t> limit,
                             std::optional<std::uint64_t> used) {
    if (!limit) return;
    const std::uint64_t headroom = (used && *used < *limit) ? *limit - *used : (used ? 0 : *limit);
    if (!least || headroom < *least) least = headroom;
  };
  take(detail::read_unsigned("/sys/fs/cgroup/memory.max"),
       detail::read_unsigned("/sys/fs/cgroup/memory.current"));
  // cgroup v1 reports "no limit" as a huge number (about 2^63); ignore anything above 2^60.
  const auto v1 = detail::read_unsigned("/sys/fs/cgroup/memory/memory.limit_in_bytes");
  if (v1 && *v1 < (std::uint64_t{1} << 60))
    take(v1, detail::read_unsigned("/sys/fs/cgroup/memory/memory.usage_in_bytes"));
  return least;
}

namespace detail {

/// Throws `insufficient_memory` when `bytes` (what `who` is about to allocate for `what`) exceeds
/// `available` (the system's figure, `available_memory_bytes()` by default); `advice` says what to
/// change. Nothing is refused when the available memory cannot be told.
inline void check_memory(const char* who, const std::string& what, std::uint64_t bytes,
                         const char* advice,
                         std::optional<std::uint64_t> available = available_memory_bytes()) {
  if (!available || bytes <= *available) return;
  std::ostringstream out;
  out << who << ": preparing this map needs " << bytes_text(bytes) << " for " << what << ", but "
      << bytes_text(*available) << " is available; " << advice;
  throw insufficient_memory(out.str(), bytes, *available);
}

/// a * b * ... in 64 bits, saturating at the largest value instead of wrapping (a map so large
/// that the product overflows is refused like any other that does not fit).
template <class... Ints>
[[nodiscard]] std::uint64_t saturating_product(Ints... factors) {
  std::uint64_t p = 1;
  for (const auto f : {static_cast<std::uint64_t>(factors)...}) {
    if (f != 0 && p > std::numeric_limits<std::uint64_t>::max() / f)
      return std::numeric_limits<std::uint64_t>::max();
    p *= f;
  }
  return p;
}

}  // namespace detail
}  // namespace tacmap
