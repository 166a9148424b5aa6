#pragma once
// Seeded randomness. Every model owns its own std::mt19937_64 seeded from (run seed, stream id), so
// adding a sensor or changing one model's draw count leaves every other stream unchanged.
// std::normal_distribution is deterministic for a given standard library (libstdc++ here).

#include <cstdint>
#include <random>

namespace vog::sim {

// SplitMix64 finaliser (Steele et al. 2014): decorrelates nearby seeds.
constexpr std::uint64_t mixSeed(std::uint64_t seed, std::uint64_t stream) {
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ull * (stream + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// Stream ids of the simulator's random sources.
enum class RngStream : std::uint64_t {
  kSurface = 1,
  kSonarRange = 2,
  kSonarFrame = 3,
  kDvl = 4,
  kImu = 5,
  kDepth = 6,
  kOdometry = 7,
};

inline std::mt19937_64 makeRng(std::uint64_t seed, RngStream stream) {
  return std::mt19937_64(mixSeed(seed, static_cast<std::uint64_t>(stream)));
}

}  // namespace vog::sim
