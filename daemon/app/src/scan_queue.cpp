#include "vog/app/scan_queue.hpp"

#include <utility>

namespace vog::app {

bool ScanQueue::push(QueuedScan scan) {
  std::unique_lock lock(mutex_);
  cv_.wait(lock, [&] { return queue_.size() < capacity_ || stopped_ || closed_; });
  if (stopped_ || closed_) return false;
  queue_.push_back(std::move(scan));
  ++unmapped_;
  cv_.notify_all();
  return true;
}

std::optional<QueuedScan> ScanQueue::pop(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  cv_.wait_for(lock, timeout, [&] { return !queue_.empty() || stopped_ || closed_; });
  if (stopped_ || queue_.empty()) return std::nullopt;
  QueuedScan out = std::move(queue_.front());
  queue_.pop_front();
  cv_.notify_all();
  return out;
}

void ScanQueue::done(bool mapped) {
  {
    const std::lock_guard lock(mutex_);
    --unmapped_;
    if (!mapped) ++not_mapped_;
  }
  cv_.notify_all();
}

void ScanQueue::skipped() {
  const std::lock_guard lock(mutex_);
  ++not_mapped_;
}

bool ScanQueue::waitDrained() {
  std::unique_lock lock(mutex_);
  cv_.wait(lock, [&] { return unmapped_ == 0 || stopped_; });
  return !stopped_;
}

void ScanQueue::close() {
  {
    const std::lock_guard lock(mutex_);
    closed_ = true;
  }
  cv_.notify_all();
}

void ScanQueue::stop() {
  {
    const std::lock_guard lock(mutex_);
    stopped_ = true;
  }
  cv_.notify_all();
}

bool ScanQueue::stopped() const {
  const std::lock_guard lock(mutex_);
  return stopped_;
}

bool ScanQueue::ended() const {
  const std::lock_guard lock(mutex_);
  return stopped_ || (closed_ && queue_.empty());
}

std::uint64_t ScanQueue::notMapped() const {
  const std::lock_guard lock(mutex_);
  return not_mapped_;
}

}  // namespace vog::app
