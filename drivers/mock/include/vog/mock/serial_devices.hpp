#pragma once
// Serial mock devices on pseudo-terminals: the DVL (PD0 or PD6) and the Digiquartz depth sensor.
// They are fed plain domain samples and put the real wire bytes (codec encoders) on the line.

#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "vog/depth/digiquartz.hpp"
#include "vog/dvl/dvl_types.hpp"
#include "vog/dvl/pd6.hpp"
#include "vog/core/result.hpp"
#include "vog/mock/faults.hpp"
#include "vog/mock/pty_device.hpp"

namespace vog::mock {

// Lifecycle: create() opens the pty at `link_path`; send*() puts one message on the line (after
// the armed fault, if any); pty().unplug()/replug() make the device disappear and return.
// Faults: kBadChecksum adds one to the PD0 checksum (PD6 has no checksum: the status letter is
// replaced by '?', which the decoder must reject as malformed).
class DvlMock {
 public:
  static Result<std::unique_ptr<DvlMock>> create(const std::filesystem::path& link_path, std::uint64_t seed = 1);
  Status sendPd0(const dvl::DvlEnsemble& ensemble);
  void sendPd6(const dvl::Pd6Sentence& sentence);
  PtyDevice& pty() { return *pty_; }
  FaultInjector& faults() { return faults_; }

 private:
  DvlMock(std::unique_ptr<PtyDevice> pty, std::uint64_t seed) : faults_(seed), pty_(std::move(pty)) {}
  FaultInjector faults_;
  std::unique_ptr<PtyDevice> pty_;  // last: destroyed first, so its device thread stops before the rest goes
};

// Paroscientific Digiquartz (PROTOCOLS.md): answers `*0100P3` with one pressure reply, starts
// continuous output on `*0100P4` (each setPressure() then sends a reply), answers `*0100UN` with
// the units code. Replies are `*0001` + value in the current units + CR LF.
// Faults apply to pressure replies; kBadChecksum (the protocol has none) puts a letter into the
// number, which the decoder must reject.
// Threading: setPressure() from any thread; commands are answered on the device thread.
// Invariant: replies carry the newest pressure given, in the configured units; a poll before the
// first reading is answered with that reading when it comes (never with a pressure nobody gave).
class DepthMock {
 public:
  static Result<std::unique_ptr<DepthMock>> create(const std::filesystem::path& link_path, int units_code = 1,
                                                   std::uint64_t seed = 1);
  // The current reading, in the configured units.
  void setPressure(double value);
  bool continuous() const;
  PtyDevice& pty() { return *pty_; }
  FaultInjector& faults() { return faults_; }
  std::uint64_t commandsReceived() const;

 private:
  DepthMock(int units_code, std::uint64_t seed) : units_code_(units_code), faults_(seed) {}
  void onHostBytes(std::span<const std::uint8_t> bytes);
  void reply(double value);

  int units_code_;
  FaultInjector faults_;
  mutable std::mutex mutex_;
  std::optional<double> pressure_;  // guarded by mutex_; none before the first setPressure()
  bool poll_pending_ = false;       // guarded by mutex_: a P3 came before the first reading
  bool continuous_ = false;         // guarded by mutex_
  std::uint64_t commands_ = 0;      // guarded by mutex_
  std::vector<std::uint8_t> line_;  // device thread: partial command line
  std::unique_ptr<PtyDevice> pty_;  // last: destroyed first, so its device thread stops before the state it uses
};

}  // namespace vog::mock
