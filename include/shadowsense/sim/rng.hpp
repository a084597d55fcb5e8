// A small seedable random generator for the scene generator. Our own (SplitMix64) rather
// than std::mt19937 + std distributions, whose outputs differ between standard libraries:
// a seed must give byte-identical frames and csv files on every platform.
#pragma once

#include <shadowsense/core/version.hpp>

#include <cmath>
#include <cstdint>

SHADOWSENSE_NAMESPACE_BEGIN
namespace sim {

// SplitMix64 finaliser: a good 64-bit mixing function. Also used to derive independent
// seeds (per frame, per session) so one frame never depends on how many frames came before.
[[nodiscard]] constexpr std::uint64_t mix64(std::uint64_t x) noexcept {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Combines a seed with a stream index (e.g. frame number) into a new seed.
[[nodiscard]] constexpr std::uint64_t derive_seed(std::uint64_t seed,
                                                  std::uint64_t stream) noexcept {
  return mix64(seed ^ mix64(stream + 0x632BE59BD9B4E019ull));
}

class Rng {
public:
  explicit constexpr Rng(std::uint64_t seed = 0) noexcept : state_(seed) {}

  // Next raw 64-bit value (SplitMix64).
  constexpr std::uint64_t next() noexcept {
    state_ += 0x9E3779B97F4A7C15ull;
    std::uint64_t z = state_;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }

  // Uniform in [0, 1) with 53 random bits.
  double uniform() noexcept { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  // Uniform in [lo, hi).
  double uniform(double lo, double hi) noexcept { return lo + (hi - lo) * uniform(); }
  // Uniform integer in [lo, hi] (inclusive). Modulo bias is < 2^-40 for the small ranges used.
  int integer(int lo, int hi) noexcept {
    const auto span = static_cast<std::uint64_t>(static_cast<std::int64_t>(hi) - lo + 1);
    return lo + static_cast<int>(next() % span);
  }
  // True with probability p.
  bool chance(double p) noexcept { return uniform() < p; }
  // Standard normal (Box-Muller, one value per call; deterministic, no cached state).
  double normal() noexcept {
    const double u1 = (static_cast<double>(next() >> 11) + 1.0) * 0x1.0p-53; // (0, 1]
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }
  double normal(double mean, double sigma) noexcept { return mean + sigma * normal(); }

  std::uint64_t state() const noexcept { return state_; }

private:
  std::uint64_t state_;
};

} // namespace sim
SHADOWSENSE_NAMESPACE_END
