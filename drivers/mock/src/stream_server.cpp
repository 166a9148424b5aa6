#include "vog/mock/stream_server.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace vog::mock {

StreamServer::StreamServer(StreamServerConfig config, ClientHandler on_client)
    : config_(std::move(config)), on_client_(std::move(on_client)) {}

Result<std::unique_ptr<StreamServer>> StreamServer::create(StreamServerConfig config, ClientHandler on_client) {
  std::unique_ptr<StreamServer> s(new StreamServer(std::move(config), std::move(on_client)));
  Status ok = s->listen();
  if (!ok.ok()) return ok.error();
  StreamServer* raw = s.get();
  s->thread_.start(
      [raw](std::vector<pollfd>& fds) {
        if (raw->listen_fd_ >= 0) fds.push_back(pollfd{raw->listen_fd_, POLLIN, 0});
        for (int fd : raw->clients_) fds.push_back(pollfd{fd, POLLIN, 0});
      },
      [raw](const std::vector<pollfd>& fds) { raw->onReady(fds); });
  return s;
}

StreamServer::~StreamServer() {
  thread_.stop();
  closeAll();
}

Status StreamServer::listen() {
  const bool seqpacket = !config_.seqpacket_path.empty();
  const int fd = seqpacket ? ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0)
                           : ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return Error{errnoText("socket")};
  if (seqpacket) {
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    if (config_.seqpacket_path.size() >= sizeof(addr.sun_path)) {
      ::close(fd);
      return Error{"seqpacket path too long: " + config_.seqpacket_path};
    }
    std::memcpy(addr.sun_path, config_.seqpacket_path.c_str(), config_.seqpacket_path.size() + 1);
    ::unlink(config_.seqpacket_path.c_str());
    if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
      const std::string msg = errnoText("bind " + config_.seqpacket_path);
      ::close(fd);
      return Error{msg};
    }
  } else {
    const int one = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(port_ != 0 ? port_ : config_.tcp_port);
    if (::inet_pton(AF_INET, config_.tcp_address.c_str(), &addr.sin_addr) != 1) {
      ::close(fd);
      return Error{"tcp_address '" + config_.tcp_address + "' is not a numeric IPv4 address"};
    }
    if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
      const std::string msg = errnoText("bind " + config_.tcp_address + ":" + std::to_string(ntohs(addr.sin_port)));
      ::close(fd);
      return Error{msg};
    }
    socklen_t len = sizeof(addr);
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
    port_ = ntohs(addr.sin_port);
  }
  if (::listen(fd, 4) != 0) {
    const std::string msg = errnoText("listen");
    ::close(fd);
    return Error{msg};
  }
  listen_fd_ = fd;
  return Status::success();
}

void StreamServer::closeAll() {
  for (int fd : clients_) ::close(fd);
  clients_.clear();
  if (listen_fd_ >= 0) {
    ::close(listen_fd_);
    listen_fd_ = -1;
    if (!config_.seqpacket_path.empty()) ::unlink(config_.seqpacket_path.c_str());
  }
  std::lock_guard<std::mutex> lock(mutex_);
  client_count_ = 0;
}

void StreamServer::onReady(const std::vector<pollfd>& fds) {
  for (const pollfd& p : fds) {
    if (p.revents == 0) continue;
    if (p.fd == listen_fd_) {
      const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
      if (fd >= 0) clients_.push_back(fd);
    } else {
      std::uint8_t buffer[4096];
      const ssize_t n = ::recv(p.fd, buffer, sizeof(buffer), MSG_DONTWAIT);
      if (n > 0) {
        if (on_client_) on_client_(std::span<const std::uint8_t>(buffer, static_cast<std::size_t>(n)));
      } else if (n == 0 || (errno != EAGAIN && errno != EINTR)) {
        ::close(p.fd);
        std::erase(clients_, p.fd);
      }
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  client_count_ = clients_.size();
}

void StreamServer::send(std::vector<std::vector<std::uint8_t>> records) {
  thread_.post([this, records = std::move(records)] {
    std::uint64_t sent = 0;
    for (auto it = clients_.begin(); it != clients_.end();) {
      bool ok = true;
      for (const auto& r : records) {
        std::size_t off = 0;
        // A zero-length record is a valid (empty) packet on a seqpacket socket.
        do {
          const ssize_t n = ::send(*it, r.data() + off, r.size() - off, MSG_NOSIGNAL);
          if (n < 0) {
            ok = false;
            break;
          }
          off += static_cast<std::size_t>(n);
        } while (off < r.size());
        if (!ok) break;
        ++sent;
      }
      if (ok) {
        ++it;
      } else {
        ::close(*it);
        it = clients_.erase(it);
      }
    }
    std::lock_guard<std::mutex> lock(mutex_);
    records_sent_ += sent;
    client_count_ = clients_.size();
  });
}

void StreamServer::disappear() {
  thread_.call([this] { closeAll(); });
}

Status StreamServer::reappear() {
  Status result;
  thread_.call([this, &result] {
    if (listen_fd_ >= 0) {
      result = Error{"server is already listening"};
      return;
    }
    result = listen();
  });
  return result;
}

std::size_t StreamServer::clientCount() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return client_count_;
}

std::uint64_t StreamServer::recordsSent() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return records_sent_;
}

}  // namespace vog::mock
