#include "vog/sim/paths.hpp"
#include "vog/sim/render.hpp"
#include "vog/sim/survey.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>
#include <zlib.h>

#include <fstream>
#include <sstream>

namespace vog::sim {
namespace {

std::size_t lineCount(const std::filesystem::path& p) {
  const std::string s = test::readFile(p);
  return static_cast<std::size_t>(std::count(s.begin(), s.end(), '\n'));
}

std::unique_ptr<World> pilingsWorld() {
  auto s = loadScene(vog::test::sourceDir() / "config" / "scenes" / "pilings.yaml");
  EXPECT_TRUE(s.ok()) << s.error().message;
  auto w = World::create(*s);
  EXPECT_TRUE(w.ok()) << w.error().message;
  return std::move(w).value();
}

// A short survey: from the start pose 1.5 m toward the first piling, then a 1.2 rad turn, 14 s.
std::vector<Waypoint> shortPath(const Scene& scene) {
  const Eigen::Vector3d p = scene.T_world_start.translation();
  return {{p + Eigen::Vector3d(1.5, 0, 0), 0.0}, {p + Eigen::Vector3d(1.5, 0, 0), 1.2}};
}

TEST(Survey, RecordsEveryStreamConsistentlyAndReadsBack) {
  const auto w = pilingsWorld();
  vog::test::TempDir dir("vog-sim-survey");
  SurveyConfig cfg;
  cfg.seed = 4;
  cfg.frame_every = 2;
  auto sum = runSurvey(*w, shortPath(w->scene()), cfg, "test", dir.path());
  ASSERT_TRUE(sum.ok()) << sum.error().message;
  EXPECT_EQ(sum->waypoints_reached, 2);
  EXPECT_EQ(sum->waypoints_skipped, 0);
  EXPECT_NEAR(sum->path_length_m, 1.5, 1e-6);
  // 1.5 m at 0.25 m/s = 6 s, then 1.2 rad at 0.15 rad/s = 8 s.
  EXPECT_NEAR(sum->duration_s, 14.0, 0.02);
  const std::size_t steps = static_cast<std::size_t>(std::lround(sum->duration_s * 100)) + 1;
  EXPECT_EQ(lineCount(dir.path() / "ground_truth.csv"), steps + 1);  // + header
  EXPECT_EQ(lineCount(dir.path() / "odometry.csv"), steps + 1);
  EXPECT_EQ(sum->n_scans, static_cast<std::size_t>(std::floor(sum->duration_s * 5 + 1e-6)) + 1);
  EXPECT_EQ(lineCount(dir.path() / "scan_poses.csv"), sum->n_scans + 1);
  EXPECT_EQ(lineCount(dir.path() / "dvl.csv"), sum->n_scans + 1);  // both at 5 Hz
  EXPECT_EQ(sum->n_frames, (sum->n_scans + 1) / 2);

  auto scans = readScans(dir.path() / "scans.csv");
  ASSERT_TRUE(scans.ok()) << scans.error().message;
  ASSERT_EQ(scans->size(), sum->n_scans);
  auto frames = readFrames(dir.path() / "frames.bin");
  ASSERT_TRUE(frames.ok()) << frames.error().message;
  ASSERT_EQ(frames->size(), sum->n_frames);

  // Replaying the sonar model at the recorded true poses with the same seed reproduces the
  // recorded scans and frames exactly: the record is complete and the run deterministic.
  auto model = SonarModel::create(*w, cfg.sonar, cfg.seed);
  ASSERT_TRUE(model.ok());
  std::ifstream poses(dir.path() / "scan_poses.csv");
  std::string line;
  std::getline(poses, line);
  std::size_t fi = 0;
  int hits = 0;
  for (std::size_t i = 0; i < scans->size(); ++i) {
    ASSERT_TRUE(std::getline(poses, line));
    std::vector<double> v;
    std::stringstream ls(line);
    for (std::string f; std::getline(ls, f, ',');) v.push_back(std::stod(f));
    ASSERT_EQ(v.size(), 14u);
    const geometry::Pose3 T = geometry::poseFromXyzRpy(v[2], v[3], v[4], v[5], v[6], v[7]);
    const bool with_frame = i % 2 == 0;
    const SonarPing p = model->ping(T, static_cast<std::int64_t>(v[1]), with_frame, static_cast<std::uint32_t>(fi));
    const auto& rec = (*scans)[i];
    EXPECT_EQ(rec.scan_index, i);
    EXPECT_EQ(rec.scan.stamp_ns, static_cast<std::int64_t>(v[1]));
    ASSERT_EQ(rec.scan.range_m.size(), 96u);
    for (std::size_t b = 0; b < 96; ++b) {
      // Poses are recorded with 9 significant digits: allow their rounding.
      if (std::isfinite(p.scan.range_m[b])) {
        ++hits;
        EXPECT_NEAR(rec.scan.range_m[b], p.scan.range_m[b], 1e-4f);
      }
    }
    if (with_frame) {
      const RecordedFrame& rf = (*frames)[fi++];
      EXPECT_EQ(rf.scan_index, i);
      EXPECT_EQ(rf.frame.stamp_ns, rec.scan.stamp_ns);
      EXPECT_EQ(rf.frame.n_beams, 96);
      EXPECT_EQ(rf.frame.samples.size(), p.frame.samples.size());
      EXPECT_DOUBLE_EQ(rf.frame.window_length_m, p.frame.window_length_m);
    }
  }
  EXPECT_GT(hits, 1000);  // the pilings are in view

  const std::string meta = test::readFile(dir.path() / "meta.yaml");
  EXPECT_NE(meta.find("profile: eq41, rate_hz: 100"), std::string::npos) << meta;
  EXPECT_NE(meta.find("seed: 4"), std::string::npos);
  EXPECT_NE(meta.find("scene: {name: \"pilings\""), std::string::npos);
}

TEST(Survey, SameSeedSameFilesOtherSeedOtherNoise) {
  const auto w = pilingsWorld();
  vog::test::TempDir a("vog-sim-a"), b("vog-sim-b"), c("vog-sim-c");
  SurveyConfig cfg;
  cfg.seed = 11;
  cfg.frame_every = 5;
  const auto path = shortPath(w->scene());
  ASSERT_TRUE(runSurvey(*w, path, cfg, "p", a.path()).ok());
  ASSERT_TRUE(runSurvey(*w, path, cfg, "p", b.path()).ok());
  cfg.seed = 12;
  ASSERT_TRUE(runSurvey(*w, path, cfg, "p", c.path()).ok());
  for (const char* f :
       {"ground_truth.csv", "odometry.csv", "scans.csv", "frames.bin", "dvl.csv", "imu.csv", "depth.csv"}) {
    EXPECT_EQ(test::readFile(a.path() / f), test::readFile(b.path() / f)) << f;
  }
  EXPECT_EQ(test::readFile(a.path() / "ground_truth.csv"),
            test::readFile(c.path() / "ground_truth.csv"));  // truth does not depend on the seed
  for (const char* f : {"odometry.csv", "scans.csv", "frames.bin", "imu.csv"})
    EXPECT_NE(test::readFile(a.path() / f), test::readFile(c.path() / f)) << f;
}

TEST(Survey, BlockedWaypointsAreSkippedAndTheVehicleNeverCollides) {
  const auto w = pilingsWorld();
  vog::test::TempDir dir("vog-sim-blocked");
  // Straight through the piling at (-2.4, 0.15) and on to a free point.
  const std::vector<Waypoint> path = {{Eigen::Vector3d(0, 0.15, -1.5), 0.0}, {Eigen::Vector3d(-5, 1.0, -1.5), 0.0}};
  SurveyConfig cfg;
  cfg.frame_every = 0;
  auto sum = runSurvey(*w, path, cfg, "blocked", dir.path());
  ASSERT_TRUE(sum.ok()) << sum.error().message;
  EXPECT_EQ(sum->waypoints_skipped, 1);
  EXPECT_EQ(sum->waypoints_reached, 1);
  EXPECT_EQ(sum->n_frames, 0u);
  EXPECT_NE(test::readFile(dir.path() / "events.csv").find(",blocked,0,"), std::string::npos);
  // Every recorded true pose is collision-free.
  std::ifstream gt(dir.path() / "ground_truth.csv");
  std::string line;
  std::getline(gt, line);
  while (std::getline(gt, line)) {
    std::vector<double> v;
    std::stringstream ls(line);
    for (std::string f; std::getline(ls, f, ',');) v.push_back(std::stod(f));
    ASSERT_FALSE(
        w->boxCollides(geometry::poseFromXyzRpy(v[1], v[2], v[3], 0, 0, v[6]), Eigen::Vector3d(0.5, 0.5, 0.25)));
  }
}

TEST(Paths, LawnmowerAndOrbitStayInsideTheBox) {
  const auto w = pilingsWorld();
  const Scene& s = w->scene();
  for (const auto& wps : {lawnmowerPath(s, PathConfig{}), orbitPath(s, PathConfig{})}) {
    ASSERT_TRUE(wps.ok()) << wps.error().message;
    EXPECT_GT(wps->size(), 4u);
    EXPECT_EQ(wps->front().xyz_world, s.T_world_start.translation());
    for (const auto& p : *wps) EXPECT_TRUE(s.bounds_world.contains(p.xyz_world)) << p.xyz_world.transpose();
  }
  PathConfig low;
  low.z_m = -3.0;
  auto lw = lawnmowerPath(s, low);
  ASSERT_TRUE(lw.ok());
  for (std::size_t i = 1; i < lw->size(); ++i) EXPECT_EQ((*lw)[i].xyz_world.z(), -3.0);
  low.z_m = 1.0;  // above the box
  EXPECT_FALSE(orbitPath(s, low).ok());
  PathConfig big;
  big.orbit_radius_m = 50;
  EXPECT_FALSE(orbitPath(s, big).ok());
  big = PathConfig{};
  big.margin_m = 10;
  EXPECT_FALSE(lawnmowerPath(s, big).ok());
}

TEST(Paths, WaypointFileErrorsNameLineAndKey) {
  vog::test::TempDir dir("vog-sim-paths");
  std::ofstream(dir.path() / "ok.yaml") << "waypoints:\n  - {xyz: [1, 2, -3], yaw_deg: 90}\n  - {xyz: [0, 0, -1]}\n";
  auto ok = loadWaypointFile(dir.path() / "ok.yaml");
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  ASSERT_EQ(ok->size(), 2u);
  EXPECT_NEAR((*ok)[0].yaw_rad, M_PI / 2, 1e-12);
  std::ofstream(dir.path() / "bad.yaml") << "waypoints:\n  - {xyz: [1, 2, -3]}\n  - {xyz: [1, 2], yaw: 3}\n";
  auto bad = loadWaypointFile(dir.path() / "bad.yaml");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("bad.yaml:3: waypoints[1].yaw: unknown key"), std::string::npos)
      << bad.error().message;
  EXPECT_FALSE(loadWaypointFile(dir.path() / "missing.yaml").ok());
}

TEST(RecordFiles, CorruptFramesAndScansAreErrors) {
  vog::test::TempDir dir("vog-sim-corrupt");
  std::ofstream(dir.path() / "f.bin", std::ios::binary) << "VOGF\x01";
  EXPECT_FALSE(readFrames(dir.path() / "f.bin").ok());
  std::ofstream(dir.path() / "g.bin", std::ios::binary) << std::string(100, 'x');
  auto g = readFrames(dir.path() / "g.bin");
  ASSERT_FALSE(g.ok());
  EXPECT_NE(g.error().message.find("bad magic"), std::string::npos);
  std::ofstream(dir.path() / "s.csv") << "stamp_ns,scan_index,r0_m\n1,0,2.5\n2,1,nan\n";
  auto s = readScans(dir.path() / "s.csv");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("s.csv:3"), std::string::npos) << s.error().message;
}

