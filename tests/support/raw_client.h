// A bare TCP client for robustness tests: sends arbitrary bytes or frames,
// reads frames, and can shrink its receive buffer to play a slow reader.
// Blocking; every read gives up after a timeout so a broken test fails
// instead of hanging.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <string>

#include "proto/framing.h"
#include "tribo/v1/api.pb.h"

namespace tribo::testing {

class RawClient {
 public:
  // receive_buffer_bytes > 0 sets SO_RCVBUF before connecting (a small TCP window).
  explicit RawClient(std::uint16_t port, int receive_buffer_bytes = 0);
  ~RawClient();
  RawClient(const RawClient&) = delete;
  RawClient& operator=(const RawClient&) = delete;

  void send_bytes(const std::string& bytes);
  void send(const v1::ClientMessage& message);
  // The next frame as a ServerMessage (run documents that arrived during a
  // request() first); nullopt on EOF, timeout or a bad frame.
  std::optional<v1::ServerMessage> read(int timeout_ms = 20000);
  // True once the peer closed the connection (reads until EOF or timeout).
  bool closed_by_peer(int timeout_ms = 20000);
  // Sends the request with the next request id and reads until its reply.
  // Run documents (request id 0) that arrive meanwhile are kept for read().
  v1::ServerMessage request(v1::ClientMessage message);
  void close();

 private:
  int fd_ = -1;
  wire::FrameDecoder decoder_{wire::kDefaultMaxFrameBytes};
  std::string unfed_;
  std::uint64_t next_id_ = 1;
  std::deque<v1::ServerMessage> held_;
  std::optional<v1::ServerMessage> read_frame(int timeout_ms);
};

// Hello messages.
v1::ClientMessage hello_message(v1::Role role = v1::OBSERVER, const std::string& token = "",
                                std::uint32_t api_version = 1);

}  // namespace tribo::testing
