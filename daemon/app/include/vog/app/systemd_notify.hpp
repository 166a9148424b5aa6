#pragma once
// sd_notify(3) for vogd (Type=notify): READY, WATCHDOG, STOPPING and STATUS messages to the service
// manager. Outside systemd (no NOTIFY_SOCKET) every call does nothing.

#include <chrono>
#include <optional>
#include <string_view>

namespace vog::app {

class SystemdNotifier {
 public:
  SystemdNotifier();
  bool enabled() const { return enabled_; }
  // WatchdogSec of the unit when the watchdog is on for this process (sd_watchdog_enabled).
  std::optional<std::chrono::microseconds> watchdogInterval() const { return watchdog_; }
  void ready(std::string_view status) const;
  void watchdog() const;
  void stopping() const;
  void status(std::string_view status) const;

 private:
  void send(const std::string& message) const;
  bool enabled_ = false;
  std::optional<std::chrono::microseconds> watchdog_;
};

}  // namespace vog::app