TEST(Render, PlyRoundTrip) {
  vog::test::TempDir dir("vog-sim-ply");
  geometry::PointCloud c;
  c.points = {{1.25, -2.5, 3.125}, {0, 0, -4}};
  c.normals = {{0, 0, 1}, {1, 0, 0}};
  ASSERT_TRUE(writePly(dir.path() / "c.ply", c).ok());
  auto r = readPly(dir.path() / "c.ply");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->points, c.points);
  EXPECT_EQ(r->normals, c.normals);
}

// Decodes our PNG with zlib (an independent implementation): checks chunk CRCs and pixels.
TEST(Render, PngDecodesWithZlibToTheSamePixels) {
  RgbImage img(300, 260, 1, 2, 3);  // raw data > 65535 bytes: several stored blocks
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      img.set(x, y, static_cast<std::uint8_t>(x), static_cast<std::uint8_t>(y), static_cast<std::uint8_t>(x ^ y));
  const std::string png = encodePng(img);
  ASSERT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n"));
  std::size_t off = 8;
  std::string idat;
  std::vector<std::string> types;
  auto be32 = [&](std::size_t o) {
    return (static_cast<std::uint32_t>(static_cast<unsigned char>(png[o])) << 24) |
           (static_cast<std::uint32_t>(static_cast<unsigned char>(png[o + 1])) << 16) |
           (static_cast<std::uint32_t>(static_cast<unsigned char>(png[o + 2])) << 8) |
           static_cast<std::uint32_t>(static_cast<unsigned char>(png[o + 3]));
  };
  while (off < png.size()) {
    const std::uint32_t len = be32(off);
    const std::string type = png.substr(off + 4, 4);
    types.push_back(type);
    const auto crc = ::crc32(0L, reinterpret_cast<const Bytef*>(png.data() + off + 4), len + 4);
    EXPECT_EQ(crc, be32(off + 8 + len)) << type;
    if (type == "IHDR") {
      EXPECT_EQ(be32(off + 8), 300u);
      EXPECT_EQ(be32(off + 12), 260u);
    }
    if (type == "IDAT") idat += png.substr(off + 8, len);
    off += 12 + len;
  }
  EXPECT_EQ(types, (std::vector<std::string>{"IHDR", "IDAT", "IEND"}));
  std::vector<unsigned char> raw(260 * (1 + 3 * 300));
  uLongf raw_len = raw.size();
  ASSERT_EQ(uncompress(raw.data(), &raw_len, reinterpret_cast<const Bytef*>(idat.data()), idat.size()), Z_OK);
  ASSERT_EQ(raw_len, raw.size());
  for (int y = 0; y < 260; ++y) {
    ASSERT_EQ(raw[static_cast<std::size_t>(y) * 901], 0);  // filter None
    for (int x = 0; x < 300; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * 901 + 1 + 3 * static_cast<std::size_t>(x);
      ASSERT_EQ(raw[i], static_cast<unsigned char>(x));
      ASSERT_EQ(raw[i + 1], static_cast<unsigned char>(y));
      ASSERT_EQ(raw[i + 2], static_cast<unsigned char>(x ^ y));
    }
  }
}

}  // namespace
}  // namespace vog::sim
