#include "vog/app/watchdog.hpp"

#include <utility>

namespace vog::app {

void Watchdog::add(std::string name, std::function<std::uint64_t()> heartbeat, Clock::time_point now) {
  Beat b{std::move(name), std::move(heartbeat), 0, now, false};
  b.last = b.read();
  beats_.push_back(std::move(b));
}

Watchdog::Check Watchdog::check(Clock::time_point now) {
  Check out;
  for (Beat& b : beats_) {
    const std::uint64_t v = b.read();
    if (v != b.last) {
      b.last = v;
      b.changed = now;
      b.reported = false;
    } else if (now - b.changed > stall_limit_) {
      out.alive = false;
      if (!std::exchange(b.reported, true))
        out.newly_stalled.push_back(
            b.name + " (" + std::to_string(std::chrono::duration_cast<std::chrono::seconds>(now - b.changed).count()) +
            " s)");
    }
  }
  return out;
}

}  // namespace vog::app
