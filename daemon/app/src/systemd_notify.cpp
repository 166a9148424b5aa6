#include "vog/app/systemd_notify.hpp"

#include <systemd/sd-daemon.h>

#include <cstdint>
#include <cstdlib>
#include <string>

namespace vog::app {

SystemdNotifier::SystemdNotifier() {
  const char* socket = std::getenv("NOTIFY_SOCKET");
  enabled_ = socket != nullptr && socket[0] != '\0';
  std::uint64_t usec = 0;
  if (sd_watchdog_enabled(0, &usec) > 0 && usec > 0) watchdog_ = std::chrono::microseconds(usec);
}

void SystemdNotifier::send(const std::string& message) const {
  if (enabled_) (void)sd_notify(0, message.c_str());
}

void SystemdNotifier::ready(std::string_view status) const { send("READY=1\nSTATUS=" + std::string(status)); }
void SystemdNotifier::watchdog() const { send("WATCHDOG=1"); }
void SystemdNotifier::stopping() const { send("STOPPING=1"); }
void SystemdNotifier::status(std::string_view status) const { send("STATUS=" + std::string(status)); }

}  // namespace vog::app
