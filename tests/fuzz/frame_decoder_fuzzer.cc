// libFuzzer target: the frame decoder and the request parser behind it, as
// the daemon runs them on bytes from the network.
// Input: byte 0 picks the maximum frame size (0: 4 MiB, else n * 64 bytes),
// byte 1 the size of the chunks the stream arrives in (1..256); the rest is
// the stream.
// Checked: no frame exceeds the maximum, the decoder never buffers more than
// one maximal frame, errors are sticky, and every frame it produces decodes
// to the same bytes when framed again.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include <google/protobuf/stubs/logging.h>

#include "proto/framing.h"
#include "tribo/v1/api.pb.h"

namespace {

void check(bool ok) {
  if (!ok) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool quiet = [] {
    google::protobuf::SetLogHandler(nullptr);  // invalid UTF-8 in strings is expected here
    return true;
  }();
  (void)quiet;
  if (size < 2) return 0;
  const std::size_t max_frame = data[0] == 0 ? tribo::wire::kDefaultMaxFrameBytes : data[0] * 64u;
  const std::size_t chunk = 1u + data[1];
  std::string_view stream(reinterpret_cast<const char*>(data + 2), size - 2);

  tribo::wire::FrameDecoder decoder(max_frame);
  std::string frame;
  tribo::wire::DecodeStatus status = tribo::wire::DecodeStatus::kNeedMore;
  while (!stream.empty()) {
    std::string_view piece = stream.substr(0, chunk);
    const std::size_t taken = decoder.feed(piece);
    check(taken <= piece.size());
    stream.remove_prefix(taken);
    while ((status = decoder.next(frame)) == tribo::wire::DecodeStatus::kFrame) {
      check(frame.size() <= max_frame);
      tribo::v1::ClientMessage request;
      if (request.ParseFromString(frame)) {
        std::string again;
        if (tribo::wire::append_frame(request, ~std::size_t{0}, again)) {
          tribo::wire::FrameDecoder round_trip(again.size());
          check(round_trip.feed(again) == again.size());
          std::string body;
          check(round_trip.next(body) == tribo::wire::DecodeStatus::kFrame);
          tribo::v1::ClientMessage reparsed;
          check(reparsed.ParseFromString(body));
          check(reparsed.SerializeAsString() == request.SerializeAsString());
        }
      }
    }
    if (status == tribo::wire::DecodeStatus::kOversized || status == tribo::wire::DecodeStatus::kBadHeader) {
      check(decoder.next(frame) == status);  // sticky
      break;
    }
    // Feeding stalls only when a maximal frame is buffered and not complete.
    if (taken == 0) break;
  }
  return 0;
}
