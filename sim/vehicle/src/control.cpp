#include "vog/vehicle/control.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>

namespace vog::vehicle {
namespace {

std::vector<std::string_view> words(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r' || line[i] == '\n')) ++i;
    const std::size_t start = i;
    while (i < line.size() && !(line[i] == ' ' || line[i] == '\t' || line[i] == '\r' || line[i] == '\n')) ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

Result<Device> parseDevice(std::string_view w) {
  for (int d = 0; d < kDeviceCount; ++d) {
    if (w == toString(static_cast<Device>(d))) return static_cast<Device>(d);
  }
  return Error{"unknown device '" + std::string(w) + "' (expected dvl, depth, imu, sonar or backseat)"};
}

Result<double> parseSeconds(std::string_view w) {
  double v = 0.0;
  const auto [ptr, ec] = std::from_chars(w.data(), w.data() + w.size(), v);
  if (ec != std::errc{} || ptr != w.data() + w.size() || !std::isfinite(v) || v <= 0.0 || v > 3600.0)
    return Error{"seconds must be a number in (0, 3600], got '" + std::string(w) + "'"};
  return v;
}

Result<double> parseProbability(std::string_view w) {
  double v = 0.0;
  const auto [ptr, ec] = std::from_chars(w.data(), w.data() + w.size(), v);
  if (ec != std::errc{} || ptr != w.data() + w.size() || !(v >= 0.0 && v <= 1.0))
    return Error{"probability must be a number in [0, 1], got '" + std::string(w) + "'"};
  return v;
}

}  // namespace

const char* arisActionName(ArisAction action) {
  switch (action) {
    case ArisAction::kLoss: return "loss";
    case ArisAction::kDuplicate: return "dup";
    case ArisAction::kReorder: return "reorder";
    case ArisAction::kReboot: return "reboot";
  }
  return "?";
}

const char* toString(Device device) {
  switch (device) {
    case Device::kDvl: return "dvl";
    case Device::kDepth: return "depth";
    case Device::kImu: return "imu";
    case Device::kSonar: return "sonar";
    case Device::kBackseat: return "backseat";
  }
  return "?";
}

const char* faultName(mock::Fault fault) {
  switch (fault) {
    case mock::Fault::kGarbage: return "garbage";
    case mock::Fault::kTruncate: return "truncate";
    case mock::Fault::kBadChecksum: return "badcrc";
    case mock::Fault::kDropout: return "dropout";
  }
  return "?";
}

Result<ControlCommand> parseControlCommand(std::string_view line) {
  const std::vector<std::string_view> w = words(line);
  if (w.empty()) return Error{"empty command (expected fault, unplug, aris or status)"};
  ControlCommand c;
  if (w[0] == "status") {
    if (w.size() != 1) return Error{"status takes no arguments"};
    c.kind = ControlCommand::Kind::kStatus;
    return c;
  }
  if (w[0] == "unplug") {
    if (w.size() != 3) return Error{"usage: unplug <device> <seconds>"};
    auto d = parseDevice(w[1]);
    if (!d) return d.error();
    auto s = parseSeconds(w[2]);
    if (!s) return s.error();
    c.kind = ControlCommand::Kind::kUnplug;
    c.device = *d;
    c.seconds = *s;
    return c;
  }
  if (w[0] == "fault") {
    if (w.size() != 4) return Error{"usage: fault <device> garbage|truncate|badcrc|dropout <seconds>"};
    auto d = parseDevice(w[1]);
    if (!d) return d.error();
    bool known = false;
    for (int f = 0; f < mock::kFaultKinds; ++f) {
      if (w[2] == faultName(static_cast<mock::Fault>(f))) {
        c.fault = static_cast<mock::Fault>(f);
        known = true;
      }
    }
    if (!known)
      return Error{"unknown fault '" + std::string(w[2]) + "' (expected garbage, truncate, badcrc or dropout)"};
    auto s = parseSeconds(w[3]);
    if (!s) return s.error();
    c.kind = ControlCommand::Kind::kFault;
    c.device = *d;
    c.seconds = *s;
    return c;
  }
  if (w[0] == "aris") {
    if (w.size() != 3) return Error{"usage: aris loss|dup|reorder <probability> or aris reboot <seconds>"};
    c.kind = ControlCommand::Kind::kAris;
    if (w[1] == "reboot") {
      auto s = parseSeconds(w[2]);
      if (!s) return s.error();
      c.aris_action = ArisAction::kReboot;
      c.seconds = *s;
      return c;
    }
    bool known = false;
    for (const ArisAction a : {ArisAction::kLoss, ArisAction::kDuplicate, ArisAction::kReorder}) {
      if (w[1] == arisActionName(a)) {
        c.aris_action = a;
        known = true;
      }
    }
    if (!known) {
      return Error{"unknown aris command '" + std::string(w[1]) + "' (expected loss, dup, reorder or reboot)"};
    }
    auto p = parseProbability(w[2]);
    if (!p) return p.error();
    c.probability = *p;
    return c;
  }
  return Error{"unknown command '" + std::string(w[0]) + "' (expected fault, unplug, aris or status)"};
}

// ------------------------------------------------------------------------------ ControlServer

Result<std::unique_ptr<ControlServer>> ControlServer::create(const std::filesystem::path& path, Handler handler) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  const std::string p = path.string();
  if (p.empty() || p.size() >= sizeof(addr.sun_path))
    return Error{"control socket path must be 1.." + std::to_string(sizeof(addr.sun_path) - 1) + " bytes, got '" + p +
                 "'"};
  std::memcpy(addr.sun_path, p.c_str(), p.size() + 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd < 0) return Error{errnoText("control socket")};
  ::unlink(p.c_str());  // a stale socket of an earlier run
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0 || ::listen(fd, 8) != 0) {
    const std::string msg = "control socket " + p + ": " + errnoText();
    ::close(fd);
    return Error{msg};
  }
  std::unique_ptr<ControlServer> s(new ControlServer(path, std::move(handler)));
  s->listen_fd_ = fd;
  ControlServer* raw = s.get();
  s->thread_.start(
      [raw](std::vector<pollfd>& fds) {
        fds.push_back(pollfd{raw->listen_fd_, POLLIN, 0});
        for (const Client& c : raw->clients_) fds.push_back(pollfd{c.fd, POLLIN, 0});
      },
      [raw](const std::vector<pollfd>& fds) { raw->onReady(fds); });
  return s;
}

