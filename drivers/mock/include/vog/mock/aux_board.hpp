#pragma once
// The vehicle's auxiliary board (leak sensors, battery, payload power) as a libmodbus TCP server on
// 127.0.0.1: a real Modbus TCP peer for ModbusClient (PROTOCOLS.md "Modbus").

#include <cstdint>
#include <memory>
#include <string>

#include "vog/core/result.hpp"
#include "vog/mock/device_thread.hpp"
#include "vog/mock/faults.hpp"

namespace vog::mock {

struct AuxBoardConfig {
  std::string address = "127.0.0.1";
  std::uint16_t port = 0;  // 0 = any free port, see AuxBoardMock::port()
  int holding_registers = 64;
  int input_registers = 64;
  std::uint64_t seed = 1;  // garbage fault content
};

// Lifecycle: create() listens and starts the device thread; registers are set/read from any
// thread; disappear() closes the listener and every connection, reappear() listens again on the
// same port; destruction stops everything. Faults apply per reply: kDropout = no reply,
// kTruncate = half a reply, kGarbage = noise before the reply, kBadChecksum = a corrupted MBAP
// transaction identifier (Modbus TCP has no checksum; the echoed identifier is what a client checks).
// Invariant: register tables are only touched under the mapping mutex.
class AuxBoardMock {
 public:
  static Result<std::unique_ptr<AuxBoardMock>> create(AuxBoardConfig config = {});
  ~AuxBoardMock();
  AuxBoardMock(const AuxBoardMock&) = delete;
  AuxBoardMock& operator=(const AuxBoardMock&) = delete;

  std::uint16_t port() const;
  Status setInputRegister(int address, std::uint16_t value);
  Status setHoldingRegister(int address, std::uint16_t value);
  Result<std::uint16_t> holdingRegister(int address) const;
  FaultInjector& faults();
  void disappear();
  Status reappear();
  std::uint64_t requestsServed() const;

  class Impl;

 private:
  explicit AuxBoardMock(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace vog::mock
