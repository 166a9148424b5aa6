#pragma once
// Serial port transport: termios through Asio serial_port, raw mode, exclusive open (TIOCEXCL),
// reconnect with backoff when the device disappears and returns (USB adapter unplugged, pty closed).

#include <cstddef>
#include <memory>
#include <span>
#include <string>

#include "vog/core/result.hpp"
#include "vog/io/byte_stream.hpp"
#include "vog/io/health.hpp"
#include "vog/io/reconnect.hpp"

namespace vog::io {

enum class Parity { kNone, kOdd, kEven };

struct SerialConfig {
  std::string device_path;  // e.g. /dev/ttyUSB0 or a symlink such as /dev/serial/by-id/...
  unsigned baud = 115200;   // PD0 Workhorse default 115200 8N1; Digiquartz commonly 9600 8N1
  Parity parity = Parity::kNone;
  int data_bits = 8;      // 5..8
  int stop_bits = 1;      // 1 or 2
  bool exclusive = true;  // TIOCEXCL: a second open by another process fails with EBUSY
  std::size_t read_chunk_bytes = 4096;
  ReconnectConfig reconnect;

  // `prefix` names the config section in messages, e.g. "dvl.serial".
  Status validate(const std::string& prefix = "serial") const;
};

// Lifecycle: construct, start() (validates the config, then opens asynchronously and keeps
// reopening with backoff while running), write() while connected, stop() or destruction.
// Threading: call every member from the thread that runs the io_context; callbacks run there too.
// Invariant: stop() reports the "stopped" state, then no callback is invoked; destruction reports nothing.
class SerialTransport {
 public:
  SerialTransport(asio::io_context& io, SerialConfig config, StampClock clock, ByteHandler on_bytes,
                  StateHandler on_state = {});
  ~SerialTransport();
  SerialTransport(const SerialTransport&) = delete;
  SerialTransport& operator=(const SerialTransport&) = delete;

  Status start();
  void stop();
  // Queues bytes for sending; fails when the port is not connected.
  Status write(std::span<const std::uint8_t> bytes);
  const DeviceHealth& health() const;

  class Impl;

 private:
  std::shared_ptr<Impl> impl_;
};

}  // namespace vog::io
