// Shared by the API fuzz targets (localizer_api, library_localizer_api): reads typed values from
// the fuzz input, so that the fuzzer's byte mutations become changes of one setting, one frame or
// one motion. Past the end every read gives 0 (the inputs may be any length).
//
// Numbers come in two kinds. A "setting" (`real`) is usually a plausible value in a range, but one
// byte in eight picks an edge from a table (0, -0, denormals, 1e-300, 1e300, DBL_MAX, infinities,
// NaN, negative values): the values a validating API has to refuse or survive. `raw_double`
// reinterprets 8 bytes, for values no table lists.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <limits>
#include <optional>
#include <span>
#include <stdexcept>
#include <string_view>
#include <utility>
#include <vector>

#include "fuzz_check.hpp"

namespace tacmap_fuzz {

class input {
 public:
  input(const std::uint8_t* data, std::size_t size) : bytes_(data, size) {}

  [[nodiscard]] bool empty() const { return at_ >= bytes_.size(); }
  [[nodiscard]] std::size_t remaining() const { return empty() ? 0 : bytes_.size() - at_; }
  [[nodiscard]] std::size_t position() const { return std::min(at_, bytes_.size()); }
  /// The bytes read since `from` (a `position()`), e.g. as a cache key.
  [[nodiscard]] std::vector<std::uint8_t> read_since(std::size_t from) const {
    return {bytes_.begin() + static_cast<std::ptrdiff_t>(from),
            bytes_.begin() + static_cast<std::ptrdiff_t>(position())};
  }

  std::uint8_t byte() { return at_ < bytes_.size() ? bytes_[at_++] : std::uint8_t{0}; }
  std::uint16_t u16() {
    const auto lo = byte();
    return static_cast<std::uint16_t>(lo | (byte() << 8U));
  }
  std::uint32_t u32() {
    const std::uint32_t lo = u16();
    return lo | (static_cast<std::uint32_t>(u16()) << 16U);
  }
  bool flag() { return (byte() & 1U) != 0U; }
  /// An integer in [lo, hi].
  int between(int lo, int hi) {
    const auto span = static_cast<std::uint32_t>(hi - lo) + 1U;
    return lo + static_cast<int>(u16() % span);
  }
  template <class E>
  E choice(int count) {
    return static_cast<E>(byte() % count);
  }

  double raw_double() {
    std::uint64_t bits = u32();
    bits |= static_cast<std::uint64_t>(u32()) << 32U;
    double out = 0.0;
    std::memcpy(&out, &bits, sizeof out);
    return out;
  }

  /// An edge value (see the file comment).
  static double edge(std::uint8_t k) {
    constexpr double inf = std::numeric_limits<double>::infinity();
    static constexpr std::array<double, 16> table = {0.0,
                                                     -0.0,
                                                     std::numeric_limits<double>::denorm_min(),
                                                     1e-300,
                                                     1e-160,
                                                     1e-9,
                                                     1.0,
                                                     -1.0,
                                                     1e9,
                                                     1e160,
                                                     1e300,
                                                     std::numeric_limits<double>::max(),
                                                     -std::numeric_limits<double>::max(),
                                                     inf,
                                                     -inf,
                                                     std::numeric_limits<double>::quiet_NaN()};
    return table[k % table.size()];
  }

  /// A setting: mostly lo + (hi - lo) * u (u uniform in [0, 1] on 16 bits), one in eight an
  /// edge value or 8 raw bytes.
  double real(double lo, double hi) {
    const std::uint8_t kind = byte();
    if ((kind & 7U) == 7U) return (kind & 8U) != 0U ? raw_double() : edge(kind >> 4U);
    return lo + (hi - lo) * (static_cast<double>(u16()) / 65535.0);
  }
  /// A setting that may be left unset (bit 0 of the first byte clear: nullopt).
  std::optional<double> maybe_real(double lo, double hi) {
    if (!flag()) return std::nullopt;
    return real(lo, hi);
  }

 private:
  std::span<const std::uint8_t> bytes_;
  std::size_t at_ = 0;
};

/// A small, fast generator for map pixels and frame counts (splitmix64): deterministic in the
/// input's seed bytes, so a map needs 8 bytes of input, not one per pixel.
class random_bits {
 public:
  explicit random_bits(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30U)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27U)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31U);
  }
  /// Uniform in [0, 1).
  float unit() { return static_cast<float>(next() >> 40U) / static_cast<float>(1U << 24U); }

 private:
  std::uint64_t state_;
};

/// TACMAP_FUZZ_VERBOSE=1 in the environment prints every refusal (to see what a finding did).
inline bool verbose() {
  static const bool on = std::getenv("TACMAP_FUZZ_VERBOSE") != nullptr;
  return on;
}

/// What a call threw.
enum class refusal { none, invalid_argument, domain_error };

/// Runs `call`. The exceptions the public API documents for bad input are std::invalid_argument
/// (a value out of range) and std::domain_error (a belief the model cannot continue from); they
/// are caught and reported. Anything else escaping the API, or one of these without a message,
/// is a finding.
template <class Call>
refusal refused(Call&& call) {
  try {
    std::forward<Call>(call)();
  } catch (const std::invalid_argument& e) {
    if (verbose()) std::fprintf(stderr, "refused (invalid_argument): %s\n", e.what());
    TACMAP_FUZZ_CHECK(std::string_view(e.what()).size() > 20);
    return refusal::invalid_argument;
  } catch (const std::domain_error& e) {
    if (verbose()) std::fprintf(stderr, "refused (domain_error): %s\n", e.what());
    TACMAP_FUZZ_CHECK(std::string_view(e.what()).size() > 20);
    return refusal::domain_error;
  }
  return refusal::none;
}

template <class Call>
bool throws_documented(Call&& call) {
  return refused(std::forward<Call>(call)) != refusal::none;
}

}  // namespace tacmap_fuzz
