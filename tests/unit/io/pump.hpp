#pragma once
// Helpers of the io tests: run an io_context until a condition holds or a deadline passes (no
// sleep-based races), deterministic stamps and payloads.

#include <asio.hpp>

#include <chrono>
#include <cstdint>
#include <functional>
#include <random>
#include <thread>
#include <vector>

namespace vog::test {

inline bool pumpUntil(asio::io_context& io, const std::function<bool()>& done,
                      std::chrono::milliseconds timeout = std::chrono::milliseconds(3000)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    // One handler at a time so the condition is checked as soon as it may have changed.
    if (io.stopped()) io.restart();
    if (io.run_one_for(std::chrono::milliseconds(5)) == 0) {
      io.restart();
      std::this_thread::sleep_for(std::chrono::microseconds(200));  // no pending work: another thread will act
    }
  }
  return true;
}

// A StampClock that advances by a fixed step on every reading: deterministic stamps.
struct SteppingClock {
  std::int64_t next_ns = 1'000'000'000;
  std::int64_t step_ns = 1'000'000;
  std::int64_t operator()() {
    const std::int64_t t = next_ns;
    next_ns += step_ns;
    return t;
  }
};

// n bytes drawn from a generator seeded with `seed`.
inline std::vector<std::uint8_t> randomBytes(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<std::uint8_t> out(n);
  for (auto& b : out) b = static_cast<std::uint8_t>(rng());
  return out;
}

}  // namespace vog::test
