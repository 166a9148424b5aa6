#pragma once
// Reconnect policy shared by the transports that can reopen their device (serial, TCP, CAN).

#include <chrono>
#include <string>

#include "vog/core/result.hpp"

namespace vog::io {

struct ReconnectConfig {
  // First retry delay after a failed open or a lost link; doubled (by `factor`) on each further
  // failure up to `max_delay_ms`, back to `initial_delay_ms` after a successful open.
  int initial_delay_ms = 100;
  int max_delay_ms = 5000;
  double factor = 2.0;

  // `prefix` names the config section in the error message, e.g. "dvl.serial.reconnect".
  Status validate(const std::string& prefix = "reconnect") const;
};

// Exponential backoff. Lifecycle: nextDelay() after each failure, reset() after a success.
// Invariant: initial <= returned delay <= max.
class ReconnectBackoff {
 public:
  explicit ReconnectBackoff(const ReconnectConfig& config) : config_(config) {}
  std::chrono::milliseconds nextDelay();
  void reset() { failures_ = 0; }
  int failures() const { return failures_; }

 private:
  ReconnectConfig config_;
  int failures_ = 0;
};

}  // namespace vog::io
