#include "proto/framing.h"

#include <algorithm>

namespace tribo::wire {

namespace {

void append_varint(std::uint32_t value, std::string& out) {
  while (value >= 0x80) {
    out.push_back(static_cast<char>((value & 0x7f) | 0x80));
    value >>= 7;
  }
  out.push_back(static_cast<char>(value));
}

}  // namespace

bool append_frame(const google::protobuf::MessageLite& msg, std::size_t max_frame_bytes,
                  std::string& out) {
  const std::size_t size = msg.ByteSizeLong();
  if (size > max_frame_bytes) return false;
  append_varint(static_cast<std::uint32_t>(size), out);
  const std::size_t offset = out.size();
  out.resize(offset + size);
  msg.SerializeWithCachedSizesToArray(reinterpret_cast<std::uint8_t*>(out.data() + offset));
  return true;
}

std::size_t FrameDecoder::feed(std::string_view data) {
  if (consumed_ > 0) {  // compact once per feed, not once per frame
    pending_.erase(0, consumed_);
    consumed_ = 0;
  }
  const std::size_t limit = max_frame_bytes_ + kMaxVarintBytes;
  const std::size_t room = pending_.size() < limit ? limit - pending_.size() : 0;
  const std::size_t taken = std::min(room, data.size());
  pending_.append(data.data(), taken);
  return taken;
}

DecodeStatus FrameDecoder::parse_header() {
  std::uint64_t value = 0;
  for (std::size_t i = 0; i < buffered() && i < kMaxVarintBytes; ++i) {
    const auto byte = static_cast<std::uint8_t>(pending_[consumed_ + i]);
    value |= static_cast<std::uint64_t>(byte & 0x7f) << (7 * i);
    if ((byte & 0x80) == 0) {
      if (value > max_frame_bytes_) {
        announced_size_ = static_cast<std::size_t>(value);
        return error_ = DecodeStatus::kOversized;
      }
      header_bytes_ = i + 1;
      announced_size_ = static_cast<std::size_t>(value);
      return DecodeStatus::kFrame;
    }
  }
  if (buffered() >= kMaxVarintBytes) return error_ = DecodeStatus::kBadHeader;
  return DecodeStatus::kNeedMore;
}

DecodeStatus FrameDecoder::next(std::string& frame) {
  if (error_ != DecodeStatus::kNeedMore) return error_;
  if (header_bytes_ == 0) {
    const DecodeStatus header = parse_header();
    if (header != DecodeStatus::kFrame) return header;
  }
  if (buffered() < header_bytes_ + announced_size_) return DecodeStatus::kNeedMore;
  frame.assign(pending_, consumed_ + header_bytes_, announced_size_);
  consumed_ += header_bytes_ + announced_size_;
  header_bytes_ = 0;
  return DecodeStatus::kFrame;
}

}  // namespace tribo::wire
