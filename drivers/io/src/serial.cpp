#include "vog/io/serial.hpp"

#include <fcntl.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <deque>
#include <vector>

#include "supervisor.hpp"

namespace vog::io {
namespace {

// Rates termios can express (Bxxx constants); others cannot be set on Linux without BOTHER.
constexpr std::array<unsigned, 18> kStandardBauds = {300,    600,    1200,   2400,   4800,   9600,
                                                      19200,  38400,  57600,  115200, 230400, 460800,
                                                      500000, 576000, 921600, 1000000, 1500000, 2000000};

std::string errnoText(const std::string& what) { return what + ": " + std::strerror(errno); }

}  // namespace

Status SerialConfig::validate(const std::string& prefix) const {
  if (device_path.empty()) return Error{prefix + ".device_path is empty"};
  bool standard = false;
  for (unsigned b : kStandardBauds) standard = standard || b == baud;
  if (!standard) return Error{prefix + ".baud " + std::to_string(baud) + " is not a standard termios rate"};
  if (data_bits < 5 || data_bits > 8) {
    return Error{prefix + ".data_bits must be 5..8, got " + std::to_string(data_bits)};
  }
  if (stop_bits != 1 && stop_bits != 2) {
    return Error{prefix + ".stop_bits must be 1 or 2, got " + std::to_string(stop_bits)};
  }
  if (read_chunk_bytes < 1 || read_chunk_bytes > (1u << 20)) {
    return Error{prefix + ".read_chunk_bytes must be in [1, 1048576], got " + std::to_string(read_chunk_bytes)};
  }
  return reconnect.validate(prefix + ".reconnect");
}

class SerialTransport::Impl final : public detail::Supervisor {
 public:
  Impl(asio::io_context& io, SerialConfig config, StampClock clock, ByteHandler on_bytes, StateHandler on_state)
      : Supervisor(io, config.reconnect, std::move(clock), std::move(on_state)),
        config_(std::move(config)),
        on_bytes_(std::move(on_bytes)),
        port_(io),
        buffer_(config_.read_chunk_bytes) {}

  const SerialConfig& config() const { return config_; }

  Status write(std::span<const std::uint8_t> bytes) {
    if (!connected()) return Error{"serial " + config_.device_path + ": not connected (" + health().reason + ")"};
    queue_.emplace_back(bytes.begin(), bytes.end());
    if (queue_.size() == 1) writeNext(generation());
    return Status::success();
  }

 protected:
  void asyncOpen(OpenDone done) override {
    queue_.clear();
    done(open());
  }

  void onOpened() override { readNext(generation()); }

  void closeLink() override {
    std::error_code ignored;
    port_.cancel(ignored);
    port_.close(ignored);
    // queue_ is cleared on the next open, not here: a cancelled write may still hold its buffer.
  }

 private:
  Status open() {
    const std::string& path = config_.device_path;
    const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return Error{errnoText("open " + path)};
    if (!::isatty(fd)) {
      ::close(fd);
      return Error{"open " + path + ": not a terminal device"};
    }
    if (config_.exclusive && ::ioctl(fd, TIOCEXCL) != 0) {
      const std::string msg = errnoText("TIOCEXCL " + path);
      ::close(fd);
      return Error{msg};
    }
    // Raw mode (cfmakeraw: no echo, no line editing, no CR/LF translation, VMIN 1) before Asio
    // sets the line parameters, so no byte is ever altered by the line discipline.
    termios tio{};
    if (::tcgetattr(fd, &tio) != 0) {
      const std::string msg = errnoText("tcgetattr " + path);
      ::close(fd);
      return Error{msg};
    }
    ::cfmakeraw(&tio);
    tio.c_cflag |= CLOCAL | CREAD;
    if (::tcsetattr(fd, TCSANOW, &tio) != 0) {
      const std::string msg = errnoText("tcsetattr " + path);
      ::close(fd);
      return Error{msg};
    }
    std::error_code ec;
    port_.assign(fd, ec);
    if (ec) {
      ::close(fd);
      return Error{"assign " + path + ": " + ec.message()};
    }
    using SP = asio::serial_port_base;
    const SP::parity::type parity = config_.parity == Parity::kNone  ? SP::parity::none
                                    : config_.parity == Parity::kOdd ? SP::parity::odd
                                                                     : SP::parity::even;
    const char* option = "baud rate";
    port_.set_option(SP::baud_rate(config_.baud), ec);
    if (!ec) option = "parity", port_.set_option(SP::parity(parity), ec);
    if (!ec) option = "data bits", port_.set_option(SP::character_size(static_cast<unsigned>(config_.data_bits)), ec);
    if (!ec) {
      option = "stop bits";
      port_.set_option(SP::stop_bits(config_.stop_bits == 1 ? SP::stop_bits::one : SP::stop_bits::two), ec);
    }
    if (!ec) option = "flow control", port_.set_option(SP::flow_control(SP::flow_control::none), ec);
    if (ec) return Error{"configure " + path + " " + option + ": " + ec.message()};
    // tcsetattr succeeds when any one of the requested changes was made (POSIX), so read the
    // settings back: a driver that silently kept other framing must not look connected.
    return verifyLine(fd);
  }

