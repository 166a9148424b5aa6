// The vogd executable as systemd runs it: READY and WATCHDOG on the notify socket, kill -9 in the
// middle of a mission followed by a restart that resumes every closed submap and keeps mapping,
// SIGHUP logged and ignored, SIGTERM answered by STOPPING and a clean exit within 2 s, and --check-config
// (ExecStartPre) refusing what vogd would refuse.
#include "vog/client/api_client.hpp"

#include "subprocess.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <fstream>
#include <thread>

namespace {

using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

// The service manager's end of NOTIFY_SOCKET.
class NotifySocket {
 public:
  explicit NotifySocket(const fs::path& path) : path_(path) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, path.c_str(), sizeof(addr.sun_path) - 1);
    bound_ = ::bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) == 0;
  }
  ~NotifySocket() { ::close(fd_); }
  bool bound() const { return bound_; }
  // Waits for a datagram containing `line` (other messages are skipped).
  bool waitFor(const std::string& line, double timeout_s) {
    const auto end = Clock::now() + std::chrono::duration<double>(timeout_s);
    while (Clock::now() < end) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 50) <= 0) continue;
      char buf[4096];
      const ssize_t n = ::recv(fd_, buf, sizeof(buf), 0);
      if (n <= 0) continue;
      const std::string msg(buf, static_cast<std::size_t>(n));
      if (("\n" + msg + "\n").find("\n" + line + "\n") != std::string::npos) return true;
    }
    return false;
  }

 private:
  fs::path path_;
  int fd_ = -1;
  bool bound_ = false;
};

std::uint16_t readPort(const fs::path& file) {
  std::ifstream in(file);
  int p = 0;
  return (in >> p) ? static_cast<std::uint16_t>(p) : 0;
}

