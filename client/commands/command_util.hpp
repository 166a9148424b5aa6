#pragma once
// Pieces shared by the command implementations (not part of the public API).

#include "vog/client/vogctl.hpp"

#include <cstdint>
#include <string>

namespace vog::client::detail {

// "vogctl <command>: <message>" on err.
void report(const CommandIo& io, const std::string& command, const std::string& message);

// A transfer's progress on err: one line rewritten in place ("\r"), updated when the percentage
// changes. Shown when err is a terminal or when forced (--progress); never in the way of stdout.
// Lifecycle: construct before the transfer, call update() from the progress callback, finish()
// (ends the line) once after it.
class ProgressLine {
 public:
  ProgressLine(const CommandIo& io, bool forced, std::string what, std::string unit)
      : io_(io), enabled_(forced || io.err_is_terminal), what_(std::move(what)), unit_(std::move(unit)) {}
  void update(std::uint64_t received, std::uint64_t total);
  void finish();

 private:
  const CommandIo& io_;
  bool enabled_;
  std::string what_;
  std::string unit_;
  int last_percent_ = -1;
};

}  // namespace vog::client::detail
