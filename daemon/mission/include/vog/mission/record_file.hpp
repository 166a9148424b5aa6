#pragma once
// Append-only record files: the framing shared by the mission journal and the raw device log.
//
// A file is a sequence of frames, nothing else (no file header):
//   [u32 payload length, little-endian, 1 .. kMaxRecordPayloadBytes]
//   [u32 CRC-32C of the payload, little-endian]
//   [payload]
// Reading walks the frames in order. At the first frame that is not valid (length out of range or past
// the end of the file, or CRC mismatch) the rest of the file is searched for any valid frame:
//  - none: a torn tail (a crash during an unsynced append); it is reported (byte offset, bytes) and
//    discarded, and a writer truncates the file back to the last good frame before appending;
//  - one: corruption in the middle of the file, an error naming the byte offset of the bad frame and
//    of the valid one after it. Nothing is misread and nothing is truncated.
// A zero-filled tail (a file system that extended the file but lost the data) reads as torn: a length
// of 0 is never valid.
#include "vog/core/atomic_file.hpp"
#include "vog/core/result.hpp"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace vog::mission {

inline constexpr std::uint32_t kMaxRecordPayloadBytes = 16U << 20;
inline constexpr std::size_t kFrameHeaderBytes = 8;

struct FramedRecord {
  std::uint64_t offset = 0;  // byte offset of the frame header in the file
  std::vector<std::uint8_t> payload;
};

struct TailRecovery {
  bool torn = false;
  std::uint64_t offset = 0;  // where the discarded tail began
  std::uint64_t discarded_bytes = 0;
};

struct RecordScan {
  std::vector<FramedRecord> records;
  TailRecovery tail;
  std::uint64_t good_end = 0;  // byte offset just after the last good frame
};

// Frames `bytes` (a whole file's content). `what` names the file in errors.
Result<RecordScan> scanRecords(std::span<const std::uint8_t> bytes, const std::string& what);
// Reads and frames a file without changing it (a missing file is an error).
Result<RecordScan> readRecordFile(const std::filesystem::path& path);
// Encodes one frame (header + payload), as RecordWriter appends it.
std::vector<std::uint8_t> encodeFrame(std::span<const std::uint8_t> payload);

// Appends frames to one file.
// Lifecycle: open() creates the file (and fsyncs its directory) or reads the existing frames, truncates
// a torn tail and positions at the end; append() buffers (64 KiB), sync() writes the buffer and fsyncs;
// the destructor writes the buffer without fsync. Every write(2) and fsync is checked. Invariants: the
// file always holds whole frames up to the last sync(); after a failed write (e.g. a full disk) the
// writer refuses further appends until rollback() to a frame boundary, which drops what came after it
// from the buffer and the file, so that the same frames can be written again. Not thread-safe: the
// owner serialises calls.
class RecordWriter {
 public:
  // `existing` (optional) receives the frames already in the file and what recovery did.
  static Result<std::unique_ptr<RecordWriter>> open(const std::filesystem::path& path, RecordScan* existing = nullptr);
  ~RecordWriter();
  RecordWriter(const RecordWriter&) = delete;
  RecordWriter& operator=(const RecordWriter&) = delete;

  Status append(std::span<const std::uint8_t> payload);
  Status sync();
  // Writes the buffer, then cuts the file to `size_bytes` (which the caller knows to be a frame
  // boundary, e.g. FramedRecord::offset) and fsyncs. Used to drop an uncommitted group of records on resume.
  Status truncate(std::uint64_t size_bytes);
  // Forgets every frame after `size_bytes` (a frame boundary, e.g. an earlier sizeBytes()) whether it is
  // buffered or already in the file, and clears an earlier write failure. Needs no free space.
  Status rollback(std::uint64_t size_bytes);
  std::uint64_t sizeBytes() const { return size_bytes_; }  // including buffered frames
  const std::filesystem::path& path() const { return path_; }

 private:
  static constexpr std::size_t kBufferBytes = 64 * 1024;
  RecordWriter(std::filesystem::path path, int fd, std::uint64_t size_bytes)
      : path_(std::move(path)), fd_(fd), size_bytes_(size_bytes), file_bytes_(size_bytes) {}
  Status fail(const std::string& what);
  Status writeBuffer(std::size_t bytes);  // the first `bytes` of buffer_

  std::filesystem::path path_;
  int fd_;                            // opened O_APPEND
  std::uint64_t size_bytes_;          // file_bytes_ + buffer_.size()
  std::uint64_t file_bytes_;          // bytes written to the file
  std::vector<std::uint8_t> buffer_;  // the frames after file_bytes_
  std::optional<Error> failed_;
};

}  // namespace vog::mission
