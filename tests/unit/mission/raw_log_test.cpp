// Raw device log: records round-trip (device, stamp, bytes, including empty chunks and every byte value);
// a torn last record is discarded and the log goes on in a new segment; the cap drops the oldest
// segments; an older single-file log is read first; a record of another type is an error naming its
// offset.
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

  // Cut inside the last record: the first 49 survive, and reopening starts a new segment after them.
  const auto segment0 = RawLog::segmentPath(path, 0);
  const auto full = testing::readBytes(segment0);
  const std::size_t last_size = 8 + 11 + chunks.back().bytes.size();
  testing::writeBytes(segment0,
                      std::vector<std::uint8_t>(full.begin(), full.end() - static_cast<std::ptrdiff_t>(last_size / 2)));
  auto torn = readRawLog(path);
  ASSERT_TRUE(torn.ok()) << torn.error().message;
  EXPECT_TRUE(torn->tail.torn);
  EXPECT_EQ(torn->tail.offset, full.size() - last_size);
  expectChunks(torn.value(), chunks, chunks.size() - 1);
  {
    auto log = RawLog::open(path);
    ASSERT_TRUE(log.ok()) << log.error().message;
    EXPECT_EQ(log.value()->segmentIndex(), 1u);
    ASSERT_TRUE(log.value()->append(chunks.back().device_id, chunks.back().stamp_ns, chunks.back().bytes).ok());
    ASSERT_TRUE(log.value()->sync().ok());
  }
  auto again = readRawLog(path);
  ASSERT_TRUE(again.ok()) << again.error().message;
  EXPECT_EQ(again->segments, 2u);
  expectChunks(again.value(), chunks, chunks.size());
}

// With a cap of 64 KiB (segments of 4 KiB) and 300 kB recorded: the oldest segments are deleted, the
// files left hold at most the cap plus one segment, and what is left reads back as the newest records
// in order, saying how many segments were dropped.
TEST(RawLog, CapDropsTheOldestSegments) {
  test::TempDir dir;
  const auto path = dir.path() / "raw.vogr";
  constexpr std::uint64_t kCap = 64 * 1024;
  const std::vector<std::uint8_t> chunk(300, 0xA5);
  constexpr int kRecords = 1000;
  {
    auto log = RawLog::open(path, kCap);
    ASSERT_TRUE(log.ok()) << log.error().message;
    for (int i = 0; i < kRecords; ++i) {
      ASSERT_TRUE(log.value()->append(3, i, chunk).ok());
      ASSERT_LE(log.value()->sizeBytes(), kCap + kCap / 16 + 8 + 11 + chunk.size()) << i;
    }
    ASSERT_TRUE(log.value()->sync().ok());
    EXPECT_GT(log.value()->droppedSegments(), 0u);
    EXPECT_GT(log.value()->droppedBytes(), 200'000u);
  }
  std::uint64_t on_disk = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir.path())) on_disk += e.file_size();
  EXPECT_LE(on_disk, kCap + kCap / 16 + 8 + 11 + chunk.size());
  EXPECT_GE(on_disk, kCap / 2);
  auto got = readRawLog(path);
  ASSERT_TRUE(got.ok()) << got.error().message;
  EXPECT_GT(got->dropped_segments, 0u);
  ASSERT_FALSE(got->records.empty());
  EXPECT_EQ(got->records.back().stamp_ns, kRecords - 1);
  for (std::size_t i = 1; i < got->records.size(); ++i)
    ASSERT_EQ(got->records[i].stamp_ns, got->records[i - 1].stamp_ns + 1) << "not the newest records in order";
  EXPECT_GT(got->records.front().stamp_ns, 0);
}

// A log written as one file before segments is read first, and new records follow it in segments.
TEST(RawLog, AnOlderSingleFileLogIsTheOldestSegment) {
  test::TempDir dir;
  const auto path = dir.path() / "raw.vogr";
  const auto chunks = sampleChunks();
  {
    auto writer = RecordWriter::open(path);
    ASSERT_TRUE(writer.ok());
    for (std::size_t i = 0; i < 25; ++i) {
      std::vector<std::uint8_t> payload = {kRawRecordType, static_cast<std::uint8_t>(chunks[i].device_id & 0xFF),
                                           static_cast<std::uint8_t>(chunks[i].device_id >> 8)};
      for (int b = 0; b < 8; ++b)
        payload.push_back(static_cast<std::uint8_t>(static_cast<std::uint64_t>(chunks[i].stamp_ns) >> (8 * b)));
      payload.insert(payload.end(), chunks[i].bytes.begin(), chunks[i].bytes.end());
      ASSERT_TRUE(writer.value()->append(payload).ok());
    }
    ASSERT_TRUE(writer.value()->sync().ok());
  }
  auto old = readRawLog(path);
  ASSERT_TRUE(old.ok()) << old.error().message;
  expectChunks(old.value(), chunks, 25);
  {
    auto log = RawLog::open(path);
    ASSERT_TRUE(log.ok()) << log.error().message;
    for (std::size_t i = 25; i < chunks.size(); ++i)
      ASSERT_TRUE(log.value()->append(chunks[i].device_id, chunks[i].stamp_ns, chunks[i].bytes).ok());
    ASSERT_TRUE(log.value()->sync().ok());
  }
  auto got = readRawLog(path);
  ASSERT_TRUE(got.ok()) << got.error().message;
  EXPECT_EQ(got->segments, 2u);
  EXPECT_EQ(got->dropped_segments, 0u);
  expectChunks(got.value(), chunks, chunks.size());
}

TEST(RawLog, ForeignRecordIsAnErrorNamingTheOffset) {
  test::TempDir dir;
  const auto path = dir.path() / "raw.vogr";
  {
    auto log = RawLog::open(path);
    ASSERT_TRUE(log.ok());
    ASSERT_TRUE(log.value()->append(1, 2, std::vector<std::uint8_t>{1, 2, 3}).ok());
  }
  const auto segment = RawLog::segmentPath(path, 0);
  auto bytes = testing::readBytes(segment);
  const std::size_t offset = bytes.size();
  const auto frame = encodeFrame(encodeRecord(WaypointRecord{}));  // a journal record in the raw log
  bytes.insert(bytes.end(), frame.begin(), frame.end());
  testing::writeBytes(segment, bytes);
  auto got = readRawLog(path);
  ASSERT_FALSE(got.ok());
  EXPECT_NE(got.error().message.find("byte offset " + std::to_string(offset) + ": unknown record type 4"),
            std::string::npos)
      << got.error().message;
}

}  // namespace
}  // namespace vog::mission
