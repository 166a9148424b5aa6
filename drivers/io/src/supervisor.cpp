#include "supervisor.hpp"

#include <algorithm>
#include <cmath>

namespace vog::io {

Status ReconnectConfig::validate(const std::string& prefix) const {
  if (initial_delay_ms < 1 || initial_delay_ms > 600000) {
    return Error{prefix + ".initial_delay_ms must be in [1, 600000], got " + std::to_string(initial_delay_ms)};
  }
  if (max_delay_ms < initial_delay_ms || max_delay_ms > 600000) {
    return Error{prefix + ".max_delay_ms must be in [initial_delay_ms, 600000], got " + std::to_string(max_delay_ms)};
  }
  if (!(factor >= 1.0 && factor <= 10.0)) {
    return Error{prefix + ".factor must be in [1, 10], got " + std::to_string(factor)};
  }
  return Status::success();
}

std::chrono::milliseconds ReconnectBackoff::nextDelay() {
  double delay_ms = config_.initial_delay_ms * std::pow(config_.factor, std::min(failures_, 64));
  delay_ms = std::min(delay_ms, static_cast<double>(config_.max_delay_ms));
  ++failures_;
  return std::chrono::milliseconds(static_cast<std::int64_t>(delay_ms));
}

namespace detail {

Supervisor::Supervisor(asio::io_context& io, ReconnectConfig reconnect, StampClock clock, StateHandler on_state)
    : io_(io), clock_(std::move(clock)), on_state_(std::move(on_state)), timer_(io), backoff_(reconnect) {}

void Supervisor::start() {
  if (running_) return;
  running_ = true;
  attempt();
}

void Supervisor::stop(bool notify) {
  if (!running_) return;
  running_ = false;
  ++generation_;
  timer_.cancel();
  closeLink();
  if (!notify) on_state_ = nullptr;
  setState(LinkState::kDisconnected, "stopped");
}

void Supervisor::attempt() {
  setState(LinkState::kConnecting, health_.connects == 0 ? "opening" : "reopening");
  const std::uint64_t gen = ++generation_;
  asyncOpen([self = shared_from_this(), gen](Status status) {
    if (!self->isCurrent(gen)) return;
    if (!status.ok()) {
      self->noteError(status.error().message);
      self->closeLink();
      self->setState(LinkState::kDisconnected, status.error().message);
      self->scheduleRetry();
      return;
    }
    self->backoff_.reset();
    ++self->health_.connects;
    self->setState(LinkState::kConnected, "connected");
    self->onOpened();
  });
}

void Supervisor::linkLost(const std::string& reason) {
  if (!running_) return;
  ++generation_;
  closeLink();
  noteError(reason);
  setState(LinkState::kDisconnected, reason);
  scheduleRetry();
}

// While waiting for the next attempt the link is disconnected, with the reason of the last failure.
void Supervisor::scheduleRetry() {
  if (!canReopen()) return;
  timer_.expires_after(backoff_.nextDelay());
  const std::uint64_t gen = generation_;
  timer_.async_wait([self = shared_from_this(), gen](const std::error_code& ec) {
    if (ec || !self->isCurrent(gen)) return;
    self->attempt();
  });
}

void Supervisor::setState(LinkState state, std::string reason) {
  const bool changed = state != health_.state || reason != health_.reason;
  health_.state = state;
  health_.reason = std::move(reason);
  if (changed && on_state_) on_state_(health_);
}

void Supervisor::noteRx(std::size_t bytes, std::uint64_t frames, std::int64_t stamp_ns) {
  health_.bytes_rx += bytes;
  health_.frames_rx += frames;
  health_.last_data_stamp_ns = stamp_ns;
}

void Supervisor::noteTx(std::size_t bytes, std::uint64_t frames) {
  health_.bytes_tx += bytes;
  health_.frames_tx += frames;
}

void Supervisor::noteError(const std::string& what) {
  ++health_.errors;
  health_.last_error = what;
}

}  // namespace detail
}  // namespace vog::io