ControlServer::~ControlServer() {
  thread_.stop();
  for (const Client& c : clients_) ::close(c.fd);
  if (listen_fd_ >= 0) ::close(listen_fd_);
  ::unlink(path_.c_str());
}

void ControlServer::onReady(const std::vector<pollfd>& fds) {
  constexpr std::size_t kMaxLine = 1024;
  std::vector<int> closed;
  for (const pollfd& p : fds) {
    if (p.revents == 0) continue;
    if (p.fd == listen_fd_) {
      const int c = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
      if (c >= 0) clients_.push_back(Client{c, {}});
      continue;
    }
    auto it = std::find_if(clients_.begin(), clients_.end(), [&](const Client& c) { return c.fd == p.fd; });
    if (it == clients_.end()) continue;
    char buf[512];
    const ssize_t n = ::read(p.fd, buf, sizeof buf);
    if (n <= 0) {
      if (n < 0 && (errno == EAGAIN || errno == EINTR)) continue;
      closed.push_back(p.fd);
      continue;
    }
    for (ssize_t i = 0; i < n; ++i) {
      if (buf[i] != '\n') {
        it->line.push_back(buf[i]);
        continue;
      }
      std::string reply =
          it->line.size() > kMaxLine ? std::string("error: line longer than 1024 bytes") : handler_(it->line);
      it->line.clear();
      reply.push_back('\n');
      // Replies are short; a client that does not read them loses them rather than stall the server.
      (void)!::send(p.fd, reply.data(), reply.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    }
    if (it->line.size() > kMaxLine) it->line.resize(kMaxLine + 1);  // keep the "too long" mark, not the bytes
  }
  for (int fd : closed) {
    ::close(fd);
    std::erase_if(clients_, [fd](const Client& c) { return c.fd == fd; });
  }
}

}  // namespace vog::vehicle
