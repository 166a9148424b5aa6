#pragma once
// Device health: what every transport reports about its link, so the daemon can show a device's
// state and recover when it returns ("Bad input").

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

namespace vog::io {

// Source of timestamps for received data, injected by the caller so tests are deterministic.
// Returns nanoseconds on the caller's time base (steady clock in the daemon, simulated time in tests).
using StampClock = std::function<std::int64_t()>;

// Monotonic clock in nanoseconds (std::chrono::steady_clock), the default StampClock.
StampClock steadyStampClock();

enum class LinkState { kDisconnected, kConnecting, kConnected };

std::string_view toString(LinkState state);

struct DeviceHealth {
  LinkState state = LinkState::kDisconnected;
  std::string reason = "not started";    // why the link is in `state` (last open error, hangup, ...)
  std::int64_t last_data_stamp_ns = -1;  // stamp of the newest received data, -1 = none yet
  std::uint64_t bytes_rx = 0;
  std::uint64_t bytes_tx = 0;
  std::uint64_t frames_rx = 0;  // datagrams / CAN frames / Modbus replies (0 for byte streams)
  std::uint64_t frames_tx = 0;
  std::uint64_t errors = 0;    // failed opens, I/O errors, malformed records, rejected writes
  std::uint64_t connects = 0;  // successful opens (1 + number of reconnects)
  std::string last_error;      // text of the newest error, empty if none
};

// Called on every state change with the new health record.
using StateHandler = std::function<void(const DeviceHealth&)>;

}  // namespace vog::io
