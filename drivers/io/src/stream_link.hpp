#pragma once
// Internal: the byte-stream part shared by the serial and TCP transports, on top of Supervisor's
// reconnect and backoff: the read loop (chunks stamped at reception and delivered in order) and
// the write queue (one async_write in flight, messages sent whole and in order).
//
// Lifecycle: as Supervisor. A derived transport opens `stream_` in asyncOpen() (calling
// clearQueue() first) and closes it in closeLink(); the read loop starts once the link is open.
// Threading: every member runs on the io_context thread.
// Invariants: only the front of the queue is ever being written; the queue is cleared on the next
// open, not on close (a cancelled write may still hold its buffer); handlers of an older
// generation return without touching the stream, the queue or the callbacks.

#include <asio.hpp>

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <span>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "supervisor.hpp"
#include "vog/io/byte_stream.hpp"

namespace vog::io::detail {

template <class Stream>
class StreamLink : public Supervisor {
 public:
  // Queues bytes for sending; fails when the link is not connected.
  Status write(std::span<const std::uint8_t> bytes) {
    if (!connected()) return Error{linkName() + ": not connected (" + health().reason + ")"};
    queue_.emplace_back(bytes.begin(), bytes.end());
    if (queue_.size() == 1) writeNext(generation());
    return Status::success();
  }

 protected:
  StreamLink(asio::io_context& io, ReconnectConfig reconnect, StampClock clock, StateHandler on_state,
             ByteHandler on_bytes, std::size_t read_chunk_bytes)
      : Supervisor(io, reconnect, std::move(clock), std::move(on_state)),
        stream_(io),
        on_bytes_(std::move(on_bytes)),
        buffer_(read_chunk_bytes) {}

  // Names the link in every message, e.g. "serial /dev/ttyUSB0" or "tcp 127.0.0.1:29500".
  virtual std::string linkName() const = 0;
  // The health reason of a failed read (TCP words end-of-stream as the peer closing).
  virtual std::string readErrorText(const std::error_code& ec) const { return ec.message(); }

  void onOpened() final { readNext(generation()); }
  void clearQueue() { queue_.clear(); }

  Stream stream_;

 private:
  std::shared_ptr<StreamLink> selfPtr() { return std::static_pointer_cast<StreamLink>(shared_from_this()); }

  void readNext(std::uint64_t gen) {
    stream_.async_read_some(asio::buffer(buffer_), [self = selfPtr(), gen](const std::error_code& ec, std::size_t n) {
      if (!self->isCurrent(gen)) return;
      if (ec) {
        // EOF or EIO: the other end went away (pty master closed, adapter unplugged, peer closed).
        self->linkLost(self->linkName() + " read: " + self->readErrorText(ec));
        return;
      }
      const std::int64_t stamp_ns = self->now_ns();
      self->noteRx(n, 0, stamp_ns);
      if (self->on_bytes_) self->on_bytes_(std::span<const std::uint8_t>(self->buffer_.data(), n), stamp_ns);
      if (self->isCurrent(gen)) self->readNext(gen);
    });
  }

  void writeNext(std::uint64_t gen) {
    asio::async_write(stream_, asio::buffer(queue_.front()),
                      [self = selfPtr(), gen](const std::error_code& ec, std::size_t n) {
                        if (!self->isCurrent(gen)) return;
                        if (ec) {
                          self->linkLost(self->linkName() + " write: " + ec.message());
                          return;
                        }
                        self->noteTx(n, 0);
                        self->queue_.pop_front();
                        if (!self->queue_.empty()) self->writeNext(gen);
                      });
  }

  ByteHandler on_bytes_;
  std::vector<std::uint8_t> buffer_;
  std::deque<std::vector<std::uint8_t>> queue_;
};

}  // namespace vog::io::detail
