#pragma once
// Raw device log: every byte a device driver received, with the device and a timestamp, in a record file
// (record_file.hpp framing, CRC-32C per record), one file per mission, so that a mission can be
// replayed offline from exactly what the drivers saw. Payload: [u8 type = 0x80][u16 device_id]
// [i64 stamp_ns][the device's bytes], little-endian (daemon/mission/README.md).
#include "vog/core/result.hpp"
#include "vog/mission/record_file.hpp"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <vector>

namespace vog::mission {

inline constexpr std::uint8_t kRawRecordType = 0x80;

struct RawRecord {
  std::uint16_t device_id = 0;
  std::int64_t stamp_ns = 0;
  std::vector<std::uint8_t> bytes;
};

struct RawLogContents {
  std::vector<RawRecord> records;
  TailRecovery tail;  // a torn last record, discarded
};

// Reads a raw log without changing it; corruption in the middle or a malformed record names its offset.
Result<RawLogContents> readRawLog(const std::filesystem::path& path);

// Lifecycle: open() creates or reopens (truncating a torn tail) the log; append() buffers; sync()
// makes everything appended durable. Not thread-safe: drivers hand their bytes to one owner.
class RawLog {
 public:
  static Result<std::unique_ptr<RawLog>> open(const std::filesystem::path& path, RawLogContents* existing = nullptr);
  // Empty chunks are allowed (a device event without data); at most kMaxRecordPayloadBytes - 11 bytes.
  Status append(std::uint16_t device_id, std::int64_t stamp_ns, std::span<const std::uint8_t> bytes);
  Status sync() { return writer_->sync(); }
  std::uint64_t sizeBytes() const { return writer_->sizeBytes(); }

 private:
  explicit RawLog(std::unique_ptr<RecordWriter> writer) : writer_(std::move(writer)) {}
  std::unique_ptr<RecordWriter> writer_;
};

}  // namespace vog::mission
