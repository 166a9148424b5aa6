#pragma once
// Watchdog: whether every one of vogd's threads is alive. Each thread bumps a counter as it goes
// round its loop (its heartbeat); a counter that has not changed for longer than the stall limit
// marks its thread as stuck. While one is, vogd stops pinging systemd (WATCHDOG=1), which restarts
// the daemon, and the mission resumes from its folder.
//
// Lifecycle: add() the threads, then check() from one thread (the main thread), with the time it
// reads: the watchdog has no clock of its own. Not thread-safe; the heartbeats it reads are.

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace vog::app {

class Watchdog {
 public:
  using Clock = std::chrono::steady_clock;
  explicit Watchdog(Clock::duration stall_limit) : stall_limit_(stall_limit) {}

  // Watches a heartbeat from `now` on.
  void add(std::string name, std::function<std::uint64_t()> heartbeat, Clock::time_point now);

  struct Check {
    bool alive = true;                       // every heartbeat changed within the stall limit
    std::vector<std::string> newly_stalled;  // "name (N s)" of threads found stuck at this check
  };
  // Reads every heartbeat at `now`. A stuck thread is reported once, and again after it has beaten
  // and stalled anew.
  Check check(Clock::time_point now);

 private:
  struct Beat {
    std::string name;
    std::function<std::uint64_t()> read;
    std::uint64_t last = 0;
    Clock::time_point changed;
    bool reported = false;
  };
  Clock::duration stall_limit_;
  std::vector<Beat> beats_;
};

}  // namespace vog::app
