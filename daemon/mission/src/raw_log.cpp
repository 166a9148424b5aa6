#include "vog/mission/raw_log.hpp"

#include "vog/core/bytes.hpp"

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

}  // namespace

Result<RawLogContents> readRawLog(const std::filesystem::path& path) {
  auto scan = readRecordFile(path);
  if (!scan) return scan.error();
  return decodeRawLog(std::move(scan.value()), path.string());
}

Result<std::unique_ptr<RawLog>> RawLog::open(const std::filesystem::path& path, RawLogContents* existing) {
  RecordScan scan;
  auto writer = RecordWriter::open(path, &scan);
  if (!writer) return writer.error();
  auto contents = decodeRawLog(std::move(scan), path.string());
  if (!contents) return contents.error();
  if (existing != nullptr) *existing = std::move(contents.value());
  return std::unique_ptr<RawLog>(new RawLog(std::move(writer.value())));
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
  return writer_->append(payload);
}

}  // namespace vog::mission
