// vog-bench io: transport throughput on this machine's real kernel paths (serial over a
// pseudo-terminal, CAN records over SOCK_SEQPACKET) and dead-reckoning update rate, medians over
// repeats. No targets; the figures size the daemon's I/O thread budget (a DVL at
// 115200 baud is 11.5 kB/s, an IMU on CAN 400 frames/s).
#include "bench_cli.hpp"
#include "bench_registry.hpp"

#include <sys/socket.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <asio.hpp>

#include <cmath>
#include <iostream>
#include <limits>
#include <thread>

#include "vog/io/can.hpp"
#include "vog/io/serial.hpp"
#include "vog/mock/pty_device.hpp"
#include "vog/nav/dead_reckoning.hpp"

namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

bool pump(asio::io_context& io, const std::function<bool()>& done, double timeout_s) {
  vog::bench::Stopwatch sw;
  while (!done()) {
    if (sw.seconds() > timeout_s) return false;
    if (io.stopped()) io.restart();
    if (io.run_one_for(std::chrono::milliseconds(5)) == 0) io.restart();
  }
  return true;
}

// MB/s from a pty master to the serial transport's byte callback.
double serialMBps(std::size_t bytes) {
  char tmpl[] = "/tmp/vog-bench-XXXXXX";
  const char* dir = ::mkdtemp(tmpl);
  if (dir == nullptr) return kNan;
  const std::string link = std::string(dir) + "/tty";
  auto dev = vog::mock::PtyDevice::create(link);
  if (!dev.ok()) return kNan;
  asio::io_context io;
  std::size_t received = 0;
  vog::io::SerialConfig c;
  c.device_path = link;
  vog::io::SerialTransport t(io, c, vog::io::steadyStampClock(),
                             [&](std::span<const std::uint8_t> b, std::int64_t) { received += b.size(); });
  if (!t.start().ok() || !pump(
                             io, [&] { return t.health().state == vog::io::LinkState::kConnected; }, 5))
    return kNan;
  const std::vector<std::uint8_t> payload(bytes, 0x55);
  vog::bench::Stopwatch sw;
  (*dev)->send(payload);
  const bool ok = pump(
      io, [&] { return received >= bytes; }, 60);
  const double s = sw.seconds();
  t.stop();
  dev->reset();
  ::rmdir(dir);
  return ok ? static_cast<double>(bytes) / s / 1e6 : kNan;
}

// can_frame records per second through the fd read loop (a writer thread fills the socket pair).
double canFramesPerSecond(int frames) {
  int fds[2];
  if (::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, fds) != 0) return kNan;
  asio::io_context io;
  int received = 0;
  auto t = vog::io::CanTransport::adopt(io, fds[0], {vog::io::CanFilter{0x180, 0x7FC}}, vog::io::steadyStampClock(),
                                        [&](const can_frame&, std::int64_t) { ++received; });
  if (!t->start().ok()) return kNan;
  vog::bench::Stopwatch sw;
  std::thread writer([fd = fds[1], frames] {
    can_frame f{};
    f.len = 8;
    for (int i = 0; i < frames; ++i) {
      f.can_id = 0x180 + static_cast<canid_t>(i % 4);
      if (::send(fd, &f, sizeof(f), 0) != static_cast<ssize_t>(sizeof(f))) return;
    }
  });
  const bool ok = pump(
      io, [&] { return received >= frames; }, 60);
  const double s = sw.seconds();
  writer.join();
  ::close(fds[1]);
  return ok ? frames / s : kNan;
}

// Dead-reckoning updates per second: 100 Hz IMU with a 5 Hz DVL and 4 Hz depth interleaved.
double navSamplesPerSecond(int imu_samples) {
  vog::nav::DeadReckoning dr;
  vog::bench::Stopwatch sw;
  for (int k = 0; k < imu_samples; ++k) {
    vog::imu::ImuSample s;
    s.stamp_ns = static_cast<std::int64_t>(k) * 10'000'000;
    s.attitude = vog::imu::ImuAttitude{0.01, -0.02, 0.001 * k};
    (void)dr.addImu(s);
    if (k % 20 == 0) {
      vog::dvl::BottomVelocity v;
      v.stamp_ns = s.stamp_ns + 3'000'000;
      v.frame = vog::dvl::CoordinateFrame::kInstrument;
      v.velocity_mps = {0.0, 0.2, 0.0};
      v.valid = true;
      (void)dr.addDvl(v);
    }
    if (k % 25 == 0) {
      vog::depth::DepthSample d;
      d.stamp_ns = s.stamp_ns;
      d.depth_m = 3.0;
      (void)dr.addDepth(d);
    }
  }
  const double s = sw.seconds();
  return (imu_samples * (1.0 + 1.0 / 20 + 1.0 / 25)) / s;
}

}  // namespace

VOG_BENCH_COMMAND(io, "Transports and navigation: serial pty MB/s, CAN seqpacket frames/s, dead-reckoning samples/s") {
  int repeats = 5;
  int serial_kb = 4096;
  int can_frames = 200000;
  int nav_samples = 1000000;
  CLI::App app{"vog-bench io"};
  app.add_option("--repeats", repeats, "repeats (median reported)")->check(CLI::PositiveNumber);
  app.add_option("--serial-kb", serial_kb, "kilobytes through the pty per repeat")->check(CLI::PositiveNumber);
  app.add_option("--can-frames", can_frames, "CAN records per repeat")->check(CLI::PositiveNumber);
  app.add_option("--nav-samples", nav_samples, "IMU samples per repeat")->check(CLI::PositiveNumber);
  if (const auto exit_code = vog::bench::parseArgs(app, args)) return *exit_code;
  std::vector<double> serial, can, nav;
  for (int r = 0; r < repeats; ++r) {
    serial.push_back(serialMBps(static_cast<std::size_t>(serial_kb) * 1024));
    can.push_back(canFramesPerSecond(can_frames));
    nav.push_back(navSamplesPerSecond(nav_samples));
  }
  vog::bench::JsonObject out;
  out.add("repeats", repeats);
  out.add("serial_pty_MBps", vog::bench::median(serial));
  out.add("can_seqpacket_frames_per_s", vog::bench::median(can));
  out.add("nav_samples_per_s", vog::bench::median(nav));
  std::cout << out.str() << std::endl;
  return 0;
}
