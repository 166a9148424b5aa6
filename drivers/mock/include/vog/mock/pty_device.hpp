#pragma once
// A serial device emulated on a pseudo-terminal (openpty). The host side (the daemon's serial
// transport) opens `linkPath()`, a symlink to the current slave /dev/pts/N, exactly as it would
// open /dev/serial/by-id/... for a USB adapter. Unplugging closes the pty and removes the link;
// replugging creates a new pty and points the link at it, like a re-enumerated adapter.

#include <termios.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "vog/core/result.hpp"
#include "vog/mock/device_thread.hpp"

namespace vog::mock {

// Lifecycle: create() opens the pty, makes the link and starts the device thread; send() queues
// bytes for the host; unplug()/replug() on command; destruction stops the thread, closes the pty
// and removes the link. Threading: every public member may be called from any thread.
// Invariants: the mock keeps its own slave descriptor open while plugged, so the line settings
// the host applied stay observable (lineSettings()) and the master never sees a hangup; bytes
// queued while unplugged are dropped (a cable that is out carries nothing).
class PtyDevice {
 public:
  // Called on the device thread with bytes the host wrote (commands to the device).
  using HostBytesHandler = std::function<void(std::span<const std::uint8_t>)>;

  static Result<std::unique_ptr<PtyDevice>> create(std::filesystem::path link_path, HostBytesHandler on_host = {});
  ~PtyDevice();
  PtyDevice(const PtyDevice&) = delete;
  PtyDevice& operator=(const PtyDevice&) = delete;

  const std::filesystem::path& linkPath() const { return link_path_; }
  void send(std::span<const std::uint8_t> bytes);
  Status unplug();
  Status replug();
  bool plugged() const;

  // Line settings the host applied (tcgetattr on the slave) and its TIOCEXCL flag.
  Result<termios> lineSettings();
  Result<bool> exclusive();

  // Bytes written to the master so far, and bytes still queued.
  std::uint64_t bytesSent() const;
  std::size_t bytesQueued() const;
  // All bytes the host wrote since creation.
  std::vector<std::uint8_t> hostBytes() const;

 private:
  PtyDevice(std::filesystem::path link_path, HostBytesHandler on_host);
  Status openPty();  // device thread (or before it starts)
  void closePty();   // device thread
  void onReady(const std::vector<pollfd>& fds);
  void flush();

  std::filesystem::path link_path_;
  HostBytesHandler on_host_;
  int master_fd_ = -1;  // device thread only
  int slave_fd_ = -1;   // device thread only
  mutable std::mutex mutex_;
  std::vector<std::uint8_t> pending_;     // guarded by mutex_: bytes not yet written to the master
  std::vector<std::uint8_t> host_bytes_;  // guarded by mutex_
  std::uint64_t bytes_sent_ = 0;          // guarded by mutex_
  bool plugged_ = false;                  // guarded by mutex_
  DeviceThread thread_;
};

}  // namespace vog::mock
