// Helpers shared by tacmap's tests.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>

namespace tacmap_test {

/// The message of the `Exception` that `call()` throws, or "no exception". Tests check that error
/// messages name the offending value and what was expected.
template <class Exception = std::invalid_argument, class Call>
std::string message_of(Call&& call) {
  try {
    std::forward<Call>(call)();
  } catch (const Exception& e) {
    return e.what();
  }
  return "no exception";
}

/// Deterministic pseudo-random integers for tests (a linear congruential generator): the same
/// sequence on every platform and standard library, which std's distributions do not promise.
class lcg {
 public:
  explicit lcg(std::uint32_t seed) : state_(seed) {}
  /// An integer in [0, bound), for 0 < bound <= 2^24.
  std::ptrdiff_t operator()(std::ptrdiff_t bound) {
    state_ = state_ * 1664525U + 1013904223U;
    return static_cast<std::ptrdiff_t>((state_ >> 8U) % static_cast<std::uint32_t>(bound));
  }

 private:
  std::uint32_t state_;
};

}  // namespace tacmap_test
