#include "proto/framing.h"

#include <gtest/gtest.h>

#include "tribo/v1/api.pb.h"

namespace tribo::wire {
namespace {

v1::ClientMessage request(std::uint64_t id) {
  v1::ClientMessage m;
  m.set_request_id(id);
  m.mutable_abort_run()->set_reason(std::string(300, 'x'));  // > 127 bytes: 2-byte varint
  return m;
}

TEST(Framing, RoundTripsFramesFedOneByteAtATime) {
  std::string stream;
  ASSERT_TRUE(append_frame(request(1), 1 << 20, stream));
  ASSERT_TRUE(append_frame(request(2), 1 << 20, stream));
  FrameDecoder decoder(1 << 20);
  std::vector<std::uint64_t> ids;
  std::string frame;
  for (char c : stream) {
    ASSERT_EQ(decoder.feed(std::string_view(&c, 1)), 1u);
    while (decoder.next(frame) == DecodeStatus::kFrame) {
      v1::ClientMessage m;
      ASSERT_TRUE(m.ParseFromString(frame));
      ids.push_back(m.request_id());
    }
  }
  EXPECT_EQ(ids, (std::vector<std::uint64_t>{1, 2}));
}

TEST(Framing, RejectsOversizedFrameFromItsHeaderAlone) {
  std::string stream;
  ASSERT_TRUE(append_frame(request(1), 1 << 20, stream));
  FrameDecoder decoder(100);
  decoder.feed(std::string_view(stream).substr(0, 2));  // just the size prefix
  std::string frame;
  EXPECT_EQ(decoder.next(frame), DecodeStatus::kOversized);
  EXPECT_GT(decoder.announced_size(), 100u);
  EXPECT_EQ(decoder.next(frame), DecodeStatus::kOversized) << "the error is sticky";
}

TEST(Framing, RejectsAVarintLongerThanFiveBytes) {
  FrameDecoder decoder(1 << 20);
  decoder.feed(std::string(6, '\x80'));
  std::string frame;
  // 0x80 0x80 ... never terminates within 5 bytes; value stays 0 so it is a bad header.
  EXPECT_EQ(decoder.next(frame), DecodeStatus::kBadHeader);
}

TEST(Framing, EncoderRefusesMessagesAboveTheLimit) {
  std::string stream;
  EXPECT_FALSE(append_frame(request(1), 10, stream));
  EXPECT_TRUE(stream.empty());
}

TEST(Framing, BuffersAtMostOneMaximalFrame) {
  FrameDecoder decoder(16);
  const std::string big(100, '\x01');
  EXPECT_EQ(decoder.feed(big), 16u + kMaxVarintBytes);
}

}  // namespace
}  // namespace tribo::wire
