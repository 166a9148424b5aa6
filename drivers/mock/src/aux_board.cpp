#include "vog/mock/aux_board.hpp"

#include <modbus.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <mutex>
#include <vector>

namespace vog::mock {

class AuxBoardMock::Impl {
 public:
  explicit Impl(AuxBoardConfig config) : config_(std::move(config)), faults_(config_.seed) {}

  ~Impl() {
    thread_.stop();
    closeAll();
    if (mapping_ != nullptr) modbus_mapping_free(mapping_);
  }

  Status init() {
    mapping_ = modbus_mapping_new(0, 0, config_.holding_registers, config_.input_registers);
    if (mapping_ == nullptr) return Error{std::string("modbus_mapping_new: ") + modbus_strerror(errno)};
    port_ = config_.port;
    Status listening = listen();
    if (!listening.ok()) return listening;
    thread_.start([this](std::vector<pollfd>& fds) { collect(fds); },
                  [this](const std::vector<pollfd>& fds) { onReady(fds); });
    return Status::success();
  }

  Status listen() {
    ctx_ = modbus_new_tcp(config_.address.c_str(), port_);
    if (ctx_ == nullptr) return Error{std::string("modbus_new_tcp: ") + modbus_strerror(errno)};
    listen_fd_ = modbus_tcp_listen(ctx_, 4);
    if (listen_fd_ < 0) {
      const std::string msg =
          "aux board listen on " + config_.address + ":" + std::to_string(port_) + ": " + modbus_strerror(errno);
      modbus_free(ctx_);
      ctx_ = nullptr;
      return Error{msg};
    }
    sockaddr_in addr{};
    socklen_t len = sizeof(addr);
    ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
    port_ = ntohs(addr.sin_port);
    return Status::success();
  }

  void closeAll() {
    for (int fd : clients_) ::close(fd);
    clients_.clear();
    if (listen_fd_ >= 0) ::close(listen_fd_);
    listen_fd_ = -1;
    if (ctx_ != nullptr) modbus_free(ctx_);
    ctx_ = nullptr;
  }

  void collect(std::vector<pollfd>& fds) {
    if (listen_fd_ >= 0) fds.push_back(pollfd{listen_fd_, POLLIN, 0});
    for (int fd : clients_) fds.push_back(pollfd{fd, POLLIN, 0});
  }

  void onReady(const std::vector<pollfd>& fds) {
    for (const pollfd& p : fds) {
      if (p.revents == 0) continue;
      if (p.fd == listen_fd_) {
        const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
        if (fd >= 0) clients_.push_back(fd);
        continue;
      }
      if (!serve(p.fd)) {
        ::close(p.fd);
        std::erase(clients_, p.fd);
      }
    }
  }

  // One request from `fd`; false when the client went away.
  bool serve(int fd) {
    std::uint8_t query[MODBUS_TCP_MAX_ADU_LENGTH];
    modbus_set_socket(ctx_, fd);
    const int rc = modbus_receive(ctx_, query);
    if (rc < 0) return false;
    if (rc == 0) return true;
    // libmodbus writes its reply to the context's socket: reply into a socket pair first, so a
    // fault can be applied to the exact bytes a real board would have sent.
    int pair[2];
    if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, pair) != 0) return false;
    modbus_set_socket(ctx_, pair[0]);
    int replied = 0;
    {
      std::lock_guard<std::mutex> lock(mapping_mutex_);
      replied = modbus_reply(ctx_, query, rc, mapping_);
      ++served_;
    }
    std::vector<std::uint8_t> reply;
    if (replied > 0) {
      reply.resize(static_cast<std::size_t>(replied));
      const ssize_t n = ::recv(pair[1], reply.data(), reply.size(), MSG_DONTWAIT);
      reply.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
    }
    ::close(pair[0]);
    ::close(pair[1]);
    modbus_set_socket(ctx_, -1);
    // Modbus TCP has no checksum; the integrity check a client makes is that the MBAP transaction
    // identifier (bytes 0..1, Modbus Messaging on TCP/IP 3.1.3) echoes its request's.
    const std::vector<std::uint8_t> out = faults_.apply(std::move(reply), [](std::vector<std::uint8_t>& m) {
      if (m.size() > 1) m[1] = static_cast<std::uint8_t>(m[1] ^ 0x5A);
    });
    std::size_t sent = 0;
    while (sent < out.size()) {
      const ssize_t n = ::send(fd, out.data() + sent, out.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) return false;
      sent += static_cast<std::size_t>(n);
    }
    return true;
  }

  Status setRegister(bool holding, int address, std::uint16_t value) {
    std::lock_guard<std::mutex> lock(mapping_mutex_);
    const int n = holding ? mapping_->nb_registers : mapping_->nb_input_registers;
    if (address < 0 || address >= n) {
      return Error{std::string(holding ? "holding" : "input") + " register " + std::to_string(address) +
                   " outside [0, " + std::to_string(n) + ")"};
    }
    (holding ? mapping_->tab_registers : mapping_->tab_input_registers)[address] = value;
    return Status::success();
  }

  Result<std::uint16_t> holding(int address) const {
    std::lock_guard<std::mutex> lock(mapping_mutex_);
    if (address < 0 || address >= mapping_->nb_registers) {
      return Error{"holding register " + std::to_string(address) + " outside [0, " +
                   std::to_string(mapping_->nb_registers) + ")"};
    }
    return mapping_->tab_registers[address];
  }

  AuxBoardConfig config_;
  FaultInjector faults_;
  std::uint16_t port_ = 0;
  modbus_t* ctx_ = nullptr;   // device thread only (after init)
  int listen_fd_ = -1;        // device thread only
  std::vector<int> clients_;  // device thread only
  mutable std::mutex mapping_mutex_;
  modbus_mapping_t* mapping_ = nullptr;  // tables guarded by mapping_mutex_
  std::uint64_t served_ = 0;             // guarded by mapping_mutex_
  DeviceThread thread_;
};

AuxBoardMock::AuxBoardMock(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
AuxBoardMock::~AuxBoardMock() = default;

Result<std::unique_ptr<AuxBoardMock>> AuxBoardMock::create(AuxBoardConfig config) {
  auto impl = std::make_unique<Impl>(std::move(config));
  Status ok = impl->init();
  if (!ok.ok()) return ok.error();
  return std::unique_ptr<AuxBoardMock>(new AuxBoardMock(std::move(impl)));
}

std::uint16_t AuxBoardMock::port() const { return impl_->port_; }
FaultInjector& AuxBoardMock::faults() { return impl_->faults_; }
Status AuxBoardMock::setInputRegister(int address, std::uint16_t value) {
  return impl_->setRegister(false, address, value);
}
Status AuxBoardMock::setHoldingRegister(int address, std::uint16_t value) {
  return impl_->setRegister(true, address, value);
}
Result<std::uint16_t> AuxBoardMock::holdingRegister(int address) const { return impl_->holding(address); }

void AuxBoardMock::disappear() {
  impl_->thread_.call([this] { impl_->closeAll(); });
}

Status AuxBoardMock::reappear() {
  Status result;
  impl_->thread_.call([this, &result] {
    if (impl_->listen_fd_ >= 0) {
      result = Error{"aux board is already listening"};
      return;
    }
    result = impl_->listen();
  });
  return result;
}

std::uint64_t AuxBoardMock::requestsServed() const {
  std::lock_guard<std::mutex> lock(impl_->mapping_mutex_);
  return impl_->served_;
}

}  // namespace vog::mock
