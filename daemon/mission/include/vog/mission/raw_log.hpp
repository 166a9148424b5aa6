#pragma once
// Raw device log: every byte a device driver received, with the device and a timestamp, so that a
// mission can be replayed offline from exactly what the drivers saw. Payload: [u8 type = 0x80]
// [u16 device_id][i64 stamp_ns][the device's bytes], little-endian (daemon/mission/README.md).
//
// Segments: for the log `raw.vogr` the records go to record files (record_file.hpp framing, CRC-32C per
// record) `raw.000000.vogr`, `raw.000001.vogr`, ... next to it, read in index order. A segment ends
// (synced) when it reaches max_bytes / 16, and at every open(), so that a torn tail can only end a
// segment. When the segments together exceed max_bytes, the oldest are deleted, so the log stays
// within max_bytes plus one segment. A log written before segments (the single file `raw.vogr`) is read
// as the oldest segment, and dropped first.
#include "vog/core/result.hpp"
#include "vog/mission/record_file.hpp"

#include <cstdint>
#include <deque>
#include <filesystem>
#include <memory>
#include <span>
#include <vector>

namespace vog::mission {

inline constexpr std::uint8_t kRawRecordType = 0x80;
inline constexpr std::uint64_t kMinRawLogBytes = 64 * 1024;
inline constexpr std::uint64_t kDefaultRawLogBytes = std::uint64_t{2} << 30;

struct RawRecord {
  std::uint16_t device_id = 0;
  std::int64_t stamp_ns = 0;
  std::vector<std::uint8_t> bytes;
};

struct RawLogContents {
  std::vector<RawRecord> records;
  TailRecovery tail;                   // a torn last record (of the last segment with one), discarded
  std::size_t segments = 0;            // segment files read (the single file of an older log counts as one)
  std::uint64_t dropped_segments = 0;  // oldest segments deleted while recording (the first index kept)
};

// Reads a raw log without changing it; corruption in the middle of a segment or a malformed record
// names its file and offset.
Result<RawLogContents> readRawLog(const std::filesystem::path& path);

// Lifecycle: open() lists the segments there are and starts a new one; append() buffers and may end
// the segment, start the next and delete the oldest; sync() makes everything appended durable.
// Invariant: the segments kept hold at most max_bytes plus the segment being written. Not
// thread-safe: drivers hand their bytes to one owner.
class RawLog {
 public:
  // Needs max_bytes >= kMinRawLogBytes.
  static Result<std::unique_ptr<RawLog>> open(const std::filesystem::path& path,
                                              std::uint64_t max_bytes = kDefaultRawLogBytes);
  // Empty chunks are allowed (a device event without data); at most kMaxRecordPayloadBytes - 11 bytes.
  Status append(std::uint16_t device_id, std::int64_t stamp_ns, std::span<const std::uint8_t> bytes);
  Status sync() { return writer_->sync(); }
  std::uint64_t sizeBytes() const;                                     // every segment kept
  std::uint64_t segmentIndex() const { return index_; }                // the segment being written
  std::uint64_t droppedSegments() const { return dropped_segments_; }  // deleted since open()
  std::uint64_t droppedBytes() const { return dropped_bytes_; }

  static std::filesystem::path segmentPath(const std::filesystem::path& path, std::uint64_t index);

 private:
  struct Segment {
    std::filesystem::path path;
    std::uint64_t bytes = 0;
  };
  RawLog(std::filesystem::path path, std::uint64_t max_bytes, std::deque<Segment> closed)
      : path_(std::move(path)), max_bytes_(max_bytes), closed_(std::move(closed)) {}
  // Ends the current segment (synced) and starts segment `index`, then drops the oldest over the cap.
  Status startSegment(std::uint64_t index);

  const std::filesystem::path path_;
  const std::uint64_t max_bytes_;
  std::deque<Segment> closed_;  // finished segments, oldest first
  std::unique_ptr<RecordWriter> writer_;
  std::uint64_t index_ = 0;
  std::uint64_t dropped_segments_ = 0;
  std::uint64_t dropped_bytes_ = 0;
};

}  // namespace vog::mission
