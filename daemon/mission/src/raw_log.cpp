#include "vog/mission/raw_log.hpp"

#include "vog/core/bytes.hpp"

#include <algorithm>
#include <cstdio>
#include <iterator>
#include <optional>
#include <string>

namespace vog::mission {
namespace {

constexpr std::size_t kRawHeaderBytes = 1 + 2 + 8;

Result<RawLogContents> decodeRawLog(RecordScan scan, const std::string& what) {
  RawLogContents out;
  out.tail = scan.tail;
  out.records.reserve(scan.records.size());
  for (const FramedRecord& f : scan.records) {
    ByteReader in(f.payload);
    const std::uint8_t type = in.u8("type");
    RawRecord r;
    r.device_id = in.u16("device_id");
    r.stamp_ns = in.i64("stamp_ns");
    if (!in.ok() || type != kRawRecordType) {
      return Error{what + ": record at byte offset " + std::to_string(f.offset) + ": " +
                   (in.ok() ? "unknown record type " + std::to_string(type) : in.error())};
    }
    auto bytes = in.bytes(in.remaining(), "bytes");
    r.bytes.assign(bytes.begin(), bytes.end());
    out.records.push_back(std::move(r));
  }
  return out;
}

// The segments of the log at `path`, oldest first: the single file of an older log, then the numbered
// segments by index.
struct SegmentFile {
  std::filesystem::path path;
  std::optional<std::uint64_t> index;  // none: the single file of an older log
};

Result<std::vector<SegmentFile>> listSegments(const std::filesystem::path& path) {
  std::vector<SegmentFile> out;
  std::error_code ec;
  if (std::filesystem::is_regular_file(path, ec)) out.push_back({path, std::nullopt});
  const std::filesystem::path dir = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  const std::string prefix = path.stem().string() + ".";
  const std::string suffix = path.extension().string();
  std::vector<SegmentFile> numbered;
  for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.size() < prefix.size() + 6 + suffix.size() || name.compare(0, prefix.size(), prefix) != 0 ||
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0)
      continue;
    const std::string digits = name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
    if (digits.size() > 18 || digits.find_first_not_of("0123456789") != std::string::npos) continue;
    numbered.push_back({it->path(), std::stoull(digits)});
  }
  if (ec) return Error{"cannot list " + dir.string() + ": " + ec.message()};
  std::sort(numbered.begin(), numbered.end(), [](const auto& a, const auto& b) { return *a.index < *b.index; });
  out.insert(out.end(), numbered.begin(), numbered.end());
  return out;
}

}  // namespace

Result<RawLogContents> readRawLog(const std::filesystem::path& path) {
  auto segments = listSegments(path);
  if (!segments) return segments.error();
  if (segments->empty()) return Error{"no raw log " + path.string() + " (nor any of its segments)"};
  RawLogContents out;
  for (const SegmentFile& segment : *segments) {
    if (segment.index && out.segments == 0) out.dropped_segments = *segment.index;
    auto scan = readRecordFile(segment.path);
    if (!scan) return scan.error();
    auto contents = decodeRawLog(std::move(scan.value()), segment.path.string());
    if (!contents) return contents.error();
    if (contents->tail.torn) out.tail = contents->tail;
    std::move(contents->records.begin(), contents->records.end(), std::back_inserter(out.records));
    ++out.segments;
  }
  return out;
}

std::filesystem::path RawLog::segmentPath(const std::filesystem::path& path, std::uint64_t index) {
  char number[32];
  std::snprintf(number, sizeof(number), ".%06llu", static_cast<unsigned long long>(index));
  return path.parent_path() / (path.stem().string() + number + path.extension().string());
}

Result<std::unique_ptr<RawLog>> RawLog::open(const std::filesystem::path& path, std::uint64_t max_bytes) {
  if (max_bytes < kMinRawLogBytes) {
    return Error{"raw log: a cap of " + std::to_string(max_bytes) + " bytes is below the minimum of " +
                 std::to_string(kMinRawLogBytes)};
  }
  auto segments = listSegments(path);
  if (!segments) return Error{"raw log: " + segments.error().message};
  std::deque<Segment> closed;
  std::uint64_t next = 0;
  for (const SegmentFile& segment : *segments) {
    std::error_code ec;
    const std::uint64_t bytes = std::filesystem::file_size(segment.path, ec);
    if (ec) return Error{"raw log: cannot stat " + segment.path.string() + ": " + ec.message()};
    closed.push_back({segment.path, bytes});
    if (segment.index) next = *segment.index + 1;
  }
  auto log = std::unique_ptr<RawLog>(new RawLog(path, max_bytes, std::move(closed)));
  if (Status s = log->startSegment(next); !s.ok()) return Error{"raw log: " + s.error().message};
  return log;
}

std::uint64_t RawLog::sizeBytes() const {
  std::uint64_t total = writer_->sizeBytes();
  for (const Segment& s : closed_) total += s.bytes;
  return total;
}

Status RawLog::startSegment(std::uint64_t index) {
  if (writer_) {
    if (Status s = writer_->sync(); !s.ok()) return s;
    closed_.push_back({writer_->path(), writer_->sizeBytes()});
    writer_.reset();
  }
  auto writer = RecordWriter::open(segmentPath(path_, index));
  if (!writer) return writer.error();
  writer_ = std::move(writer).value();
  index_ = index;
  bool dropped = false;
  while (!closed_.empty() && sizeBytes() > max_bytes_) {
    std::error_code ec;
    std::filesystem::remove(closed_.front().path, ec);
    if (ec) return Error{"cannot delete the oldest segment " + closed_.front().path.string() + ": " + ec.message()};
    ++dropped_segments_;
    dropped_bytes_ += closed_.front().bytes;
    closed_.pop_front();
    dropped = true;
  }
  if (dropped) return syncDirectory(path_.has_parent_path() ? path_.parent_path() : std::filesystem::path("."));
  return Status::success();
}

Status RawLog::append(std::uint16_t device_id, std::int64_t stamp_ns, std::span<const std::uint8_t> bytes) {
  if (bytes.size() > kMaxRecordPayloadBytes - kRawHeaderBytes) {
    return Error{"raw log: chunk of " + std::to_string(bytes.size()) + " bytes from device " +
                 std::to_string(device_id) + " exceeds " + std::to_string(kMaxRecordPayloadBytes - kRawHeaderBytes)};
  }
  std::vector<std::uint8_t> payload;
  ByteWriter w(payload);
  w.u8(kRawRecordType);
  w.u16(device_id);
  w.i64(stamp_ns);
  w.bytes(bytes);
  if (Status s = writer_->append(payload); !s.ok()) return s;
  if (writer_->sizeBytes() >= max_bytes_ / 16) return startSegment(index_ + 1);
  return Status::success();
}

}  // namespace vog::mission
