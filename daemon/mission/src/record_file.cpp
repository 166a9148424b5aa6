#include "vog/mission/record_file.hpp"

#include "vog/core/bytes.hpp"
#include "vog/core/crc.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace vog::mission {
namespace {

// Payload length of a valid frame at `at`, or nullopt.
std::optional<std::uint32_t> validFrame(std::span<const std::uint8_t> b, std::size_t at) {
  if (b.size() - at < kFrameHeaderBytes) return std::nullopt;
  const std::uint32_t len = readU32LE(b, at);
  if (len == 0 || len > kMaxRecordPayloadBytes) return std::nullopt;
  if (b.size() - at - kFrameHeaderBytes < len) return std::nullopt;
  if (crc32c(b.subspan(at + kFrameHeaderBytes, len)) != readU32LE(b, at + 4)) return std::nullopt;
  return len;
}

Result<std::vector<std::uint8_t>> readAll(int fd, const std::filesystem::path& path) {
  struct stat st {};
  if (::fstat(fd, &st) != 0) return Error{"cannot stat " + path.string() + ": " + errnoText()};
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(st.st_size));
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::pread(fd, bytes.data() + done, bytes.size() - done, static_cast<off_t>(done));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return Error{"cannot read " + path.string() + ": " + errnoText()};
    if (n == 0) break;  // shrank meanwhile
    done += static_cast<std::size_t>(n);
  }
  bytes.resize(done);
  return bytes;
}

}  // namespace

Result<RecordScan> scanRecords(std::span<const std::uint8_t> bytes, const std::string& what) {
  RecordScan scan;
  std::size_t pos = 0;
  while (pos < bytes.size()) {
    if (auto len = validFrame(bytes, pos)) {
      FramedRecord r;
      r.offset = pos;
      const auto payload = bytes.subspan(pos + kFrameHeaderBytes, *len);
      r.payload.assign(payload.begin(), payload.end());
      scan.records.push_back(std::move(r));
      pos += kFrameHeaderBytes + *len;
      continue;
    }
    for (std::size_t p = pos + 1; p + kFrameHeaderBytes < bytes.size(); ++p) {
      if (validFrame(bytes, p)) {
        return Error{what + ": corrupt record at byte offset " + std::to_string(pos) +
                     " (not a torn tail: a valid record follows at byte offset " + std::to_string(p) + ")"};
      }
    }
    scan.tail.torn = true;
    scan.tail.offset = pos;
    scan.tail.discarded_bytes = bytes.size() - pos;
    break;
  }
  scan.good_end = pos;
  return scan;
}

Result<RecordScan> readRecordFile(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Error{"cannot open " + path.string() + ": " + errnoText()};
  auto bytes = readAll(fd, path);
  ::close(fd);
  if (!bytes) return bytes.error();
  return scanRecords(bytes.value(), path.string());
}

std::vector<std::uint8_t> encodeFrame(std::span<const std::uint8_t> payload) {
  std::vector<std::uint8_t> out;
  out.reserve(kFrameHeaderBytes + payload.size());
  const auto len = static_cast<std::uint32_t>(payload.size());
  const std::uint32_t crc = crc32c(payload);
  ByteWriter w(out);
  w.u32(len);
  w.u32(crc);
  w.bytes(payload);
  return out;
}

Result<std::unique_ptr<RecordWriter>> RecordWriter::open(const std::filesystem::path& path, RecordScan* existing) {
  std::error_code ec;
  const bool existed = std::filesystem::exists(path, ec);
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd < 0) return Error{"cannot open " + path.string() + " for appending: " + errnoText()};
  auto close_with = [fd](Error e) -> Error {
    ::close(fd);
    return e;
  };
  auto bytes = readAll(fd, path);
  if (!bytes) return close_with(bytes.error());
  auto scan = scanRecords(bytes.value(), path.string());
  if (!scan) return close_with(scan.error());
  if (scan->tail.torn) {
    if (::ftruncate(fd, static_cast<off_t>(scan->good_end)) != 0 || ::fsync(fd) != 0) {
      return close_with(Error{"cannot truncate the torn tail of " + path.string() + " at byte offset " +
                              std::to_string(scan->good_end) + ": " + errnoText()});
    }
  }
  if (!existed) {
    const std::filesystem::path parent = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
    if (Status s = syncDirectory(parent); !s.ok()) return close_with(s.error());
  }
  const std::uint64_t good_end = scan->good_end;
  if (existing != nullptr) *existing = std::move(scan.value());
  return std::unique_ptr<RecordWriter>(new RecordWriter(path, fd, good_end));
}

