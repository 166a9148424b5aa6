#pragma once
// UDP transports: a receiver that delivers whole datagrams (sonar live frames) and a sender.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>

#include "vog/core/result.hpp"
#include "vog/io/byte_stream.hpp"
#include "vog/io/health.hpp"
#include "vog/io/reconnect.hpp"

namespace vog::io {

// One whole datagram, stamped at reception.
using DatagramHandler = std::function<void(std::span<const std::uint8_t> datagram, std::int64_t stamp_ns)>;

struct UdpReceiverConfig {
  std::string bind_address = "127.0.0.1";  // numeric IPv4/IPv6 address
  std::uint16_t port = 0;                  // 0 = any free port (see UdpReceiver::localPort)
  // Largest datagram accepted; a larger one is counted as an error and dropped, never delivered
  // truncated. 65507 = largest UDP payload over IPv4; a 96 x 512 DIDSON frame is 49152 bytes.
  std::size_t max_datagram_bytes = 65507;
  int receive_buffer_bytes = 4 << 20;  // SO_RCVBUF: several frames of burst at 10 frames/s
  ReconnectConfig reconnect;           // rebinding when the bind fails (address not yet up)

  Status validate(const std::string& prefix = "udp") const;
};

// Lifecycle: construct, start() binds (retrying with backoff if binding fails), datagrams are
// delivered until stop()/destruction. Threading: io_context thread only. stop() reports the
// "stopped" state, then no callback is invoked; destruction reports nothing.
class UdpReceiver {
 public:
  UdpReceiver(asio::io_context& io, UdpReceiverConfig config, StampClock clock, DatagramHandler on_datagram,
              StateHandler on_state = {});
  ~UdpReceiver();
  UdpReceiver(const UdpReceiver&) = delete;
  UdpReceiver& operator=(const UdpReceiver&) = delete;

  Status start();
  void stop();
  // Bound port (useful with port 0); 0 while not bound.
  std::uint16_t localPort() const;
  // The numeric address the datagram being delivered came from; valid inside the handler only.
  std::string senderAddress() const;
  // Sends a datagram from the bound socket (replies such as acknowledgements leave from the port the
  // peer sends to). Error naming the destination when not bound, the address is not numeric, or the
  // send fails (counted in health().errors).
  Status sendTo(const std::string& address, std::uint16_t port, std::span<const std::uint8_t> datagram);
  const DeviceHealth& health() const;

  class Impl;

 private:
  std::shared_ptr<Impl> impl_;
};

struct UdpSenderConfig {
  std::string address = "127.0.0.1";  // numeric destination address
  std::uint16_t port = 0;             // destination port, must be set

  Status validate(const std::string& prefix = "udp_sender") const;
};

// Sends datagrams synchronously (a UDP send does not block on a healthy host).
// Lifecycle: open(), send()..., destruction closes. Not thread-safe: one thread at a time.
class UdpSender {
 public:
  UdpSender(asio::io_context& io, UdpSenderConfig config);
  ~UdpSender();
  UdpSender(const UdpSender&) = delete;
  UdpSender& operator=(const UdpSender&) = delete;

  Status open();
  Status send(std::span<const std::uint8_t> datagram);
  const DeviceHealth& health() const { return health_; }

 private:
  struct Socket;
  UdpSenderConfig config_;
  std::unique_ptr<Socket> socket_;
  DeviceHealth health_;
};

}  // namespace vog::io
