// Raw device log: records round-trip (device, stamp, bytes, including empty chunks and every byte value);
// a torn last record is discarded and the log appends after it; a record of another type is an error
// naming its offset.
#include "journal_fixture.hpp"
#include "test_support.hpp"
#include "vog/mission/raw_log.hpp"

#include <gtest/gtest.h>

namespace vog::mission {
namespace {

std::vector<RawRecord> sampleChunks() {
  std::mt19937_64 rng(3);
  std::vector<RawRecord> out;
  for (int i = 0; i < 50; ++i) {
    RawRecord r;
    r.device_id = static_cast<std::uint16_t>(i % 5 == 0 ? 0xFFFF : i % 5);
    r.stamp_ns = -5 + static_cast<std::int64_t>(i) * 1'234'567;
    r.bytes.resize(static_cast<std::size_t>(i % 7 == 0 ? 0 : rng() % 300));
    for (auto& b : r.bytes) b = static_cast<std::uint8_t>(rng());
    out.push_back(std::move(r));
  }
  return out;
}

void expectChunks(const RawLogContents& got, const std::vector<RawRecord>& want, std::size_t n) {
  ASSERT_EQ(got.records.size(), n);
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_EQ(got.records[i].device_id, want[i].device_id) << i;
    EXPECT_EQ(got.records[i].stamp_ns, want[i].stamp_ns) << i;
    EXPECT_EQ(got.records[i].bytes, want[i].bytes) << i;
  }
}

TEST(RawLog, RoundTripTornTailAndAppend) {
  test::TempDir dir;
  const auto path = dir.path() / "raw.vogr";
  const auto chunks = sampleChunks();
  {
    auto log = RawLog::open(path);
    ASSERT_TRUE(log.ok()) << log.error().message;
    for (const RawRecord& r : chunks) ASSERT_TRUE(log.value()->append(r.device_id, r.stamp_ns, r.bytes).ok());
    ASSERT_TRUE(log.value()->sync().ok());
  }
  auto got = readRawLog(path);
  ASSERT_TRUE(got.ok()) << got.error().message;
  EXPECT_FALSE(got->tail.torn);
  expectChunks(got.value(), chunks, chunks.size());

  // Cut inside the last record: the first 49 survive, and reopening appends after them.
  const auto full = testing::readBytes(path);
  const std::size_t last_size = 8 + 11 + chunks.back().bytes.size();
  testing::writeBytes(path,
                      std::vector<std::uint8_t>(full.begin(), full.end() - static_cast<std::ptrdiff_t>(last_size / 2)));
  RawLogContents existing;
  auto log = RawLog::open(path, &existing);
  ASSERT_TRUE(log.ok()) << log.error().message;
  EXPECT_TRUE(existing.tail.torn);
  EXPECT_EQ(existing.tail.offset, full.size() - last_size);
  expectChunks(existing, chunks, chunks.size() - 1);
  ASSERT_TRUE(log.value()->append(chunks.back().device_id, chunks.back().stamp_ns, chunks.back().bytes).ok());
  ASSERT_TRUE(log.value()->sync().ok());
  log.value().reset();
  EXPECT_EQ(testing::readBytes(path), full);
}

TEST(RawLog, ForeignRecordIsAnErrorNamingTheOffset) {
  test::TempDir dir;
  const auto path = dir.path() / "raw.vogr";
  {
    auto log = RawLog::open(path);
    ASSERT_TRUE(log.ok());
    ASSERT_TRUE(log.value()->append(1, 2, std::vector<std::uint8_t>{1, 2, 3}).ok());
  }
  auto bytes = testing::readBytes(path);
  const std::size_t offset = bytes.size();
  const auto frame = encodeFrame(encodeRecord(WaypointRecord{}));  // a journal record in the raw log
  bytes.insert(bytes.end(), frame.begin(), frame.end());
  testing::writeBytes(path, bytes);
  auto got = readRawLog(path);
  ASSERT_FALSE(got.ok());
  EXPECT_NE(got.error().message.find("byte offset " + std::to_string(offset) + ": unknown record type 4"),
            std::string::npos)
      << got.error().message;
}

}  // namespace
}  // namespace vog::mission