RecordWriter::~RecordWriter() {
  if (!failed_) (void)writeBuffer(buffer_.size());
  ::close(fd_);
}

Status RecordWriter::fail(const std::string& what) {
  failed_ = Error{what + " " + path_.string() + ": " + errnoText()};
  return *failed_;
}

Status RecordWriter::writeBuffer(std::size_t bytes) {
  std::size_t done = 0;
  while (done < bytes) {
    const ssize_t n = ::write(fd_, buffer_.data() + done, bytes - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n == 0) errno = EIO;
      buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(done));
      file_bytes_ += done;
      return fail("cannot write");
    }
    done += static_cast<std::size_t>(n);
  }
  file_bytes_ += done;
  buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(done));
  return Status::success();
}

Status RecordWriter::append(std::span<const std::uint8_t> payload) {
  if (failed_) return Error{"record file unusable after an earlier error: " + failed_->message};
  if (payload.empty() || payload.size() > kMaxRecordPayloadBytes) {
    return Error{"record payload of " + std::to_string(payload.size()) + " bytes is outside 1.." +
                 std::to_string(kMaxRecordPayloadBytes)};
  }
  const std::vector<std::uint8_t> frame = encodeFrame(payload);
  buffer_.insert(buffer_.end(), frame.begin(), frame.end());
  size_bytes_ += frame.size();
  // Whole buffers, as stdio writes them: a frame may be split until sync().
  if (buffer_.size() >= kBufferBytes) return writeBuffer(buffer_.size() / kBufferBytes * kBufferBytes);
  return Status::success();
}

Status RecordWriter::sync() {
  if (failed_) return Error{"record file unusable after an earlier error: " + failed_->message};
  if (Status s = writeBuffer(buffer_.size()); !s.ok()) return s;
  if (::fsync(fd_) != 0) return fail("cannot fsync");
  return Status::success();
}

Status RecordWriter::truncate(std::uint64_t size_bytes) {
  if (failed_) return Error{"record file unusable after an earlier error: " + failed_->message};
  if (size_bytes > size_bytes_) {
    return Error{"cannot truncate " + path_.string() + " to " + std::to_string(size_bytes) + " bytes: it holds " +
                 std::to_string(size_bytes_)};
  }
  if (Status s = writeBuffer(buffer_.size()); !s.ok()) return s;
  if (::ftruncate(fd_, static_cast<off_t>(size_bytes)) != 0) return fail("cannot truncate");
  if (::fsync(fd_) != 0) return fail("cannot fsync");
  size_bytes_ = file_bytes_ = size_bytes;
  return Status::success();
}

Status RecordWriter::rollback(std::uint64_t size_bytes) {
  if (size_bytes > size_bytes_) {
    return Error{"cannot roll " + path_.string() + " back to " + std::to_string(size_bytes) + " bytes: it holds " +
                 std::to_string(size_bytes_)};
  }
  if (size_bytes >= file_bytes_) {
    buffer_.resize(static_cast<std::size_t>(size_bytes - file_bytes_));
  } else {
    if (::ftruncate(fd_, static_cast<off_t>(size_bytes)) != 0) {
      failed_ = Error{"cannot truncate " + path_.string() + ": " + errnoText()};
      return *failed_;
    }
    buffer_.clear();
    file_bytes_ = size_bytes;
  }
  size_bytes_ = size_bytes;
  failed_.reset();
  return Status::success();
}

}  // namespace vog::mission
