#include "vog/io/can.hpp"

#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <deque>

#include "supervisor.hpp"

namespace vog::io {

Status CanConfig::validate(const std::string& prefix) const {
  if (interface.empty() == unix_seqpacket.empty()) {
    return Error{prefix + ": set exactly one of 'interface' and 'unix_seqpacket' (got interface='" + interface +
                 "', unix_seqpacket='" + unix_seqpacket + "')"};
  }
  if (!interface.empty() && interface.size() >= IFNAMSIZ) {
    return Error{prefix + ".interface '" + interface + "' is longer than " + std::to_string(IFNAMSIZ - 1) +
                 " characters"};
  }
  if (!unix_seqpacket.empty() && unix_seqpacket.size() >= sizeof(sockaddr_un{}.sun_path)) {
    return Error{prefix + ".unix_seqpacket path is longer than " + std::to_string(sizeof(sockaddr_un{}.sun_path) - 1) +
                 " characters: '" + unix_seqpacket + "'"};
  }
  return reconnect.validate(prefix + ".reconnect");
}

class CanTransport::Impl final : public detail::Supervisor {
 public:
  Impl(asio::io_context& io, CanConfig config, StampClock clock, CanFrameHandler handler, StateHandler on_state,
       int adopted_fd)
      : Supervisor(io, config.reconnect, std::move(clock), std::move(on_state)),
        config_(std::move(config)),
        handler_(std::move(handler)),
        descriptor_(io),
        adopted_fd_(adopted_fd) {}

  ~Impl() override {
    if (adopted_fd_ >= 0) ::close(adopted_fd_);
  }

  Status validate() const {
    if (adopted_fd_ >= 0 || adopted_) return Status::success();
    return config_.validate();
  }

  Status write(const can_frame& frame) {
    if (frame.len > CAN_MAX_DLEN) {
      noteError("can write: frame length " + std::to_string(frame.len) + " > 8");
      return Error{"can write: frame length " + std::to_string(frame.len) + " > 8"};
    }
    if (!connected()) return Error{"can: not connected (" + health().reason + ")"};
    queue_.push_back(frame);
    if (queue_.size() == 1) waitWritable(generation());
    return Status::success();
  }

  std::uint64_t filtered() const { return filtered_; }

 protected:
  void asyncOpen(OpenDone done) override {
    int fd = -1;
    if (adopted_fd_ >= 0 || adopted_) {
      if (adopted_fd_ < 0) {
        done(Error{"can: adopted descriptor was closed and cannot be reopened"});
        return;
      }
      fd = adopted_fd_;
      adopted_fd_ = -1;
      adopted_ = true;
    } else if (!config_.interface.empty()) {
      Result<int> opened = openCanSocket();
      if (!opened.ok()) {
        done(opened.error());
        return;
      }
      fd = opened.value();
    } else {
      Result<int> opened = openUnixSeqpacket();
      if (!opened.ok()) {
        done(opened.error());
        return;
      }
      fd = opened.value();
    }
    std::error_code ec;
    descriptor_.assign(fd, ec);
    if (!ec) descriptor_.non_blocking(true, ec);
    if (ec) {
      ::close(fd);
      done(Error{"can: " + ec.message()});
      return;
    }
    done(Status::success());
  }

  void onOpened() override { waitReadable(generation()); }

  void closeLink() override {
    std::error_code ignored;
    descriptor_.close(ignored);
    queue_.clear();
  }

  bool canReopen() const override { return !adopted_; }

