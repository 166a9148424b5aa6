#include "vog/io/tcp_client.hpp"

#include <chrono>
#include <string>

#include "stream_link.hpp"

namespace vog::io {

Status TcpClientConfig::validate(const std::string& prefix) const {
  std::error_code ec;
  asio::ip::make_address(address, ec);
  if (ec) return Error{prefix + ".address '" + address + "' is not a numeric IP address"};
  if (port == 0) return Error{prefix + ".port must be set (got 0)"};
  if (connect_timeout_ms < 1 || connect_timeout_ms > 600000) {
    return Error{prefix + ".connect_timeout_ms must be in [1, 600000], got " + std::to_string(connect_timeout_ms)};
  }
  if (read_chunk_bytes < 1 || read_chunk_bytes > (1u << 20)) {
    return Error{prefix + ".read_chunk_bytes must be in [1, 1048576], got " + std::to_string(read_chunk_bytes)};
  }
  return reconnect.validate(prefix + ".reconnect");
}

class TcpClient::Impl final : public detail::StreamLink<asio::ip::tcp::socket> {
 public:
  Impl(asio::io_context& io, TcpClientConfig config, StampClock clock, ByteHandler on_bytes, StateHandler on_state)
      : StreamLink(io, config.reconnect, std::move(clock), std::move(on_state), std::move(on_bytes),
                   config.read_chunk_bytes),
        config_(std::move(config)),
        connect_timer_(io) {}

  const TcpClientConfig& config() const { return config_; }

 protected:
  std::string linkName() const override { return "tcp " + endpointText(); }

  std::string readErrorText(const std::error_code& ec) const override {
    return ec == asio::error::eof ? std::string("connection closed by peer") : ec.message();
  }

  void asyncOpen(OpenDone done) override {
    clearQueue();
    const asio::ip::tcp::endpoint ep(asio::ip::make_address(config_.address), config_.port);
    const std::uint64_t gen = generation();
    auto self = std::static_pointer_cast<Impl>(shared_from_this());
    connect_timer_.expires_after(std::chrono::milliseconds(config_.connect_timeout_ms));
    connect_timer_.async_wait([self, gen](const std::error_code& ec) {
      if (!ec && self->isCurrent(gen)) {
        std::error_code ignored;
        self->stream_.close(ignored);  // completes the connect with operation_aborted
        self->timed_out_ = true;
      }
    });
    timed_out_ = false;
    stream_.async_connect(ep, [self, gen, done = std::move(done)](const std::error_code& ec) {
      if (!self->isCurrent(gen)) return;
      self->connect_timer_.cancel();
      if (ec) {
        done(Error{"tcp connect " + self->endpointText() + ": " +
                   (self->timed_out_ ? std::string("timed out") : ec.message())});
        return;
      }
      std::error_code ignored;
      self->stream_.set_option(asio::ip::tcp::no_delay(true), ignored);
      done(Status::success());
    });
  }

  void closeLink() override {
    std::error_code ignored;
    connect_timer_.cancel();
    stream_.close(ignored);
  }

 private:
  std::string endpointText() const { return config_.address + ":" + std::to_string(config_.port); }

  TcpClientConfig config_;
  asio::steady_timer connect_timer_;
  bool timed_out_ = false;
};

TcpClient::TcpClient(asio::io_context& io, TcpClientConfig config, StampClock clock, ByteHandler on_bytes,
                     StateHandler on_state)
    : impl_(std::make_shared<Impl>(io, std::move(config), std::move(clock), std::move(on_bytes), std::move(on_state))) {
}

TcpClient::~TcpClient() { impl_->stop(/*notify=*/false); }

Status TcpClient::start() {
  Status valid = impl_->config().validate();
  if (!valid.ok()) return valid;
  impl_->start();
  return Status::success();
}

void TcpClient::stop() { impl_->stop(); }
Status TcpClient::write(std::span<const std::uint8_t> bytes) { return impl_->write(bytes); }
const DeviceHealth& TcpClient::health() const { return impl_->health(); }

}  // namespace vog::io
