#pragma once
// Server side of a socket device: a TCP listener on 127.0.0.1 (backseat) or a Unix-domain
// SOCK_SEQPACKET listener at a path (the CAN stand-in). Sends records to every connected client;
// can disappear (listener and connections closed, path removed) and reappear at the same address.

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "vog/core/result.hpp"
#include "vog/mock/device_thread.hpp"

namespace vog::mock {

struct StreamServerConfig {
  // Exactly one: a TCP port on `tcp_address` (0 = any free port) or a SOCK_SEQPACKET path.
  std::string tcp_address = "127.0.0.1";
  std::uint16_t tcp_port = 0;
  std::string seqpacket_path;  // when set, the server is a Unix-domain SOCK_SEQPACKET one
};

// Lifecycle: create() listens and starts the device thread; send() reaches clients connected at
// that moment; disappear()/reappear() on command; destruction closes everything (and unlinks the
// path). Threading: public members from any thread; client I/O on the device thread only.
// Invariant: on a seqpacket server every record is one packet, on TCP records are concatenated.
class StreamServer {
 public:
  // Bytes (TCP) or one packet (seqpacket) received from a client, on the device thread.
  using ClientHandler = std::function<void(std::span<const std::uint8_t>)>;

  static Result<std::unique_ptr<StreamServer>> create(StreamServerConfig config, ClientHandler on_client = {});
  ~StreamServer();
  StreamServer(const StreamServer&) = delete;
  StreamServer& operator=(const StreamServer&) = delete;

  void send(std::vector<std::vector<std::uint8_t>> records);
  void disappear();
  Status reappear();
  std::uint16_t port() const { return port_; }
  std::size_t clientCount() const;
  std::uint64_t recordsSent() const;

 private:
  StreamServer(StreamServerConfig config, ClientHandler on_client);
  Status listen();
  void closeAll();
  void onReady(const std::vector<pollfd>& fds);

  StreamServerConfig config_;
  ClientHandler on_client_;
  std::uint16_t port_ = 0;
  int listen_fd_ = -1;              // device thread
  std::vector<int> clients_;        // device thread
  std::size_t client_count_ = 0;    // atomic-ish copy, guarded by mutex_
  std::uint64_t records_sent_ = 0;  // guarded by mutex_
  mutable std::mutex mutex_;
  DeviceThread thread_;
};

}  // namespace vog::mock