  Status verifyLine(int fd) {
    termios got{};
    if (::tcgetattr(fd, &got) != 0) return Error{errnoText("tcgetattr " + config_.device_path)};
    const std::string where = "configure " + config_.device_path + ": the driver did not apply ";
    const tcflag_t sizes[] = {CS5, CS6, CS7, CS8};
    if ((got.c_cflag & CSIZE) != sizes[config_.data_bits - 5]) {
      return Error{where + "data bits " + std::to_string(config_.data_bits)};
    }
    const bool want_parity = config_.parity != Parity::kNone;
    if (((got.c_cflag & PARENB) != 0) != want_parity ||
        (want_parity && ((got.c_cflag & PARODD) != 0) != (config_.parity == Parity::kOdd))) {
      return Error{where + "parity " + (config_.parity == Parity::kNone  ? "none"
                                        : config_.parity == Parity::kOdd ? "odd"
                                                                         : "even")};
    }
    if (((got.c_cflag & CSTOPB) != 0) != (config_.stop_bits == 2)) {
      return Error{where + "stop bits " + std::to_string(config_.stop_bits)};
    }
    if (got.c_lflag & (ICANON | ECHO | ISIG)) return Error{where + "raw mode"};
    ::tcflush(fd, TCIOFLUSH);  // drop bytes of a previous connection at another line setting
    return Status::success();
  }

  void readNext(std::uint64_t gen) {
    port_.async_read_some(asio::buffer(buffer_), [self = selfPtr(), gen](const std::error_code& ec, std::size_t n) {
      if (!self->isCurrent(gen)) return;
      if (ec) {
        // EOF or EIO: the other end of the line went away (pty master closed, adapter unplugged).
        self->linkLost("serial " + self->config_.device_path + " read: " + ec.message());
        return;
      }
      const std::int64_t stamp_ns = self->now_ns();
      self->noteRx(n, 0, stamp_ns);
      if (self->on_bytes_) self->on_bytes_(std::span<const std::uint8_t>(self->buffer_.data(), n), stamp_ns);
      if (self->isCurrent(gen)) self->readNext(gen);
    });
  }

  void writeNext(std::uint64_t gen) {
    asio::async_write(port_, asio::buffer(queue_.front()), [self = selfPtr(), gen](const std::error_code& ec, std::size_t n) {
      if (!self->isCurrent(gen)) return;
      if (ec) {
        self->linkLost("serial " + self->config_.device_path + " write: " + ec.message());
        return;
      }
      self->noteTx(n, 0);
      self->queue_.pop_front();
      if (!self->queue_.empty()) self->writeNext(gen);
    });
  }

  std::shared_ptr<Impl> selfPtr() { return std::static_pointer_cast<Impl>(shared_from_this()); }

  SerialConfig config_;
  ByteHandler on_bytes_;
  asio::serial_port port_;
  std::vector<std::uint8_t> buffer_;
  std::deque<std::vector<std::uint8_t>> queue_;
};

SerialTransport::SerialTransport(asio::io_context& io, SerialConfig config, StampClock clock, ByteHandler on_bytes,
                                 StateHandler on_state)
    : impl_(std::make_shared<Impl>(io, std::move(config), std::move(clock), std::move(on_bytes),
                                   std::move(on_state))) {}

SerialTransport::~SerialTransport() { impl_->stop(/*notify=*/false); }

Status SerialTransport::start() {
  Status valid = impl_->config().validate();
  if (!valid.ok()) return valid;
  impl_->start();
  return Status::success();
}

void SerialTransport::stop() { impl_->stop(); }

Status SerialTransport::write(std::span<const std::uint8_t> bytes) { return impl_->write(bytes); }

const DeviceHealth& SerialTransport::health() const { return impl_->health(); }

}  // namespace vog::io
