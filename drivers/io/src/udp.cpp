#include "vog/io/udp.hpp"

#include <vector>

#include "supervisor.hpp"

namespace vog::io {

Status UdpReceiverConfig::validate(const std::string& prefix) const {
  std::error_code ec;
  asio::ip::make_address(bind_address, ec);
  if (ec) return Error{prefix + ".bind_address '" + bind_address + "' is not a numeric IP address"};
  if (max_datagram_bytes < 1 || max_datagram_bytes > 65507) {
    return Error{prefix + ".max_datagram_bytes must be in [1, 65507], got " + std::to_string(max_datagram_bytes)};
  }
  if (receive_buffer_bytes < 4096) {
    return Error{prefix + ".receive_buffer_bytes must be >= 4096, got " + std::to_string(receive_buffer_bytes)};
  }
  return reconnect.validate(prefix + ".reconnect");
}

Status UdpSenderConfig::validate(const std::string& prefix) const {
  std::error_code ec;
  asio::ip::make_address(address, ec);
  if (ec) return Error{prefix + ".address '" + address + "' is not a numeric IP address"};
  if (port == 0) return Error{prefix + ".port must be set (got 0)"};
  return Status::success();
}

class UdpReceiver::Impl final : public detail::Supervisor {
 public:
  Impl(asio::io_context& io, UdpReceiverConfig config, StampClock clock, DatagramHandler handler, StateHandler on_state)
      : Supervisor(io, config.reconnect, std::move(clock), std::move(on_state)),
        config_(std::move(config)),
        handler_(std::move(handler)),
        socket_(io),
        buffer_(config_.max_datagram_bytes + 1) {}

  const UdpReceiverConfig& config() const { return config_; }
  std::string senderAddress() const { return sender_.address().to_string(); }

  Status sendTo(const std::string& address, std::uint16_t port, std::span<const std::uint8_t> datagram) {
    const std::string where = "udp send to " + address + ":" + std::to_string(port);
    std::error_code ec;
    const asio::ip::address ip = asio::ip::make_address(address, ec);
    if (ec) return Error{where + ": not a numeric IP address"};
    if (!socket_.is_open()) return Error{where + ": the socket is not bound"};
    const std::size_t n =
        socket_.send_to(asio::buffer(datagram.data(), datagram.size()), asio::ip::udp::endpoint(ip, port), 0, ec);
    if (ec || n != datagram.size()) {
      noteError(where + ": " + (ec ? ec.message() : "short send"));
      return Error{where + ": " + (ec ? ec.message() : "short send")};
    }
    noteTx(n, 1);
    return Status::success();
  }
  std::uint16_t localPort() const {
    std::error_code ec;
    const auto ep = socket_.local_endpoint(ec);
    return ec ? 0 : ep.port();
  }

 protected:
  void asyncOpen(OpenDone done) override {
    const asio::ip::udp::endpoint ep(asio::ip::make_address(config_.bind_address), config_.port);
    std::error_code ec;
    socket_.open(ep.protocol(), ec);
    if (!ec) socket_.set_option(asio::socket_base::receive_buffer_size(config_.receive_buffer_bytes), ec);
    if (!ec) socket_.bind(ep, ec);
    if (ec) {
      done(Error{"udp bind " + config_.bind_address + ":" + std::to_string(config_.port) + ": " + ec.message()});
      return;
    }
    done(Status::success());
  }

  void onOpened() override { receiveNext(generation()); }

  void closeLink() override {
    std::error_code ignored;
    socket_.close(ignored);
  }

 private:
  void receiveNext(std::uint64_t gen) {
    // The buffer is one byte larger than the largest accepted datagram: a datagram that fills it
    // was truncated by the kernel and is rejected whole.
    socket_.async_receive_from(
        asio::buffer(buffer_), sender_,
        [self = std::static_pointer_cast<Impl>(shared_from_this()), gen](const std::error_code& ec, std::size_t n) {
          if (!self->isCurrent(gen)) return;
          if (ec) {
            // ICMP port-unreachable and similar are reported on the next receive; the socket is fine.
            self->noteError("udp receive: " + ec.message());
          } else if (n > self->config_.max_datagram_bytes) {
            self->noteError("udp datagram larger than " + std::to_string(self->config_.max_datagram_bytes) +
                            " bytes dropped");
          } else {
            const std::int64_t stamp_ns = self->now_ns();
            self->noteRx(n, 1, stamp_ns);
            if (self->handler_) self->handler_(std::span<const std::uint8_t>(self->buffer_.data(), n), stamp_ns);
          }
          if (self->isCurrent(gen)) self->receiveNext(gen);
        });
  }

  UdpReceiverConfig config_;
  DatagramHandler handler_;
  asio::ip::udp::socket socket_;
  asio::ip::udp::endpoint sender_;
  std::vector<std::uint8_t> buffer_;
};

UdpReceiver::UdpReceiver(asio::io_context& io, UdpReceiverConfig config, StampClock clock, DatagramHandler on_datagram,
                         StateHandler on_state)
    : impl_(std::make_shared<Impl>(io, std::move(config), std::move(clock), std::move(on_datagram),
                                   std::move(on_state))) {}

UdpReceiver::~UdpReceiver() { impl_->stop(/*notify=*/false); }

Status UdpReceiver::start() {
  Status valid = impl_->config().validate();
  if (!valid.ok()) return valid;
  impl_->start();
  return Status::success();
}

void UdpReceiver::stop() { impl_->stop(); }
std::uint16_t UdpReceiver::localPort() const { return impl_->localPort(); }
std::string UdpReceiver::senderAddress() const { return impl_->senderAddress(); }
Status UdpReceiver::sendTo(const std::string& address, std::uint16_t port, std::span<const std::uint8_t> datagram) {
  return impl_->sendTo(address, port, datagram);
}
const DeviceHealth& UdpReceiver::health() const { return impl_->health(); }

struct UdpSender::Socket {
  explicit Socket(asio::io_context& io) : socket(io) {}
  asio::ip::udp::socket socket;
  asio::ip::udp::endpoint destination;
};

UdpSender::UdpSender(asio::io_context& io, UdpSenderConfig config)
    : config_(std::move(config)), socket_(std::make_unique<Socket>(io)) {}

UdpSender::~UdpSender() = default;

Status UdpSender::open() {
  Status valid = config_.validate();
  if (!valid.ok()) return valid;
  health_.state = LinkState::kConnecting;
  socket_->destination = asio::ip::udp::endpoint(asio::ip::make_address(config_.address), config_.port);
  std::error_code ec;
  socket_->socket.open(socket_->destination.protocol(), ec);
  if (ec) {
    ++health_.errors;
    health_.state = LinkState::kDisconnected;
    health_.reason = health_.last_error = "udp open: " + ec.message();
    return Error{health_.reason};
  }
  ++health_.connects;
  health_.state = LinkState::kConnected;
  health_.reason = "open";
  return Status::success();
}

Status UdpSender::send(std::span<const std::uint8_t> datagram) {
  if (health_.state != LinkState::kConnected) return Error{"udp sender: not open"};
  std::error_code ec;
  const std::size_t n =
      socket_->socket.send_to(asio::buffer(datagram.data(), datagram.size()), socket_->destination, 0, ec);
  if (ec || n != datagram.size()) {
    ++health_.errors;
    health_.last_error = "udp send to " + config_.address + ":" + std::to_string(config_.port) + ": " +
                         (ec ? ec.message() : "short send");
    return Error{health_.last_error};
  }
  health_.bytes_tx += n;
  ++health_.frames_tx;
  return Status::success();
}

}  // namespace vog::io
