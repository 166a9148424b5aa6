#include "vog/io/modbus_client.hpp"

#include <modbus.h>

#include <asio/ip/address.hpp>
#include <cerrno>

namespace vog::io {

struct ModbusClient::Context {
  explicit Context(modbus_t* c) : ctx(c) {}
  ~Context() {
    modbus_close(ctx);
    modbus_free(ctx);
  }
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
  modbus_t* ctx;
};

Status ModbusConfig::validate(const std::string& prefix) const {
  if (tcp_address.empty() == rtu_device.empty()) {
    return Error{prefix + ": set exactly one of 'tcp_address' and 'rtu_device' (got tcp_address='" + tcp_address +
                 "', rtu_device='" + rtu_device + "')"};
  }
  if (!tcp_address.empty()) {
    std::error_code ec;
    asio::ip::make_address(tcp_address, ec);
    if (ec) return Error{prefix + ".tcp_address '" + tcp_address + "' is not a numeric IP address"};
    if (tcp_port == 0) return Error{prefix + ".tcp_port must be set (got 0)"};
  } else {
    SerialConfig serial;
    serial.device_path = rtu_device;
    serial.baud = rtu_baud;
    serial.parity = rtu_parity;
    serial.data_bits = rtu_data_bits;
    serial.stop_bits = rtu_stop_bits;
    Status s = serial.validate(prefix + ".rtu");
    if (!s.ok()) return s;
  }
  if (slave_id < 1 || slave_id > 247)
    return Error{prefix + ".slave_id must be in [1, 247], got " + std::to_string(slave_id)};
  if (response_timeout_ms < 1 || response_timeout_ms > 60000) {
    return Error{prefix + ".response_timeout_ms must be in [1, 60000], got " + std::to_string(response_timeout_ms)};
  }
  return Status::success();
}

ModbusClient::ModbusClient(ModbusConfig config, StampClock clock)
    : config_(std::move(config)), clock_(std::move(clock)) {}

ModbusClient::~ModbusClient() = default;

std::string ModbusClient::name() const {
  return config_.tcp_address.empty() ? "modbus rtu " + config_.rtu_device
                                     : "modbus tcp " + config_.tcp_address + ":" + std::to_string(config_.tcp_port);
}

Status ModbusClient::connect() {
  if (ctx_) return Status::success();
  Status valid = config_.validate();
  if (!valid.ok()) return valid;
  health_.state = LinkState::kConnecting;
  modbus_t* raw = nullptr;
  if (!config_.tcp_address.empty()) {
    raw = modbus_new_tcp(config_.tcp_address.c_str(), config_.tcp_port);
  } else {
    const char parity = config_.rtu_parity == Parity::kNone ? 'N' : config_.rtu_parity == Parity::kOdd ? 'O' : 'E';
    raw = modbus_new_rtu(config_.rtu_device.c_str(), static_cast<int>(config_.rtu_baud), parity, config_.rtu_data_bits,
                         config_.rtu_stop_bits);
  }
  if (raw == nullptr) {
    linkFailed("create context: " + std::string(modbus_strerror(errno)));
    return Error{health_.reason};
  }
  auto ctx = std::make_unique<Context>(raw);
  const auto timeout_ms = static_cast<std::uint32_t>(config_.response_timeout_ms);
  if (modbus_set_slave(raw, config_.slave_id) != 0 ||
      modbus_set_response_timeout(raw, timeout_ms / 1000, (timeout_ms % 1000) * 1000) != 0) {
    linkFailed("configure: " + std::string(modbus_strerror(errno)));
    return Error{health_.reason};
  }
  if (modbus_connect(raw) != 0) {
    linkFailed("connect: " + std::string(modbus_strerror(errno)));
    return Error{health_.reason};
  }
  ctx_ = std::move(ctx);
  ++health_.connects;
  health_.state = LinkState::kConnected;
  health_.reason = "connected";
  return Status::success();
}

void ModbusClient::close() {
  ctx_.reset();
  health_.state = LinkState::kDisconnected;
  health_.reason = "closed";
}

void ModbusClient::linkFailed(const std::string& what) {
  ctx_.reset();
  ++health_.errors;
  health_.state = LinkState::kDisconnected;
  health_.reason = health_.last_error = name() + " " + what;
}

Result<std::vector<std::uint16_t>> ModbusClient::readHoldingRegisters(int address, int count) {
  return read(Table::kHolding, address, count);
}

Result<std::vector<std::uint16_t>> ModbusClient::readInputRegisters(int address, int count) {
  return read(Table::kInput, address, count);
}

namespace {
// libmodbus reports a Modbus exception reply as errno = MODBUS_ENOBASE + exception code (1..11);
// those leave the link usable. Everything else (timeout, reset, bad CRC) drops the connection.
bool isExceptionReply(int err) { return err > MODBUS_ENOBASE && err <= MODBUS_ENOBASE + 11; }
}  // namespace

Result<std::vector<std::uint16_t>> ModbusClient::read(Table table, int address, int count) {
  const char* table_name = table == Table::kHolding ? "holding" : "input";
  if (count < 1 || count > MODBUS_MAX_READ_REGISTERS) {
    return Error{name() + ": read " + table_name + " registers: count " + std::to_string(count) + " outside [1, 125]"};
  }
  if (address < 0 || address + count > 65536) {
    return Error{name() + ": read " + table_name + " registers: address " + std::to_string(address) + " + count " +
                 std::to_string(count) + " outside [0, 65536]"};
  }
  Status connected = connect();
  if (!connected.ok()) return connected.error();
  std::vector<std::uint16_t> registers(static_cast<std::size_t>(count));
  const int n = table == Table::kHolding ? modbus_read_registers(ctx_->ctx, address, count, registers.data())
                                         : modbus_read_input_registers(ctx_->ctx, address, count, registers.data());
  if (n != count) {
    const int err = errno;
    const std::string what = std::string("read ") + table_name + " registers " + std::to_string(address) + "+" +
                             std::to_string(count) + ": " + (n < 0 ? modbus_strerror(err) : "short reply");
    if (n < 0 && isExceptionReply(err)) {
      ++health_.errors;
      health_.last_error = name() + " " + what;
      return Error{health_.last_error};
    }
    linkFailed(what);
    return Error{health_.reason};
  }
  health_.bytes_rx += static_cast<std::uint64_t>(count) * 2;
  ++health_.frames_rx;
  ++health_.frames_tx;
  health_.last_data_stamp_ns = clock_();
  return registers;
}

Status ModbusClient::writeRegister(int address, std::uint16_t value) {
  if (address < 0 || address > 65535) {
    return Error{name() + ": write register: address " + std::to_string(address) + " outside [0, 65535]"};
  }
  Status connected = connect();
  if (!connected.ok()) return connected;
  if (modbus_write_register(ctx_->ctx, address, value) != 1) {
    const int err = errno;
    const std::string what = "write register " + std::to_string(address) + ": " + modbus_strerror(err);
    if (isExceptionReply(err)) {
      ++health_.errors;
      health_.last_error = name() + " " + what;
      return Error{health_.last_error};
    }
    linkFailed(what);
    return Error{health_.reason};
  }
  health_.bytes_tx += 2;
  ++health_.frames_tx;
  ++health_.frames_rx;
  return Status::success();
}

}  // namespace vog::io
