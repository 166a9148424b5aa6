#include "vog/mock/pty_device.hpp"

#include <fcntl.h>
#include <pty.h>
#include <sys/ioctl.h>
#include <unistd.h>

namespace vog::mock {

PtyDevice::PtyDevice(std::filesystem::path link_path, HostBytesHandler on_host)
    : link_path_(std::move(link_path)), on_host_(std::move(on_host)) {}

Result<std::unique_ptr<PtyDevice>> PtyDevice::create(std::filesystem::path link_path, HostBytesHandler on_host) {
  std::unique_ptr<PtyDevice> dev(new PtyDevice(std::move(link_path), std::move(on_host)));
  Status opened = dev->openPty();
  if (!opened.ok()) return opened.error();
  PtyDevice* raw = dev.get();
  dev->thread_.start(
      [raw](std::vector<pollfd>& fds) {
        if (raw->master_fd_ < 0) return;
        short events = POLLIN;
        {
          std::lock_guard<std::mutex> lock(raw->mutex_);
          if (!raw->pending_.empty()) events |= POLLOUT;
        }
        fds.push_back(pollfd{raw->master_fd_, events, 0});
      },
      [raw](const std::vector<pollfd>& fds) { raw->onReady(fds); });
  return dev;
}

PtyDevice::~PtyDevice() {
  thread_.stop();
  closePty();
}

Status PtyDevice::openPty() {
  termios raw_mode{};
  ::cfmakeraw(&raw_mode);
  // A real device's line starts raw too; the host sets its own settings when it opens the port.
  if (::openpty(&master_fd_, &slave_fd_, nullptr, &raw_mode, nullptr) != 0) {
    master_fd_ = slave_fd_ = -1;
    return Error{errnoText("openpty")};
  }
  ::fcntl(master_fd_, F_SETFL, ::fcntl(master_fd_, F_GETFL) | O_NONBLOCK);
  ::fcntl(master_fd_, F_SETFD, FD_CLOEXEC);
  ::fcntl(slave_fd_, F_SETFD, FD_CLOEXEC);
  const char* slave_name = ::ttyname(slave_fd_);
  if (slave_name == nullptr) {
    const std::string msg = errnoText("ttyname");
    closePty();
    return Error{msg};
  }
  // Replace the link atomically (symlink to a temporary name, then rename over the link), so the
  // host never sees a half-made link.
  const std::filesystem::path tmp = link_path_.string() + ".new";
  std::error_code ec;
  std::filesystem::remove(tmp, ec);
  std::filesystem::create_symlink(slave_name, tmp, ec);
  if (!ec) std::filesystem::rename(tmp, link_path_, ec);
  if (ec) {
    closePty();
    return Error{"link " + link_path_.string() + " -> " + slave_name + ": " + ec.message()};
  }
  std::lock_guard<std::mutex> lock(mutex_);
  plugged_ = true;
  return Status::success();
}

void PtyDevice::closePty() {
  std::error_code ec;
  std::filesystem::remove(link_path_, ec);
  if (master_fd_ >= 0) ::close(master_fd_);
  if (slave_fd_ >= 0) ::close(slave_fd_);
  master_fd_ = slave_fd_ = -1;
  std::lock_guard<std::mutex> lock(mutex_);
  plugged_ = false;
  pending_.clear();
}

void PtyDevice::send(std::span<const std::uint8_t> bytes) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!plugged_) return;
    pending_.insert(pending_.end(), bytes.begin(), bytes.end());
  }
  thread_.post([this] { flush(); });
}

Status PtyDevice::unplug() {
  thread_.call([this] { closePty(); });
  return Status::success();
}

Status PtyDevice::replug() {
  Status result;
  thread_.call([this, &result] {
    if (master_fd_ >= 0) {
      result = Error{"replug: " + link_path_.string() + " is still plugged"};
      return;
    }
    result = openPty();
  });
  return result;
}

bool PtyDevice::plugged() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return plugged_;
}

Result<termios> PtyDevice::lineSettings() {
  Result<termios> result = Error{"unplugged"};
  thread_.call([this, &result] {
    if (slave_fd_ < 0) return;
    termios tio{};
    if (::tcgetattr(slave_fd_, &tio) != 0) {
      result = Error{errnoText("tcgetattr")};
      return;
    }
    result = tio;
  });
  return result;
}

Result<bool> PtyDevice::exclusive() {
  Result<bool> result = Error{"unplugged"};
  thread_.call([this, &result] {
    if (slave_fd_ < 0) return;
    int excl = 0;
    if (::ioctl(slave_fd_, TIOCGEXCL, &excl) != 0) {
      result = Error{errnoText("TIOCGEXCL")};
      return;
    }
    result = excl != 0;
  });
  return result;
}

std::uint64_t PtyDevice::bytesSent() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return bytes_sent_;
}

std::size_t PtyDevice::bytesQueued() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return pending_.size();
}

std::vector<std::uint8_t> PtyDevice::hostBytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return host_bytes_;
}

void PtyDevice::flush() {
  if (master_fd_ < 0) return;
  std::lock_guard<std::mutex> lock(mutex_);
  while (!pending_.empty()) {
    const ssize_t n = ::write(master_fd_, pending_.data(), pending_.size());
    if (n <= 0) break;  // EAGAIN: the host is not reading fast enough; POLLOUT resumes
    pending_.erase(pending_.begin(), pending_.begin() + n);
    bytes_sent_ += static_cast<std::uint64_t>(n);
  }
}

void PtyDevice::onReady(const std::vector<pollfd>& fds) {
  if (fds.empty() || master_fd_ < 0 || fds[0].fd != master_fd_) return;
  if (fds[0].revents & POLLOUT) flush();
  if (fds[0].revents & POLLIN) {
    std::uint8_t buffer[4096];
    const ssize_t n = ::read(master_fd_, buffer, sizeof(buffer));
    if (n > 0) {
      const std::span<const std::uint8_t> bytes(buffer, static_cast<std::size_t>(n));
      {
        std::lock_guard<std::mutex> lock(mutex_);
        host_bytes_.insert(host_bytes_.end(), bytes.begin(), bytes.end());
      }
      if (on_host_) on_host_(bytes);
    }
  }
}

}  // namespace vog::mock
