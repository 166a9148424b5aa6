#include "vog/mock/faults.hpp"

#include <algorithm>

namespace vog::mock {

void FaultInjector::inject(Fault fault, int count) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (int i = 0; i < count; ++i) armed_.push_back(fault);
}

std::vector<std::uint8_t> FaultInjector::apply(std::vector<std::uint8_t> message, const CorruptChecksum& corrupt) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (armed_.empty()) return message;
  const Fault fault = armed_.front();
  armed_.erase(armed_.begin());
  ++applied_[static_cast<std::size_t>(fault)];
  switch (fault) {
    case Fault::kGarbage: {
      const std::size_t n = std::uniform_int_distribution<std::size_t>(1, 64)(rng_);
      std::uniform_int_distribution<int> byte(0x80, 0xFE);
      std::vector<std::uint8_t> out;
      out.reserve(n + message.size());
      for (std::size_t i = 0; i < n; ++i) out.push_back(static_cast<std::uint8_t>(byte(rng_)));
      out.insert(out.end(), message.begin(), message.end());
      return out;
    }
    case Fault::kTruncate: message.resize(message.size() > 1 ? message.size() / 2 : message.size()); return message;
    case Fault::kBadChecksum:
      if (corrupt) corrupt(message);
      return message;
    case Fault::kDropout: return {};
  }
  return message;
}

std::optional<Fault> FaultInjector::take() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (armed_.empty()) return std::nullopt;
  const Fault fault = armed_.front();
  armed_.erase(armed_.begin());
  ++applied_[static_cast<std::size_t>(fault)];
  return fault;
}

std::vector<std::uint8_t> FaultInjector::noise(std::size_t max_bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::size_t n = std::uniform_int_distribution<std::size_t>(1, std::max<std::size_t>(1, max_bytes))(rng_);
  std::uniform_int_distribution<int> byte(0x80, 0xFE);
  std::vector<std::uint8_t> out(n);
  for (auto& b : out) b = static_cast<std::uint8_t>(byte(rng_));
  return out;
}

std::array<std::uint64_t, kFaultKinds> FaultInjector::applied() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return applied_;
}

std::size_t FaultInjector::armed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return armed_.size();
}

}  // namespace vog::mock
