#pragma once
// Fault injection shared by the mock devices (garbage bytes, truncated frames, bad
// checksums, dropouts; disappearing devices are handled by each transport mock).

#include <array>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <random>
#include <vector>

namespace vog::mock {

enum class Fault : std::uint8_t {
  kGarbage,      // line noise before the message
  kTruncate,     // only the first half of the message is sent
  kBadChecksum,  // the message is sent with a corrupted checksum / CRC
  kDropout,      // the message is not sent at all
};
constexpr int kFaultKinds = 4;

// Lifecycle: inject() arms faults for the next messages; apply() is called once per outgoing message.
// Threading: all members are safe to call from any thread (one mutex).
// Determinism: garbage content and length come from a seeded generator.
class FaultInjector {
 public:
  // Rewrites the checksum of an encoded message so that it no longer matches (protocol specific).
  using CorruptChecksum = std::function<void(std::vector<std::uint8_t>& message)>;

  explicit FaultInjector(std::uint64_t seed = 1) : rng_(seed) {}

  // The next `count` outgoing messages get `fault`. Faults armed earlier are applied first.
  void inject(Fault fault, int count = 1);
  // Returns what to put on the wire for `message`. Garbage bytes are drawn from 0x80..0xFE, which
  // holds no sync byte of the PD0 (0x7F), NMEA ($), Digiquartz (*) protocols, so the message after
  // the noise is always recoverable; adversarial noise is the decoders' own fuzz tests' business.
  std::vector<std::uint8_t> apply(std::vector<std::uint8_t> message, const CorruptChecksum& corrupt);
  // For message kinds apply() does not fit (frame records): the next armed fault, counted as
  // applied, or none; and 1..max_bytes bytes of noise from the same range and generator.
  std::optional<Fault> take();
  std::vector<std::uint8_t> noise(std::size_t max_bytes = 64);
  // Number of messages each fault was applied to, indexed by Fault.
  std::array<std::uint64_t, kFaultKinds> applied() const;
  std::size_t armed() const;

 private:
  mutable std::mutex mutex_;
  std::vector<Fault> armed_;                          // guarded by mutex_, front = next
  std::array<std::uint64_t, kFaultKinds> applied_{};  // guarded by mutex_
  std::mt19937_64 rng_;                               // guarded by mutex_
};

}  // namespace vog::mock
