// tacmap: `sim_rng` — a small, portable pseudo-random generator for simulations and data.
//
// Why our own: std::normal_distribution (and the other std:: distributions) are specified by
// their results' distribution, not their algorithm, so libstdc++, libc++ and MSVC give different
// numbers for the same engine and seed. The simulator and the bundled data promise "same seed,
// same frames" everywhere, so the generator and the normal sampler are spelled out here:
// splitmix64 expands a 64-bit seed into the state of xoshiro256** (Blackman & Vigna), and normal
// deviates come from the Box-Muller transform. Only std::log, std::sqrt and std::cos remain
// platform-dependent, to the last bit of a double at most.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>

#include "tacmap/config.hpp"

namespace tacmap {

/// One step of splitmix64: advances `state` and returns a well-mixed 64-bit value. Used to seed
/// xoshiro and to derive independent sub-seeds (gains, dead taxels, noise) from one seed.
[[nodiscard]] constexpr std::uint64_t splitmix64(std::uint64_t& state) {
  state += 0x9E3779B97F4A7C15ULL;
  std::uint64_t z = state;
  z = (z ^ (z >> 30U)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27U)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31U);
}

/// xoshiro256** with uniform, bounded-integer and normal sampling. A value type: copy it to fork
/// a stream. Not cryptographic.
class sim_rng {
 public:
  explicit constexpr sim_rng(std::uint64_t seed = 0) {
    std::uint64_t s = seed;
    for (auto& word : state_) word = splitmix64(s);
  }

  /// The next 64 random bits.
  constexpr std::uint64_t next_u64() {
    const std::uint64_t result = rotl(state_[1] * 5U, 7) * 9U;
    const std::uint64_t t = state_[1] << 17U;
    state_[2] ^= state_[0];
    state_[3] ^= state_[1];
    state_[1] ^= state_[2];
    state_[0] ^= state_[3];
    state_[2] ^= t;
    state_[3] = rotl(state_[3], 45);
    return result;
  }

  /// Uniform in [0, 1) with 53 random bits.
  constexpr double uniform() { return static_cast<double>(next_u64() >> 11U) * 0x1.0p-53; }

  /// Uniform integer in [0, n) for n > 0 (Lemire's nearly-divisionless method would be faster;
  /// rejection keeps it exact and obviously unbiased).
  constexpr std::uint64_t below(std::uint64_t n) {
    TACMAP_ASSERT(n > 0, "sim_rng::below needs n > 0");
    const std::uint64_t limit = UINT64_MAX - UINT64_MAX % n;
    std::uint64_t x = next_u64();
    while (x >= limit) x = next_u64();
    return x % n;
  }

  /// Standard normal deviate (Box-Muller; the second value of each pair is kept for the next
  /// call, so the stream is a fixed function of the seed and the call sequence).
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = 1.0 - uniform();  // (0, 1]: log is finite
    const double u2 = uniform();
    const double radius = std::sqrt(-2.0 * std::log(u1));
    const double angle = 2.0 * std::numbers::pi * u2;
    spare_ = radius * std::sin(angle);
    has_spare_ = true;
    return radius * std::cos(angle);
  }

 private:
  static constexpr std::uint64_t rotl(std::uint64_t x, int k) {
    return (x << static_cast<unsigned>(k)) | (x >> static_cast<unsigned>(64 - k));
  }

  std::array<std::uint64_t, 4> state_{};
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace tacmap
