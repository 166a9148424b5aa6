#pragma once
// Worker thread shared by the mock devices: runs a poll loop over the device's descriptors and
// executes commands posted from other threads (send, unplug, replug) on the device thread, so a
// descriptor is only ever touched by one thread.

#include <poll.h>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace vog::mock {

// Lifecycle: start(pollSet, onReady) launches the thread; post()/call() queue work for it; stop()
// (or destruction) joins it. Invariant: `collect` and `on_ready` and posted work run only on the
// device thread, never concurrently.
class DeviceThread {
 public:
  // Fills the descriptors to poll (besides the internal wake-up descriptor).
  using Collect = std::function<void(std::vector<pollfd>& fds)>;
  // Handles the poll result for the descriptors `collect` added.
  using OnReady = std::function<void(const std::vector<pollfd>& fds)>;

  DeviceThread();
  ~DeviceThread();
  DeviceThread(const DeviceThread&) = delete;
  DeviceThread& operator=(const DeviceThread&) = delete;

  void start(Collect collect, OnReady on_ready);
  void stop();
  // Runs `work` on the device thread, asynchronously.
  void post(std::function<void()> work);
  // Runs `work` on the device thread and waits for it (runs inline when called on that thread).
  void call(const std::function<void()>& work);
  bool onDeviceThread() const { return std::this_thread::get_id() == thread_.get_id(); }

 private:
  void run();
  void wake();

  int wake_fd_ = -1;  // eventfd
  Collect collect_;
  OnReady on_ready_;
  std::mutex mutex_;
  std::deque<std::function<void()>> work_;  // guarded by mutex_
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace vog::mock
