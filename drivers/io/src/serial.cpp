#include "vog/io/serial.hpp"

#include <fcntl.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <array>

#include "stream_link.hpp"

namespace vog::io {
namespace {

// Rates termios can express (Bxxx constants); others cannot be set on Linux without BOTHER.
constexpr std::array<unsigned, 18> kStandardBauds = {300,    600,    1200,   2400,    4800,    9600,
                                                     19200,  38400,  57600,  115200,  230400,  460800,
                                                     500000, 576000, 921600, 1000000, 1500000, 2000000};

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

class SerialTransport::Impl final : public detail::StreamLink<asio::serial_port> {
 public:
  Impl(asio::io_context& io, SerialConfig config, StampClock clock, ByteHandler on_bytes, StateHandler on_state)
      : StreamLink(io, config.reconnect, std::move(clock), std::move(on_state), std::move(on_bytes),
                   config.read_chunk_bytes),
        config_(std::move(config)) {}

  const SerialConfig& config() const { return config_; }

 protected:
  std::string linkName() const override { return "serial " + config_.device_path; }

  void asyncOpen(OpenDone done) override {
    clearQueue();
    done(open());
  }

  void closeLink() override {
    std::error_code ignored;
    stream_.cancel(ignored);
    stream_.close(ignored);
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
    stream_.assign(fd, ec);
    if (ec) {
      ::close(fd);
      return Error{"assign " + path + ": " + ec.message()};
    }
    using SP = asio::serial_port_base;
    const SP::parity::type parity = config_.parity == Parity::kNone  ? SP::parity::none
                                    : config_.parity == Parity::kOdd ? SP::parity::odd
                                                                     : SP::parity::even;
    const char* option = "baud rate";
    stream_.set_option(SP::baud_rate(config_.baud), ec);
    if (!ec) option = "parity", stream_.set_option(SP::parity(parity), ec);
    if (!ec) option = "data bits", stream_.set_option(SP::character_size(static_cast<unsigned>(config_.data_bits)), ec);
    if (!ec) {
      option = "stop bits";
      stream_.set_option(SP::stop_bits(config_.stop_bits == 1 ? SP::stop_bits::one : SP::stop_bits::two), ec);
    }
    if (!ec) option = "flow control", stream_.set_option(SP::flow_control(SP::flow_control::none), ec);
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
      return Error{where + "parity " +
                   (config_.parity == Parity::kNone  ? "none"
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

  SerialConfig config_;
};

SerialTransport::SerialTransport(asio::io_context& io, SerialConfig config, StampClock clock, ByteHandler on_bytes,
                                 StateHandler on_state)
    : impl_(std::make_shared<Impl>(io, std::move(config), std::move(clock), std::move(on_bytes), std::move(on_state))) {
}

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
