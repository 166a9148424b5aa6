// vog::codec's PNG encoder, read back by an independent decoder (zlib's CRC-32 and inflate).
#include "vog/codec/png.hpp"

#include "readers.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <random>

namespace vog::codec {
namespace {

using client::test::decodePng;

RgbImage randomImage(int w, int h, std::uint64_t seed) {
  RgbImage img(w, h, 0, 0, 0);
  std::mt19937_64 rng(seed);
  for (auto& v : img.rgb) v = static_cast<std::uint8_t>(rng() & 0xFFu);
  return img;
}

TEST(Png, DecodesIndependentlyToTheSameScanlines) {
  // Odd sizes (no row alignment to rely on); random pixels do not compress, a flat image does.
  for (const auto& [w, h, seed] : {std::tuple{37, 23, 1u}, std::tuple{1, 1, 2u}, std::tuple{301, 257, 3u}}) {
    const RgbImage img = randomImage(w, h, seed);
    auto png = toPng(img);
    ASSERT_TRUE(png.ok()) << png.error().message;
    const auto d = decodePng(*png);
    ASSERT_EQ(d.error, "") << w << "x" << h;
    EXPECT_EQ(d.width, static_cast<std::uint32_t>(w));
    EXPECT_EQ(d.height, static_cast<std::uint32_t>(h));
    EXPECT_EQ(d.chunk_types, (std::vector<std::string>{"IHDR", "IDAT", "IEND"}));
    // The inflated data is exactly the filter-0 scanlines of the image.
    std::string expected;
    for (int y = 0; y < h; ++y) {
      expected.push_back('\0');
      expected.append(reinterpret_cast<const char*>(img.rgb.data()) + 3 * static_cast<std::size_t>(y * w),
                      3 * static_cast<std::size_t>(w));
    }
    EXPECT_EQ(d.scanlines, expected);
  }
  // A uniform image deflates to a small fraction of its raw size.
  const RgbImage flat(500, 400, 20, 20, 28);
  auto png = toPng(flat);
  ASSERT_TRUE(png.ok());
  EXPECT_LT(png->size(), 500u * 400u * 3u / 50u);
  const auto d = decodePng(*png);
  ASSERT_EQ(d.error, "");
  EXPECT_EQ(d.at(499, 399), (std::array<std::uint8_t, 3>{20, 20, 28}));
}

TEST(Png, ACorruptedByteIsCaughtByTheChunkCrc) {
  // Guards the decoder itself: a check that cannot fail would pass anything.
  auto png = toPng(randomImage(8, 8, 4));
  ASSERT_TRUE(png.ok());
  std::string bad = *png;
  bad[8 + 8 + 2] ^= 0x01;  // inside IHDR's width
  EXPECT_EQ(decodePng(bad).error, "bad CRC in IHDR");
}

TEST(Png, MalformedImageIsAnErrorNamingTheSizes) {
  RgbImage img(4, 3, 1, 2, 3);
  img.rgb.pop_back();
  auto png = toPng(img);
  ASSERT_FALSE(png.ok());
  EXPECT_NE(png.error().message.find("35 bytes"), std::string::npos) << png.error().message;
  EXPECT_NE(png.error().message.find("needs 36"), std::string::npos) << png.error().message;
  img.width = 0;
  EXPECT_FALSE(toPng(img).ok());
}

TEST(Png, WritePngWritesTheEncodedBytesAndReportsAnUnwritablePath) {
  const vog::test::TempDir dir("vog-png");
  const RgbImage img = randomImage(13, 7, 5);
  ASSERT_TRUE(writePng(dir.path() / "a.png", img).ok());
  EXPECT_EQ(client::test::readFile((dir.path() / "a.png").string()), toPng(img).value());
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "a.png.tmp"));
  const Status bad = writePng(dir.path() / "missing-dir" / "b.png", img);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("missing-dir"), std::string::npos) << bad.error().message;
}

}  // namespace
}  // namespace vog::codec
