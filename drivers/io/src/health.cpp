#include "vog/io/health.hpp"

#include <chrono>

namespace vog::io {

StampClock steadyStampClock() {
  return [] {
    return static_cast<std::int64_t>(
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
            .count());
  };
}

std::string_view toString(LinkState state) {
  switch (state) {
    case LinkState::kDisconnected: return "disconnected";
    case LinkState::kConnecting: return "connecting";
    case LinkState::kConnected: return "connected";
  }
  return "unknown";
}

}  // namespace vog::io
