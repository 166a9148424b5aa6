// Journal and record-file framing: every record type round-trips bit for bit; a torn last record (the
// file cut at every byte of it, or its payload damaged) is detected, reported and discarded with the
// earlier records intact, and appending afterwards works; damage anywhere before the last record is an
// error naming the byte offset and changes nothing; payloads that do not decode are errors, never
// misread.
#include "journal_fixture.hpp"
#include "test_support.hpp"
#include "vog/mission/journal.hpp"

#include <gtest/gtest.h>

#include <string>

namespace vog::mission {
namespace {

using testing::readBytes;
using testing::same;
using testing::sampleRecords;
using testing::writeBytes;

std::filesystem::path writeJournal(const std::filesystem::path& path, const std::vector<JournalRecord>& records) {
  auto journal = Journal::open(path);
  EXPECT_TRUE(journal.ok()) << journal.error().message;
  for (const JournalRecord& r : records) EXPECT_TRUE(journal.value()->append(r).ok());
  EXPECT_TRUE(journal.value()->sync().ok());
  return path;
}

void expectPrefix(const JournalContents& got, const std::vector<JournalRecord>& want, std::size_t n) {
  ASSERT_EQ(got.entries.size(), n);
  for (std::size_t i = 0; i < n; ++i) EXPECT_TRUE(same(got.entries[i].record, want[i])) << "record " << i;
}

TEST(Journal, EveryRecordTypeRoundTripsBitForBit) {
  test::TempDir dir;
  const auto records = sampleRecords(7);
  writeJournal(dir.path() / "j", records);
  auto got = readJournal(dir.path() / "j");
  ASSERT_TRUE(got.ok()) << got.error().message;
  EXPECT_FALSE(got->tail.torn);
  expectPrefix(got.value(), records, records.size());
  // Reopening for append reports the same records and leaves the file as it was.
  const auto before = readBytes(dir.path() / "j");
  JournalContents existing;
  auto journal = Journal::open(dir.path() / "j", &existing);
  ASSERT_TRUE(journal.ok());
  expectPrefix(existing, records, records.size());
  EXPECT_EQ(readBytes(dir.path() / "j"), before);
}

TEST(Journal, TornLastRecordIsDiscardedAtEveryCutAndAppendingResumes) {
  test::TempDir dir;
  auto records = sampleRecords(11);
  const JournalRecord last = records[5];  // a rank-3 loop closure: the longest payload
  records.resize(5);
  records.push_back(last);
  const auto path = writeJournal(dir.path() / "full", records);
  const auto full = readBytes(path);
  auto parsed = readJournal(path);
  ASSERT_TRUE(parsed.ok());
  const std::uint64_t last_offset = parsed->entries.back().offset;
  ASSERT_GT(full.size() - last_offset, 100U);

  for (std::size_t cut = last_offset + 1; cut < full.size(); ++cut) {
    SCOPED_TRACE("cut at byte " + std::to_string(cut));
    const auto torn_path = dir.path() / "torn";
    writeBytes(torn_path, std::vector<std::uint8_t>(full.begin(), full.begin() + static_cast<std::ptrdiff_t>(cut)));
    auto got = readJournal(torn_path);
    ASSERT_TRUE(got.ok()) << got.error().message;
    EXPECT_TRUE(got->tail.torn);
    EXPECT_EQ(got->tail.offset, last_offset);
    EXPECT_EQ(got->tail.discarded_bytes, cut - last_offset);
    expectPrefix(got.value(), records, records.size() - 1);

    // The appending side reports the same, truncates and appends after the last good record (checked
    // on a sample of the cuts: each costs two fsyncs).
    if (cut > last_offset + 12 && cut % 16 != 0) continue;
    JournalContents existing;
    auto journal = Journal::open(torn_path, &existing);
    ASSERT_TRUE(journal.ok()) << journal.error().message;
    EXPECT_TRUE(existing.tail.torn);
    EXPECT_EQ(std::filesystem::file_size(torn_path), last_offset);
    ASSERT_TRUE(journal.value()->append(last).ok());
    ASSERT_TRUE(journal.value()->sync().ok());
    journal.value().reset();
    EXPECT_EQ(readBytes(torn_path), full);
  }
}

TEST(Journal, DamagedOrZeroFilledLastRecordIsATornTail) {
  test::TempDir dir;
  const auto records = sampleRecords(3);
  const auto path = writeJournal(dir.path() / "j", records);
  const auto full = readBytes(path);
  auto parsed = readJournal(path);
  ASSERT_TRUE(parsed.ok());
  const std::uint64_t last_offset = parsed->entries.back().offset;
  for (std::size_t byte = last_offset; byte < full.size(); ++byte) {
    auto damaged = full;
    damaged[byte] ^= 0x10;
    writeBytes(path, damaged);
    auto got = readJournal(path);
    ASSERT_TRUE(got.ok()) << "flip at " << byte << ": " << got.error().message;
    EXPECT_TRUE(got->tail.torn);
    expectPrefix(got.value(), records, records.size() - 1);
  }
  // A file system that extended the file with zeros after a crash.
  auto zeros = full;
  zeros.resize(full.size() + 4096, 0);
  writeBytes(path, zeros);
  auto got = readJournal(path);
  ASSERT_TRUE(got.ok());
  EXPECT_TRUE(got->tail.torn);
  EXPECT_EQ(got->tail.offset, full.size());
  expectPrefix(got.value(), records, records.size());
}

TEST(Journal, DamageBeforeTheLastRecordIsAnErrorNamingTheOffsetAndChangesNothing) {
  test::TempDir dir;
  const auto records = sampleRecords(5);
  const auto path = writeJournal(dir.path() / "j", records);
  const auto full = readBytes(path);
  auto parsed = readJournal(path);
  ASSERT_TRUE(parsed.ok());
  for (std::size_t k = 0; k + 1 < parsed->entries.size(); ++k) {
    const std::uint64_t offset = parsed->entries[k].offset;
    // A bit in the length, in the CRC and in the payload of record k.
    for (std::uint64_t byte : {offset + 1, offset + 5, offset + 8, parsed->entries[k + 1].offset - 1}) {
      SCOPED_TRACE("record " + std::to_string(k) + ", byte " + std::to_string(byte));
      auto damaged = full;
      damaged[byte] ^= 0x04;
      writeBytes(path, damaged);
      auto got = readJournal(path);
      ASSERT_FALSE(got.ok());
      EXPECT_NE(got.error().message.find("corrupt record at byte offset " + std::to_string(offset) + " "),
                std::string::npos)
          << got.error().message;
      auto journal = Journal::open(path);
      ASSERT_FALSE(journal.ok());
      EXPECT_EQ(readBytes(path), damaged);
    }
  }
}

TEST(Journal, UnknownRecordTypeIsAnErrorNamingTheOffset) {
  test::TempDir dir;
  const auto records = sampleRecords(9);
  const auto path = writeJournal(dir.path() / "j", records);
  auto bytes = readBytes(path);
  const std::uint64_t offset = bytes.size();
  const std::vector<std::uint8_t> payload = {0x42, 1, 2, 3};
  const auto frame = encodeFrame(payload);
  bytes.insert(bytes.end(), frame.begin(), frame.end());
  writeBytes(path, bytes);
  auto got = readJournal(path);
  ASSERT_FALSE(got.ok());
  EXPECT_NE(got.error().message.find("byte offset " + std::to_string(offset) + ": unknown record type 66"),
            std::string::npos)
      << got.error().message;
  EXPECT_FALSE(Journal::open(path).ok());
}

TEST(Journal, MalformedPayloadsAreErrorsNeverMisread) {
  for (const JournalRecord& r : sampleRecords(13)) {
    const auto payload = encodeRecord(r);
    for (std::size_t n = 0; n < payload.size(); ++n) {
      auto got = decodeRecord(std::span<const std::uint8_t>(payload.data(), n));
      EXPECT_FALSE(got.ok()) << "type " << int(payload[0]) << " cut to " << n << " bytes";
    }
    auto longer = payload;
    longer.push_back(0);
    auto got = decodeRecord(longer);
    ASSERT_FALSE(got.ok());
    EXPECT_NE(got.error().message.find("trailing"), std::string::npos) << got.error().message;
  }
  // Out-of-range enums and non-finite values.
  auto state = encodeRecord(MissionStateRecord{5, MissionState::kIdle});
  state.back() = 6;  // near_home, the last state
  ASSERT_TRUE(decodeRecord(state).ok());
  EXPECT_EQ(std::get<MissionStateRecord>(decodeRecord(state).value()).state, MissionState::kNearHome);
  state.back() = 7;
  auto s = decodeRecord(state);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("state 7"), std::string::npos) << s.error().message;
  auto waypoint = encodeRecord(WaypointRecord{1, 0.0, std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0});
  EXPECT_FALSE(decodeRecord(waypoint).ok());
  std::mt19937_64 rng(1);
  auto closure = testing::sampleClosure(0, 1, 2, rng);
  auto bytes = encodeRecord(closure);
  bytes[1 + 8 + 8 + 12 * 8 + 12 * 8 + 6 * 8] = 9;  // rank
  auto c = decodeRecord(bytes);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().message.find("rank 9"), std::string::npos) << c.error().message;
  // A sensor origin count that does not match the bytes that follow it.
  auto submap = encodeRecord(testing::sampleSubmap(1, rng));
  submap.resize(submap.size() - 8);
  auto m = decodeRecord(submap);
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().message.find("3 sensor origins need 72 bytes, 64 remain"), std::string::npos)
      << m.error().message;
  auto nan_origin = testing::sampleSubmap(1, rng);
  nan_origin.sensor_origins[2].y() = std::numeric_limits<double>::quiet_NaN();
  auto n = decodeRecord(encodeRecord(nan_origin));
  ASSERT_FALSE(n.ok());
  EXPECT_NE(n.error().message.find("sensor_origins is not finite"), std::string::npos) << n.error().message;
}

// Journals written before the sensor origins were recorded (type 1: the same fields without them) are
// read, with no origins.
TEST(Journal, SubmapRecordWithoutSensorOriginsIsRead) {
  std::mt19937_64 rng(3);
  SubmapClosedRecord want = testing::sampleSubmap(1, rng);
  ASSERT_FALSE(want.sensor_origins.empty());
  auto payload = encodeRecord(want);
  ASSERT_EQ(payload[0], static_cast<std::uint8_t>(RecordType::kSubmapClosed));
  payload.resize(payload.size() - 4 - 24 * want.sensor_origins.size());  // count and origins
  payload[0] = static_cast<std::uint8_t>(RecordType::kSubmapClosedWithoutOrigins);
  auto got = decodeRecord(payload);
  ASSERT_TRUE(got.ok()) << got.error().message;
  want.sensor_origins.clear();
  EXPECT_TRUE(same(got.value(), JournalRecord{want}));
  payload.push_back(0);
  EXPECT_FALSE(decodeRecord(payload).ok());
}

}  // namespace
}  // namespace vog::mission
