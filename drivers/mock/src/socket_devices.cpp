#include "vog/mock/socket_devices.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include "vog/sonar/sonar_udp.hpp"

namespace vog::mock {

// ---------------------------------------------------------------------------------------- IMU

Result<std::unique_ptr<ImuMock>> ImuMock::create(const std::string& socket_path, imu::ImuCanConfig config,
                                                 std::uint64_t seed) {
  Status valid = config.validate();
  if (!valid.ok()) return valid.error();
  std::unique_ptr<ImuMock> mock(new ImuMock(config, seed));
  StreamServerConfig sc;
  sc.seqpacket_path = socket_path;
  auto server = StreamServer::create(sc);
  if (!server.ok()) return server.error();
  mock->server_ = std::move(server).value();
  return mock;
}

Status ImuMock::send(const imu::ImuSample& sample) {
  auto frames = imu::encodeImuCan(sample, config_);
  if (!frames.ok()) return frames.error();
  std::vector<std::vector<std::uint8_t>> records;
  for (const can_frame& f : *frames) records.push_back(imu::canFramesToBytes(std::span<const can_frame>(&f, 1)));
  switch (faults_.take().value_or(static_cast<Fault>(255))) {
    case Fault::kGarbage: {
      std::vector<std::uint8_t> noise16 = faults_.noise(16);
      noise16.resize(sizeof(can_frame), 0x80);
      std::vector<std::uint8_t> noise7 = faults_.noise(7);
      noise7.resize(7, 0x80);
      records.insert(records.begin(), {noise16, noise7});
      break;
    }
    case Fault::kTruncate: records.resize(2); break;
    case Fault::kBadChecksum:
      // Frame 3 bytes 6-7 hold the CRC-16 (drivers/imu/README.md); the data starts at offset 8.
      records[3][8 + 7] ^= 0xFF;
      break;
    case Fault::kDropout: records.clear(); break;
  }
  server_->send(std::move(records));
  return Status::success();
}

// -------------------------------------------------------------------------------------- sonar

Result<std::unique_ptr<SonarMock>> SonarMock::create(std::uint16_t port, std::uint64_t seed) {
  if (port == 0) return Error{"sonar mock: destination port must be set (got 0)"};
  std::unique_ptr<SonarMock> mock(new SonarMock(port, seed));
  Status ok = mock->open();
  if (!ok.ok()) return ok.error();
  return mock;
}

SonarMock::~SonarMock() { disappear(); }

Status SonarMock::open() {
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) return Error{errnoText("sonar mock socket")};
  return Status::success();
}

void SonarMock::disappear() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

Status SonarMock::reappear() {
  if (fd_ >= 0) return Error{"sonar mock is already open"};
  return open();
}

Status SonarMock::sendDatagram(const std::vector<std::uint8_t>& d) {
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port_);
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const ssize_t n = ::sendto(fd_, d.data(), d.size(), 0, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr));
  if (n != static_cast<ssize_t>(d.size())) return Error{errnoText("sonar mock sendto")};
  ++datagrams_sent_;
  return Status::success();
}

Status SonarMock::send(const sonar::SonarFrame& frame, std::size_t payload_bytes) {
  if (fd_ < 0) return Status::success();  // disappeared: the sonar is silent
  auto datagrams = sonar::encodeSonarDatagrams(frame, payload_bytes);
  if (!datagrams.ok()) return datagrams.error();
  std::vector<std::vector<std::uint8_t>>& all = datagrams.value();
  // The fault hits the middle fragment of the frame.
  const std::size_t victim = all.size() / 2;
  const std::optional<Fault> fault = faults_.take();
  for (std::size_t i = 0; i < all.size(); ++i) {
    std::vector<std::uint8_t>& d = all[i];
    if (fault && i == victim) {
      switch (*fault) {
        case Fault::kGarbage: {
          Status s = sendDatagram(faults_.noise(256));
          if (!s.ok()) return s;
          break;
        }
        case Fault::kTruncate: d.resize(d.size() / 2); break;
        case Fault::kBadChecksum: d[sonar::udp::kHeaderBytes] ^= 0x01; break;
        case Fault::kDropout: continue;
      }
    }
    Status s = sendDatagram(d);
    if (!s.ok()) return s;
  }
  return Status::success();
}

// ----------------------------------------------------------------------------------- backseat

Result<std::unique_ptr<BackseatMock>> BackseatMock::create(std::uint16_t port, std::uint64_t seed) {
  std::unique_ptr<BackseatMock> mock(new BackseatMock(seed));
  BackseatMock* raw = mock.get();
  StreamServerConfig sc;
  sc.tcp_port = port;
  auto server = StreamServer::create(sc, [raw](std::span<const std::uint8_t> b) { raw->onPayloadBytes(b); });
  if (!server.ok()) return server.error();
  mock->server_ = std::move(server).value();
  return mock;
}

void BackseatMock::send(const backseat::BackseatSentence& sentence) {
  const std::string line = backseat::encodeBackseat(sentence);
  auto out = faults_.apply(std::vector<std::uint8_t>(line.begin(), line.end()), [](std::vector<std::uint8_t>& m) {
    // "*hh\r\n": change the first hex digit to another valid hex digit.
    if (m.size() >= 5) {
      std::uint8_t& c = m[m.size() - 4];
      c = c == '0' ? '1' : '0';
    }
  });
  server_->send({std::move(out)});
}

void BackseatMock::setAcknowledge(bool acknowledge) {
  std::lock_guard<std::mutex> lock(mutex_);
  acknowledge_ = acknowledge;
}

std::vector<backseat::BackseatSentence> BackseatMock::received() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return received_;
}

void BackseatMock::onPayloadBytes(std::span<const std::uint8_t> bytes) {
  pending_.insert(pending_.end(), bytes.begin(), bytes.end());
  const backseat::BackseatCodec codec;
  std::size_t pos = 0;
  while (pos < pending_.size()) {
    auto r = codec.decode(std::span<const std::uint8_t>(pending_).subspan(pos));
    if (r.isNeedMore()) break;
    pos += r.consumed();
    if (!r.isFrame()) continue;
    bool ack = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      received_.push_back(r.frame());
      ack = acknowledge_;
    }
    if (const auto* cmd = std::get_if<backseat::WaypointCommand>(&r.frame()); cmd != nullptr && ack) {
      const backseat::AckSentence a{.stamp_ns = 0,
                                    .time = cmd->time,
                                    .command = std::string("BPGHP"),
                                    .command_time = cmd->time,
                                    .command_id = cmd->id,
                                    .status = backseat::AckStatus::kAccepted,
                                    .reason = std::string("accepted")};
      const std::string line = backseat::encodeBackseat(a);
      server_->send({std::vector<std::uint8_t>(line.begin(), line.end())});
    }
  }
  pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(pos));
}

}  // namespace vog::mock