 private:
  Result<int> openCanSocket() {
    const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
    if (fd < 0) return Error{errnoText("can socket(PF_CAN) for " + config_.interface)};
    if (!config_.filters.empty()) {
      std::vector<can_filter> filters;
      for (const CanFilter& f : config_.filters) filters.push_back(can_filter{f.id, f.mask});
      if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters.data(),
                       static_cast<socklen_t>(filters.size() * sizeof(can_filter))) != 0) {
        const std::string msg = errnoText("can setsockopt(CAN_RAW_FILTER) on " + config_.interface);
        ::close(fd);
        return Error{msg};
      }
    }
    const unsigned index = ::if_nametoindex(config_.interface.c_str());
    if (index == 0) {
      const std::string msg = errnoText("can interface " + config_.interface);
      ::close(fd);
      return Error{msg};
    }
    sockaddr_can addr{};
    addr.can_family = AF_CAN;
    addr.can_ifindex = static_cast<int>(index);
    if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
      const std::string msg = errnoText("can bind " + config_.interface);
      ::close(fd);
      return Error{msg};
    }
    return fd;
  }

  Result<int> openUnixSeqpacket() {
    const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
    if (fd < 0) return Error{errnoText("can socket(AF_UNIX, SOCK_SEQPACKET)")};
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::memcpy(addr.sun_path, config_.unix_seqpacket.c_str(), config_.unix_seqpacket.size() + 1);
    if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
      const std::string msg = errnoText("can connect " + config_.unix_seqpacket);
      ::close(fd);
      return Error{msg};
    }
    return fd;
  }

  void waitReadable(std::uint64_t gen) {
    descriptor_.async_wait(asio::posix::descriptor_base::wait_read,
                           [self = std::static_pointer_cast<Impl>(shared_from_this()), gen](const std::error_code& ec) {
                             if (!self->isCurrent(gen)) return;
                             if (ec) {
                               self->linkLost("can wait: " + ec.message());
                               return;
                             }
                             self->drain(gen);
                           });
  }

  // One read() returns exactly one record on both a CAN raw socket and a SOCK_SEQPACKET socket.
  void drain(std::uint64_t gen) {
    for (;;) {
      // Larger than a CAN FD frame (72 bytes) so an oversized record is seen as such, not cut to 16.
      alignas(can_frame) unsigned char record[128];
      const ssize_t n = ::read(descriptor_.native_handle(), record, sizeof(record));
      if (n < 0) {
        if (errno == EAGAIN || errno == EWOULDBLOCK) break;
        if (errno == EINTR) continue;
        linkLost(errnoText("can read"));
        return;
      }
      if (n == 0) {
        linkLost("can read: peer closed the socket");
        return;
      }
      const std::int64_t stamp_ns = now_ns();
      if (static_cast<std::size_t>(n) != sizeof(can_frame)) {
        noteError("can record of " + std::to_string(n) + " bytes, expected " + std::to_string(sizeof(can_frame)));
        continue;
      }
      can_frame frame{};
      std::memcpy(&frame, record, sizeof(frame));
      if (frame.len > CAN_MAX_DLEN) {
        noteError("can frame length " + std::to_string(frame.len) + " > 8");
        continue;
      }
      if ((frame.can_id & CAN_ERR_FLAG) != 0) {
        noteError("can error frame, class 0x" + std::to_string(frame.can_id & CAN_ERR_MASK));
        continue;
      }
      noteRx(sizeof(frame), 1, stamp_ns);
      if (!passes(frame.can_id)) {
        ++filtered_;
        continue;
      }
      if (handler_) handler_(frame, stamp_ns);
      if (!isCurrent(gen)) return;
    }
    waitReadable(gen);
  }

  bool passes(std::uint32_t can_id) const {
    if (config_.filters.empty()) return true;
    for (const CanFilter& f : config_.filters) {
      if (f.matches(can_id)) return true;
    }
    return false;
  }

  void waitWritable(std::uint64_t gen) {
    descriptor_.async_wait(asio::posix::descriptor_base::wait_write,
                           [self = std::static_pointer_cast<Impl>(shared_from_this()), gen](const std::error_code& ec) {
                             if (!self->isCurrent(gen)) return;
                             if (ec) {
                               self->linkLost("can wait: " + ec.message());
                               return;
                             }
                             self->flush(gen);
                           });
  }

  void flush(std::uint64_t gen) {
    while (!queue_.empty()) {
      const ssize_t n = ::write(descriptor_.native_handle(), &queue_.front(), sizeof(can_frame));
      if (n < 0) {
        if (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS) break;  // tx queue full: wait
        if (errno == EINTR) continue;
        linkLost(errnoText("can write"));
        return;
      }
      noteTx(static_cast<std::size_t>(n), 1);
      queue_.pop_front();
    }
    if (!queue_.empty()) waitWritable(gen);
  }

  CanConfig config_;
  CanFrameHandler handler_;
  asio::posix::stream_descriptor descriptor_;
  int adopted_fd_ = -1;  // owned until the first open hands it to descriptor_
  bool adopted_ = false;
  std::uint64_t filtered_ = 0;
  std::deque<can_frame> queue_;
};

CanTransport::CanTransport(asio::io_context& io, CanConfig config, StampClock clock, CanFrameHandler on_frame,
                           StateHandler on_state)
    : impl_(std::make_shared<Impl>(io, std::move(config), std::move(clock), std::move(on_frame), std::move(on_state),
                                   -1)) {}

CanTransport::CanTransport(std::shared_ptr<Impl> impl) : impl_(std::move(impl)) {}

std::unique_ptr<CanTransport> CanTransport::adopt(asio::io_context& io, int fd, std::vector<CanFilter> filters,
                                                  StampClock clock, CanFrameHandler on_frame, StateHandler on_state) {
  CanConfig config;
  config.filters = std::move(filters);
  return std::unique_ptr<CanTransport>(new CanTransport(
      std::make_shared<Impl>(io, std::move(config), std::move(clock), std::move(on_frame), std::move(on_state), fd)));
}

CanTransport::~CanTransport() { impl_->stop(/*notify=*/false); }

Status CanTransport::start() {
  Status valid = impl_->validate();
  if (!valid.ok()) return valid;
  impl_->start();
  return Status::success();
}

void CanTransport::stop() { impl_->stop(); }
Status CanTransport::write(const can_frame& frame) { return impl_->write(frame); }
const DeviceHealth& CanTransport::health() const { return impl_->health(); }
std::uint64_t CanTransport::framesFiltered() const { return impl_->filtered(); }

}  // namespace vog::io
