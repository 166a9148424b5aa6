#include "vog/mock/serial_devices.hpp"

#include "vog/dvl/pd0.hpp"

namespace vog::mock {

Result<std::unique_ptr<DvlMock>> DvlMock::create(const std::filesystem::path& link_path, std::uint64_t seed) {
  auto pty = PtyDevice::create(link_path);
  if (!pty.ok()) return pty.error();
  return std::unique_ptr<DvlMock>(new DvlMock(std::move(pty).value(), seed));
}

Status DvlMock::sendPd0(const dvl::DvlEnsemble& ensemble) {
  std::vector<std::uint8_t> bytes = dvl::encodePd0(ensemble);
  if (bytes.size() < 4) return Error{"pd0 encoder produced " + std::to_string(bytes.size()) + " bytes"};
  // PD0 checksum: the u16 after the ensemble (PROTOCOLS.md), little-endian.
  const auto out = faults_.apply(std::move(bytes), [](std::vector<std::uint8_t>& m) {
    m[m.size() - 2] = static_cast<std::uint8_t>(m[m.size() - 2] + 1);
  });
  pty_->send(out);
  return Status::success();
}

void DvlMock::sendPd6(const dvl::Pd6Sentence& sentence) {
  const std::string line = dvl::encodePd6(sentence);
  const auto out = faults_.apply(std::vector<std::uint8_t>(line.begin(), line.end()), [](std::vector<std::uint8_t>& m) {
    for (auto& c : m) {
      if (c == 'A' || c == 'V') c = '?';
    }
  });
  pty_->send(out);
}

Result<std::unique_ptr<DepthMock>> DepthMock::create(const std::filesystem::path& link_path, int units_code,
                                                     std::uint64_t seed) {
  auto unit = depth::pressureUnitFromCode(units_code);
  if (!unit.ok()) return unit.error();
  std::unique_ptr<DepthMock> mock(new DepthMock(units_code, seed));
  DepthMock* raw = mock.get();
  auto pty = PtyDevice::create(link_path, [raw](std::span<const std::uint8_t> b) { raw->onHostBytes(b); });
  if (!pty.ok()) return pty.error();
  mock->pty_ = std::move(pty).value();
  return mock;
}

void DepthMock::setPressure(double value) {
  bool send_now = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    pressure_ = value;
    send_now = continuous_ || poll_pending_;
    poll_pending_ = false;
  }
  if (send_now) reply(value);
}

bool DepthMock::continuous() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return continuous_;
}

std::uint64_t DepthMock::commandsReceived() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return commands_;
}

void DepthMock::reply(double value) {
  const std::string line = depth::encodePressureReply(0, 1, value, 4);
  const auto out = faults_.apply(std::vector<std::uint8_t>(line.begin(), line.end()), [](std::vector<std::uint8_t>& m) {
    if (m.size() > 6) m[6] = 'x';  // inside the number, after "*0001" and its first digit
  });
  pty_->send(out);
}

void DepthMock::onHostBytes(std::span<const std::uint8_t> bytes) {
  // Commands are `*0100<cmd>` CR LF lines (Digiquartz manual Ch. 7); decoded with the real codec.
  for (std::uint8_t b : bytes) {
    line_.push_back(b);
    if (b != '\n') {
      if (line_.size() > 128) line_.clear();  // runaway line: drop, as the instrument would
      continue;
    }
    depth::DigiquartzCodec codec;
    auto result = codec.decode(line_);
    line_.clear();
    if (!result.isFrame()) continue;
    const depth::DigiquartzMessage& m = result.frame();
    if (m.kind != depth::DigiquartzMessage::Kind::kCommand || m.destination != 1) continue;
    std::optional<double> pressure;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++commands_;
      pressure = pressure_;
      if (m.body == "P4") continuous_ = true;
      if (m.body == "P3") {
        continuous_ = false;
        poll_pending_ = !pressure_.has_value();
      }
    }
    if (m.body == "P3") {
      if (pressure) reply(*pressure);
    } else if (m.body == "UN") {
      const std::string line = depth::encodeParameterReply(0, 1, "UN", std::to_string(units_code_));
      pty_->send(std::vector<std::uint8_t>(line.begin(), line.end()));
    }
  }
}

}  // namespace vog::mock
