#pragma once
/// \file Seeded random streams. One run seed determines every stream; each stream is derived from the
/// seed and its place in the computation (episode, generation, candidate, rollout), so results do not
/// depend on the number of threads.

#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>

namespace drops {

/// SplitMix64 finaliser (Steele, Lea & Flood 2014): a bijective 64-bit mixer. Thread-safe (pure).
constexpr std::uint64_t splitmix64(std::uint64_t z) {
  z += 0x9E3779B97F4A7C15ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

/// Derives the seed of a sub-stream from a parent seed and a path of indices, e.g.
/// derive_seed(run_seed, {episode, generation, candidate}). Distinct paths give independent-looking
/// streams. Thread-safe (pure).
inline std::uint64_t derive_seed(std::uint64_t seed, std::initializer_list<std::uint64_t> path) {
  std::uint64_t s = splitmix64(seed);
  for (std::uint64_t p : path) s = splitmix64(s ^ splitmix64(p + 0x632BE59BD9B4E019ULL));
  return s;
}

/// xoshiro256++ generator (Blackman & Vigna 2018), satisfies UniformRandomBitGenerator.
/// Not thread-safe: one instance per stream.
class Rng {
 public:
  using result_type = std::uint64_t;
  /// Seeds the four words of state from `seed` through SplitMix64.
  explicit Rng(std::uint64_t seed = 0) {
    std::uint64_t z = seed;
    for (auto& w : s_) {
      z += 0x9E3779B97F4A7C15ULL;
      w = splitmix64(z);
    }
  }
  static constexpr result_type min() { return 0; }
  static constexpr result_type max() { return std::numeric_limits<result_type>::max(); }
  result_type operator()() {
    const std::uint64_t result = rotl(s_[0] + s_[3], 23) + s_[0];
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }
  /// Uniform double in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>((*this)() >> 11) * 0x1.0p-53; }
  /// Uniform double in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Standard normal draw (Marsaglia polar method; caches the second value).
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u, v, s;
    do {
      u = 2.0 * uniform() - 1.0;
      v = 2.0 * uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double m = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * m;
    has_spare_ = true;
    return u * m;
  }

 private:
  static constexpr std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  std::uint64_t s_[4];
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace drops
