#pragma once
// Modbus RTU/TCP client through libmodbus 3.1.6 (PROTOCOLS.md "Modbus"): the vehicle's auxiliary
// board (leak sensors, battery, payload power) and Modbus pressure transducers.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "vog/core/result.hpp"
#include "vog/io/health.hpp"
#include "vog/io/serial.hpp"

namespace vog::io {

// Exactly one of `tcp_address` and `rtu_device` is set.
struct ModbusConfig {
  std::string tcp_address;       // numeric address of a Modbus TCP server
  std::uint16_t tcp_port = 502;  // Modbus TCP standard port
  std::string rtu_device;        // serial device of a Modbus RTU bus
  unsigned rtu_baud = 19200;     // Modbus over serial line spec default: 19200, even parity
  Parity rtu_parity = Parity::kEven;
  int rtu_data_bits = 8;
  int rtu_stop_bits = 1;
  int slave_id = 1;  // unit identifier, 1..247
  int response_timeout_ms = 500;

  Status validate(const std::string& prefix = "modbus") const;
};

// Blocking client. Lifecycle: construct; every read/write connects first if needed; an I/O error
// closes the connection (health disconnected with the reason) and the next call reconnects.
// A Modbus exception reply (illegal address...) is an error of that request only; the link stays up.
// Threading: blocking calls, one thread at a time (run it off the io_context thread).
// Invariant: a successful read returns exactly `count` registers.
class ModbusClient {
 public:
  explicit ModbusClient(ModbusConfig config, StampClock clock = steadyStampClock());
  ~ModbusClient();
  ModbusClient(const ModbusClient&) = delete;
  ModbusClient& operator=(const ModbusClient&) = delete;

  Status connect();
  void close();
  // `count` in [1, 125] (Modbus limit per read), `address` in [0, 65535 - count + 1].
  Result<std::vector<std::uint16_t>> readHoldingRegisters(int address, int count);
  Result<std::vector<std::uint16_t>> readInputRegisters(int address, int count);
  Status writeRegister(int address, std::uint16_t value);
  const DeviceHealth& health() const { return health_; }

 private:
  enum class Table { kHolding, kInput };
  Result<std::vector<std::uint16_t>> read(Table table, int address, int count);
  void linkFailed(const std::string& what);
  std::string name() const;

  ModbusConfig config_;
  StampClock clock_;
  struct Context;
  std::unique_ptr<Context> ctx_;  // null while disconnected
  DeviceHealth health_;
};

}  // namespace vog::io
