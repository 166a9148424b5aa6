#pragma once
// Socket mock devices: the IMU on the Unix-domain SOCK_SEQPACKET CAN stand-in, the sonar's live
// frames over UDP on loopback, and the HAUV backseat as a TCP server on loopback.

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "vog/backseat/backseat.hpp"
#include "vog/core/result.hpp"
#include "vog/imu/imu_can.hpp"
#include "vog/mock/faults.hpp"
#include "vog/mock/stream_server.hpp"
#include "vog/sonar/sonar_frame.hpp"

namespace vog::mock {

// IMU: every sample is four can_frame records (drivers/imu/README.md), one packet each.
// Faults: kGarbage = a record of random bytes and a 7-byte record before the sample,
// kTruncate = only the first two frames, kBadChecksum = CRC byte flipped, kDropout = nothing.
// Lifecycle as StreamServer (server().disappear()/reappear()).
class ImuMock {
 public:
  static Result<std::unique_ptr<ImuMock>> create(const std::string& socket_path, imu::ImuCanConfig config = {},
                                                 std::uint64_t seed = 1);
  Status send(const imu::ImuSample& sample);
  StreamServer& server() { return *server_; }
  FaultInjector& faults() { return faults_; }

 private:
  ImuMock(imu::ImuCanConfig config, std::uint64_t seed) : config_(config), faults_(seed) {}
  imu::ImuCanConfig config_;
  FaultInjector faults_;
  std::unique_ptr<StreamServer> server_;
};

// Sonar live frames: each frame is sent as the fragment datagrams of sonar_udp.hpp to
// 127.0.0.1:port. Faults apply to one fragment of the frame: kGarbage = a datagram of noise
// before it, kTruncate = the fragment cut in half, kBadChecksum = a payload byte flipped (CRC-32
// fails), kDropout = the fragment not sent (its frame can never complete). disappear() closes the
// socket (nothing is sent) until reappear().
// Threading: one thread at a time. Invariant: datagrams go to loopback only.
class SonarMock {
 public:
  static Result<std::unique_ptr<SonarMock>> create(std::uint16_t port, std::uint64_t seed = 1);
  ~SonarMock();
  SonarMock(const SonarMock&) = delete;
  SonarMock& operator=(const SonarMock&) = delete;
  Status send(const sonar::SonarFrame& frame, std::size_t payload_bytes = 1400);
  void disappear();
  Status reappear();
  FaultInjector& faults() { return faults_; }
  std::uint64_t datagramsSent() const { return datagrams_sent_; }

 private:
  SonarMock(std::uint16_t port, std::uint64_t seed) : port_(port), faults_(seed) {}
  Status open();
  Status sendDatagram(const std::vector<std::uint8_t>& d);
  std::uint16_t port_;
  int fd_ = -1;
  FaultInjector faults_;
  std::uint64_t datagrams_sent_ = 0;
};

// HAUV backseat (vehicle side) on 127.0.0.1: sends $BF sentences to the payload, decodes the
// payload's $BP sentences, and acknowledges each $BPGHP with $BFACK (accepted) unless
// setAcknowledge(false). Faults apply to sent $BF sentences; kBadChecksum changes the XOR digits.
// Threading: public members from any thread.
class BackseatMock {
 public:
  static Result<std::unique_ptr<BackseatMock>> create(std::uint16_t port = 0, std::uint64_t seed = 1);
  void send(const backseat::BackseatSentence& sentence);
  void setAcknowledge(bool acknowledge);
  std::vector<backseat::BackseatSentence> received() const;
  StreamServer& server() { return *server_; }
  FaultInjector& faults() { return faults_; }

 private:
  explicit BackseatMock(std::uint64_t seed) : faults_(seed) {}
  void onPayloadBytes(std::span<const std::uint8_t> bytes);

  FaultInjector faults_;
  std::unique_ptr<StreamServer> server_;
  mutable std::mutex mutex_;
  std::vector<backseat::BackseatSentence> received_;  // guarded by mutex_
  bool acknowledge_ = true;                           // guarded by mutex_
  std::vector<std::uint8_t> pending_;                 // device thread: undecoded bytes
};

}  // namespace vog::mock
