#pragma once
// Internal base of the reconnecting transports: owns the link state machine
//   disconnected --start()--> connecting --open ok--> connected --lost--> connecting (after backoff)
// and the health record. Derived classes implement how to open, read from and close the link.
//
// Lifecycle: created with std::make_shared (handlers keep it alive through shared_from_this), start(),
// then stop() before the owner goes away; after stop() no user callback is invoked again.
// Threading: every member runs on the thread that runs the io_context (no locks needed).
// Invariant: `generation_` changes on every open and close, and completion handlers of an older
// generation are ignored, so a handler of a closed link never touches the new one.

#include <asio.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "vog/core/result.hpp"
#include "vog/io/health.hpp"
#include "vog/io/reconnect.hpp"

namespace vog::io::detail {

class Supervisor : public std::enable_shared_from_this<Supervisor> {
 public:
  Supervisor(asio::io_context& io, ReconnectConfig reconnect, StampClock clock, StateHandler on_state);
  virtual ~Supervisor() = default;
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  // Opens now (the state callback may run before start() returns); retries with backoff on failure.
  void start();
  // Closes the link; reports the "stopped" state unless `notify` is false (owner being destroyed).
  void stop(bool notify = true);
  const DeviceHealth& health() const { return health_; }

 protected:
  using OpenDone = std::function<void(Status)>;
  // Opens the link; calls `done` exactly once (possibly synchronously) with the outcome.
  virtual void asyncOpen(OpenDone done) = 0;
  // Starts the read loop of a freshly opened link.
  virtual void onOpened() = 0;
  // Closes the link (cancels pending operations). Must be idempotent.
  virtual void closeLink() = 0;
  // False for links that cannot be reopened (an adopted file descriptor).
  virtual bool canReopen() const { return true; }

  // For derived classes: the link broke (EOF, hangup, I/O error). Closes it and schedules a retry.
  void linkLost(const std::string& reason);
  void noteRx(std::size_t bytes, std::uint64_t frames, std::int64_t stamp_ns);
  void noteTx(std::size_t bytes, std::uint64_t frames);
  void noteError(const std::string& what);
  bool isCurrent(std::uint64_t generation) const { return running_ && generation == generation_; }
  std::uint64_t generation() const { return generation_; }
  bool connected() const { return health_.state == LinkState::kConnected; }
  std::int64_t now_ns() const { return clock_(); }

  asio::io_context& io_;

 private:
  void attempt();
  void scheduleRetry();
  void setState(LinkState state, std::string reason);

  StampClock clock_;
  StateHandler on_state_;
  asio::steady_timer timer_;
  ReconnectBackoff backoff_;
  DeviceHealth health_;
  bool running_ = false;
  std::uint64_t generation_ = 0;
};

}  // namespace vog::io::detail
