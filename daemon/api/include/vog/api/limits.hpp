#pragma once
// The allowed range of every API server setting, defined once: ApiServerConfig::validate() (the
// server's own rule) and vogd's configuration reader (which names file:line) both use these.
// Settings whose bound depends on another (max_frame_bytes against the chunk sizes) are checked
// again by validate() across fields.

#include <cstdint>

namespace vog::api {

template <class T>
struct Range {
  T min;
  T max;
  constexpr bool contains(T v) const { return v >= min && v <= max; }
};

namespace limits {

inline constexpr Range<std::uint64_t> kMaxClients{1, 4096};
inline constexpr Range<std::uint64_t> kMaxClientsPerPeer{1, 4096};
inline constexpr Range<std::uint64_t> kMaxInFlight{1, 1024};
inline constexpr Range<double> kMaxRequestsPerS{0.001, 1e6};
inline constexpr Range<double> kRequestBurst{1.0, 1e6};
inline constexpr Range<std::uint64_t> kMaxQueuedResponses{1, 65536};
inline constexpr Range<std::uint64_t> kMaxQueuedWaypoints{1, 65536};
inline constexpr Range<std::uint64_t> kMaxQueuedBytes{64u * 1024, 1ull << 32};
inline constexpr Range<std::int64_t> kSocketSendBufferBytes{0, 64ll << 20};
inline constexpr Range<std::int64_t> kCloseTimeoutMs{1, 60'000};
inline constexpr Range<std::int64_t> kHelloTimeoutMs{100, 600'000};
inline constexpr Range<std::int64_t> kIdleTimeoutMs{1'000, 86'400'000};
inline constexpr Range<std::int64_t> kWriteTimeoutMs{100, 600'000};
inline constexpr Range<std::int64_t> kTlsHandshakeTimeoutMs{1, 600'000};
// The frame bound includes everything after the 4-byte length prefix (the Envelope's bytes).
inline constexpr Range<std::uint64_t> kMaxFrameBytes{64u * 1024, 1u << 30};
inline constexpr Range<std::uint64_t> kMapBlocksPerChunk{1, 1u << 20};
inline constexpr Range<std::uint64_t> kCloudPointsPerChunk{1, 1u << 24};
inline constexpr std::uint64_t kMinSecretBytes = 16;
// The operator secret file's size (trailing line breaks not counted).
inline constexpr Range<std::uint64_t> kSecretFileBytes{kMinSecretBytes, 4096};

}  // namespace limits
}  // namespace vog::api
