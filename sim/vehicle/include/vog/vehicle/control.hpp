#pragma once
// Run-time control of `vogsim vehicle`: fault injection and unplugging, one text command per line
// (sim/README.md "Control commands"):
//   fault <device> garbage|truncate|badcrc|dropout <seconds>
//   unplug <device> <seconds>
//   aris loss|dup|reorder <probability>   (sonar kind aris: per-datagram link faults, in [0, 1])
//   aris reboot <seconds>                 (sonar kind aris: the sonar forgets its settings and is
//                                          silent for <seconds>)
//   status
// with <device> one of dvl, depth, imu, sonar, backseat and <seconds> simulated seconds in
// (0, 3600]. Lines are answered with one line: "ok ..." or "error: ...".

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "vog/core/result.hpp"
#include "vog/mock/device_thread.hpp"
#include "vog/mock/faults.hpp"

namespace vog::vehicle {

enum class Device : std::uint8_t { kDvl, kDepth, kImu, kSonar, kBackseat };
constexpr int kDeviceCount = 5;
const char* toString(Device device);
const char* faultName(mock::Fault fault);  // the control word: garbage, truncate, badcrc, dropout

// What an `aris` command does to the mock ARIS sonar.
enum class ArisAction : std::uint8_t { kLoss, kDuplicate, kReorder, kReboot };
const char* arisActionName(ArisAction action);  // the control word: loss, dup, reorder, reboot

struct ControlCommand {
  enum class Kind : std::uint8_t { kFault, kUnplug, kAris, kStatus };
  Kind kind = Kind::kStatus;
  Device device = Device::kDvl;
  mock::Fault fault = mock::Fault::kGarbage;   // kFault only
  double seconds = 0.0;                        // simulated seconds (kFault, kUnplug, kAris kReboot)
  ArisAction aris_action = ArisAction::kLoss;  // kAris only
  double probability = 0.0;                    // kAris kLoss, kDuplicate, kReorder: in [0, 1]
};

// Parses one line (surrounding blanks ignored). Errors name the bad word and what was expected.
Result<ControlCommand> parseControlCommand(std::string_view line);

// A Unix-domain stream socket at `path` accepting any number of clients; every line received is
// passed to the handler and its reply is written back followed by LF.
// Lifecycle: create() removes a stale socket file, listens and starts the thread; destruction
// closes the clients and the listener and removes the socket file. Threading: the handler runs
// on the server's own thread. Invariant: a client line longer than 1 kB is answered with an
// error and discarded, never buffered without bound.
class ControlServer {
 public:
  using Handler = std::function<std::string(const std::string& line)>;

  static Result<std::unique_ptr<ControlServer>> create(const std::filesystem::path& path, Handler handler);
  ~ControlServer();
  ControlServer(const ControlServer&) = delete;
  ControlServer& operator=(const ControlServer&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  struct Client {
    int fd = -1;
    std::string line;
  };
  ControlServer(std::filesystem::path path, Handler handler) : path_(std::move(path)), handler_(std::move(handler)) {}
  void onReady(const std::vector<pollfd>& fds);

  std::filesystem::path path_;
  Handler handler_;
  int listen_fd_ = -1;           // server thread (after start)
  std::vector<Client> clients_;  // server thread
  mock::DeviceThread thread_;
};

}  // namespace vog::vehicle