vog::api::StatusReport waitForSubmaps(vog::client::ApiClient& c, std::uint32_t n, double timeout_s) {
  const auto end = Clock::now() + std::chrono::duration<double>(timeout_s);
  vog::api::StatusReport s;
  while (Clock::now() < end) {
    auto r = c.status();
    if (!r) break;
    s = *r;
    if (s.n_submaps >= n) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return s;
}

std::string logText(const fs::path& log) { return vog::test::readTextFile(log); }

TEST(VogdProcess, NotifiesResumesAfterKillAndStopsOnSigterm) {
  vog::test::TempDir dir("vogd-process");
  const fs::path config = dir.path() / "vogd.yaml";
  std::ofstream(config) << "source: sim\n"
                           "sim:\n  scene: "
                        << (vog::test::sourceDir() / "config/scenes/pilings.yaml").string()
                        << "\n  seed: 2\n  speedup: 0\n"
                           "mission:\n  box_min_m: [-6, -4, -4]\n  box_max_m: [6, 4, 0]\n  start_on_launch: true\n"
                           "  max_submaps: 60\n"
                           "api:\n  port: 0\n";
  const fs::path mission = dir.path() / "mission", port_file = dir.path() / "port", log = dir.path() / "vogd.log";
  NotifySocket notify(dir.path() / "notify.sock");
  ASSERT_TRUE(notify.bound());
  const std::vector<std::string> args = {VOGD_EXECUTABLE,  "--config",    config.string(),   "--mission-dir",
                                         mission.string(), "--port-file", port_file.string()};
  const std::vector<std::string> env = {"NOTIFY_SOCKET=" + (dir.path() / "notify.sock").string(),
                                        "WATCHDOG_USEC=2000000"};

  std::uint32_t committed = 0;
  {
    vog::test::Subprocess vogd(args, env, log);
    ASSERT_TRUE(vogd.started());
    ASSERT_TRUE(notify.waitFor("READY=1", 30.0)) << logText(log);
    EXPECT_TRUE(notify.waitFor("WATCHDOG=1", 5.0)) << "no watchdog ping within 5 s of WatchdogSec=2s";
    auto c = vog::client::ApiClient::connect("127.0.0.1", readPort(port_file)).value();
    const vog::api::StatusReport s = waitForSubmaps(*c, 3, 60.0);
    ASSERT_GE(s.n_submaps, 3u) << logText(log);
    committed = s.n_submaps;  // the API reports a submap only after its journal group is durable
    ::kill(vogd.pid(), SIGKILL);
    EXPECT_EQ(vogd.wait(5.0), 128 + SIGKILL);
  }
  fs::remove(port_file);
  {
    vog::test::Subprocess vogd(args, env, log);
    ASSERT_TRUE(notify.waitFor("READY=1", 30.0)) << logText(log);
    auto c = vog::client::ApiClient::connect("127.0.0.1", readPort(port_file)).value();
    const vog::api::StatusReport resumed = c->status().value();
    EXPECT_GE(resumed.n_submaps, committed) << "a closed submap was lost in the kill";
    EXPECT_EQ(resumed.mission_state, vog::api::MissionState::kExploring);
    // The mission goes on from where it was: new submaps are mapped after the resume.
    const vog::api::StatusReport later = waitForSubmaps(*c, resumed.n_submaps + 2, 60.0);
    EXPECT_GE(later.n_submaps, resumed.n_submaps + 2) << logText(log);
    // SIGHUP is logged and ignored: the daemon keeps answering and stops cleanly afterwards.
    ::kill(vogd.pid(), SIGHUP);
    const auto hup_end = Clock::now() + std::chrono::seconds(5);
    while (Clock::now() < hup_end && logText(log).find("SIGHUP ignored") == std::string::npos)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    EXPECT_NE(logText(log).find("SIGHUP ignored"), std::string::npos) << logText(log);
    EXPECT_TRUE(c->status().ok()) << "vogd did not survive SIGHUP";
    const auto t0 = Clock::now();
    ::kill(vogd.pid(), SIGTERM);
    EXPECT_TRUE(notify.waitFor("STOPPING=1", 2.0));
    EXPECT_EQ(vogd.wait(2.0), 0) << logText(log);
    EXPECT_LT(std::chrono::duration<double>(Clock::now() - t0).count(), 2.0);
  }
  EXPECT_EQ(logText(log).find("rejected"), std::string::npos) << "no scan may be refused after the resume";
}

// ExecStartPre=vogd --check-config must fail (exit 2, the reason with file:line) on what vogd would
// refuse at startup, or Restart=on-failure loops on it.
TEST(VogdProcess, CheckConfigRefusesWhatVogdWouldRefuse) {
  vog::test::TempDir dir("vogd-check");
  const fs::path secret = dir.path() / "operator.secret", config = dir.path() / "vogd.yaml";
  std::ofstream(secret) << "correct horse battery staple\n";
  fs::permissions(secret, fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
  const std::string text =
      "source: sim\n"
      "sim:\n  scene: " +
      (vog::test::sourceDir() / "config/scenes/pilings.yaml").string() +
      "\n"
      "api:\n  port: 0\n  secret_file: operator.secret\n";
  std::ofstream(config) << text;
  const auto check = [&](const std::vector<std::string>& extra, const fs::path& log) {
    std::vector<std::string> args = {VOGD_EXECUTABLE, "--config", config.string(), "--check-config"};
    args.insert(args.end(), extra.begin(), extra.end());
    vog::test::Subprocess vogd(args, {}, log);
    return vogd.started() ? vogd.wait(30.0) : -1;
  };
  const fs::path mission = dir.path() / "missions" / "current";
  EXPECT_EQ(check({"--mission-dir", mission.string()}, dir.path() / "secret.log"), 2);
  EXPECT_NE(logText(dir.path() / "secret.log")
                .find("vogd.yaml:6: api.secret_file: " + secret.string() +
                      " has mode 0640, accessible by group or others; chmod 600 " + secret.string()),
            std::string::npos)
      << logText(dir.path() / "secret.log");

  fs::permissions(secret, fs::perms::owner_read | fs::perms::owner_write);
  EXPECT_EQ(check({"--mission-dir", mission.string()}, dir.path() / "ok.log"), 0) << logText(dir.path() / "ok.log");
  EXPECT_FALSE(fs::exists(dir.path() / "missions")) << "the check leaves nothing behind";

  std::ofstream(dir.path() / "missions") << "a file";
  EXPECT_EQ(check({"--mission-dir", mission.string()}, dir.path() / "mission.log"), 2);
  EXPECT_NE(logText(dir.path() / "mission.log")
                .find("--mission-dir: " + mission.string() + ": " + (dir.path() / "missions").string() +
                      " is not a directory"),
            std::string::npos)
      << logText(dir.path() / "mission.log");
}

}  // namespace
