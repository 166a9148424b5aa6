#pragma once
// SocketCAN transport. The read/write loop works on any file descriptor that carries whole
// `struct can_frame` records (PROTOCOLS.md "SocketCAN"): a PF_CAN raw socket on the vehicle, or a
// Unix-domain SOCK_SEQPACKET socket on machines without CAN (this one), which keeps record
// boundaries exactly like a CAN socket does. Both paths apply the same software filter, so what
// the caller receives does not depend on the path.

#include <linux/can.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "vog/core/result.hpp"
#include "vog/io/byte_stream.hpp"
#include "vog/io/health.hpp"
#include "vog/io/reconnect.hpp"

namespace vog::io {

// SocketCAN filter semantics (linux/can.h): a frame passes when
// (frame.can_id & mask) == (id & mask), on the full can_id including the EFF/RTR flag bits.
struct CanFilter {
  std::uint32_t id = 0;
  std::uint32_t mask = 0;
  bool matches(std::uint32_t can_id) const { return (can_id & mask) == (id & mask); }
};

// Config `can: {interface: can0}` or `can: {unix_seqpacket: /run/vog/imu.sock}`; exactly one is set.
struct CanConfig {
  std::string interface;           // PF_CAN raw socket bound to this interface (kernel filters + ours)
  std::string unix_seqpacket;      // path of a SOCK_SEQPACKET server socket carrying can_frame records
  std::vector<CanFilter> filters;  // empty = accept every data frame
  ReconnectConfig reconnect;

  Status validate(const std::string& prefix = "can") const;
};

// A frame that passed the filters, stamped at reception.
using CanFrameHandler = std::function<void(const can_frame& frame, std::int64_t stamp_ns)>;

// Lifecycle: construct (from a config, or adopt() an open descriptor), start(), frames are
// delivered until stop()/destruction; a config-based transport reopens with backoff when the
// socket hangs up, an adopted descriptor cannot be reopened and stays disconnected.
// Threading: io_context thread only. Invariant: a record that is not exactly one valid classic
// CAN frame (size != 16, len > 8) or an error frame is counted as an error, never delivered.
class CanTransport {
 public:
  CanTransport(asio::io_context& io, CanConfig config, StampClock clock, CanFrameHandler on_frame,
               StateHandler on_state = {});
  // Takes ownership of `fd` (e.g. one end of socketpair(AF_UNIX, SOCK_SEQPACKET)).
  static std::unique_ptr<CanTransport> adopt(asio::io_context& io, int fd, std::vector<CanFilter> filters,
                                             StampClock clock, CanFrameHandler on_frame, StateHandler on_state = {});
  ~CanTransport();
  CanTransport(const CanTransport&) = delete;
  CanTransport& operator=(const CanTransport&) = delete;

  Status start();
  void stop();
  // Queues one frame for sending; fails when disconnected or the frame is malformed (len > 8).
  Status write(const can_frame& frame);
  const DeviceHealth& health() const;
  // Frames that were valid but rejected by the filters.
  std::uint64_t framesFiltered() const;

  class Impl;

 private:
  explicit CanTransport(std::shared_ptr<Impl> impl);
  std::shared_ptr<Impl> impl_;
};

}  // namespace vog::io
