#include "vog/mock/device_thread.hpp"

#include <sys/eventfd.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <future>
#include <memory>

namespace vog::mock {

DeviceThread::DeviceThread() : wake_fd_(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) {}

DeviceThread::~DeviceThread() {
  stop();
  if (wake_fd_ >= 0) ::close(wake_fd_);
}

void DeviceThread::start(Collect collect, OnReady on_ready) {
  collect_ = std::move(collect);
  on_ready_ = std::move(on_ready);
  thread_ = std::thread([this] { run(); });
}

void DeviceThread::stop() {
  if (!thread_.joinable()) return;
  stop_ = true;
  wake();
  thread_.join();
}

void DeviceThread::post(std::function<void()> work) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    work_.push_back(std::move(work));
  }
  wake();
}

void DeviceThread::call(const std::function<void()>& work) {
  if (!thread_.joinable() || onDeviceThread()) {
    work();
    return;
  }
  // The promise is shared with the posted work so it outlives a set_value() still running on the
  // device thread when this thread wakes up and returns.
  auto done = std::make_shared<std::promise<void>>();
  std::future<void> finished = done->get_future();
  post([&work, done] {
    work();
    done->set_value();
  });
  finished.wait();
}

void DeviceThread::wake() {
  const std::uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(wake_fd_, &one, sizeof(one));
}

void DeviceThread::run() {
  std::vector<pollfd> fds;
  while (!stop_) {
    fds.clear();
    fds.push_back(pollfd{wake_fd_, POLLIN, 0});
    collect_(fds);
    const int n = ::poll(fds.data(), fds.size(), 1000);
    if (n < 0 && errno != EINTR) break;
    if (fds[0].revents & POLLIN) {
      std::uint64_t count = 0;
      [[maybe_unused]] const ssize_t r = ::read(wake_fd_, &count, sizeof(count));
    }
    std::deque<std::function<void()>> work;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      work.swap(work_);
    }
    for (auto& w : work) w();
    // Work may have closed or replaced a polled descriptor: poll again rather than act on stale results.
    if (work.empty() && n > 0) on_ready_(std::vector<pollfd>(fds.begin() + 1, fds.end()));
  }
  // Run what is left so callers blocked in call() return.
  std::deque<std::function<void()>> work;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    work.swap(work_);
  }
  for (auto& w : work) w();
}

}  // namespace vog::mock
