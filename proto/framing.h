// Length-delimited frames: a base-128 varint byte count, then the message bytes.
// The decoder checks a frame's announced size against the maximum before it
// buffers any of the body, so an oversized frame costs no allocation.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include <google/protobuf/message_lite.h>

namespace tribo::wire {

inline constexpr std::size_t kMaxVarintBytes = 5;  // a 32-bit size
inline constexpr std::size_t kDefaultMaxFrameBytes = 4u << 20;

// Appends one frame holding msg to out. Returns false if msg exceeds
// max_frame_bytes (nothing is appended then).
bool append_frame(const google::protobuf::MessageLite& msg, std::size_t max_frame_bytes,
                  std::string& out);

enum class DecodeStatus {
  kFrame,      // a complete frame body was produced
  kNeedMore,   // feed more bytes
  kOversized,  // the announced size exceeds the maximum; the stream is unusable
  kBadHeader,  // the size prefix is not a valid varint; the stream is unusable
};

class FrameDecoder {
 public:
  explicit FrameDecoder(std::size_t max_frame_bytes) : max_frame_bytes_(max_frame_bytes) {}

  // Accepts up to max_frame_bytes + kMaxVarintBytes of pending data; returns how
  // many bytes of data it took. Call next() until it stops returning kFrame,
  // then feed the rest.
  std::size_t feed(std::string_view data);

  // Extracts the next frame body into frame. After kOversized or kBadHeader the
  // decoder stays in that state.
  DecodeStatus next(std::string& frame);

  std::size_t announced_size() const { return announced_size_; }
  std::size_t max_frame_bytes() const { return max_frame_bytes_; }

 private:
  DecodeStatus parse_header();

  std::size_t max_frame_bytes_;
  std::size_t buffered() const { return pending_.size() - consumed_; }

  std::string pending_;
  std::size_t consumed_ = 0;       // bytes of pending_ already handed out
  std::size_t header_bytes_ = 0;   // 0 while the header is incomplete
  std::size_t announced_size_ = 0;
  DecodeStatus error_ = DecodeStatus::kNeedMore;
};

}  // namespace tribo::wire
