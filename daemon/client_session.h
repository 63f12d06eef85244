// One client connection: reads frames, answers requests, queues outgoing
// frames. Lives on the io_context thread only.
//
// A session starts unauthenticated: Hello must come first (version check,
// role). Control commands need the session to hold control (ApiServer decides
// who does). Outgoing frames are queued with a byte budget: sample blocks
// beyond it are dropped for this client only and replaced by one GapNotice
// naming the missed sequence range, sent as soon as the client has caught up;
// every other document and reply is always queued.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>

#include <asio.hpp>

#include "proto/framing.h"
#include "tribo/v1/api.pb.h"

namespace tribo::daemon {

class ApiServer;
class InstrumentService;

// A published sample block and its frames, one per decimation asked for,
// built once and shared by every session that wants it.
class SampleFrames {
 public:
  SampleFrames(std::shared_ptr<const v1::SampleBlock> block, std::shared_ptr<const std::string> full)
      : block_(std::move(block)), full_(std::move(full)) {}
  const v1::SampleBlock& block() const { return *block_; }
  // nullptr when no sample of the block survives the decimation.
  std::shared_ptr<const std::string> frame(std::uint32_t decimation);

 private:
  std::shared_ptr<const v1::SampleBlock> block_;
  std::shared_ptr<const std::string> full_;
  std::vector<std::pair<std::uint32_t, std::shared_ptr<const std::string>>> decimated_;
};

struct SessionLimits {
  std::size_t max_frame_bytes = 0;   // incoming frames
  std::size_t queue_bytes = 0;       // sample frames are dropped beyond this
  std::chrono::steady_clock::duration handshake_timeout = std::chrono::seconds(5);
  std::chrono::steady_clock::duration idle_timeout = std::chrono::seconds(300);
  double control_lease_s = 0;  // told to clients in HelloReply
};

class ClientSession : public std::enable_shared_from_this<ClientSession> {
 public:
  ClientSession(asio::ip::tcp::socket socket, ApiServer& server, InstrumentService& service,
                SessionLimits limits);

  void start();
  // Decodes and answers the requests in data (bytes as read from the
  // socket); false once the session is closing. The fuzz target calls it.
  bool process(std::string_view data);
  // Replies and run documents other than samples: always queued.
  void send(std::shared_ptr<const std::string> frame);
  void send(const v1::ServerMessage& message);
  // Samples: queued within the byte budget, otherwise recorded as a gap.
  void offer_samples(SampleFrames& frames);
  // Sends the pending gap notice, if any (before a run's stop document).
  void flush_gap();
  void close_after_writes();
  void close();

  bool subscribed() const { return subscribed_; }
  bool handshake_done() const { return handshake_done_; }
  std::uint32_t decimation() const { return decimation_; }
  const std::string& name() const { return client_name_; }

 private:
  void read_more();
  void arm_timer();
  void on_bytes(std::size_t n);
  void handle(const std::string& frame);
  void dispatch(const v1::ClientMessage& request, v1::ServerMessage& reply);
  void hello(const v1::Hello& hello, v1::ServerMessage& reply);
  void status(v1::ServerMessage& reply);
  void queue(std::shared_ptr<const std::string> frame);
  void write_next();

  asio::ip::tcp::socket socket_;
  ApiServer& server_;
  InstrumentService& service_;
  wire::FrameDecoder decoder_;
  SessionLimits limits_;
  std::array<char, 64 * 1024> read_buffer_{};
  std::deque<std::shared_ptr<const std::string>> write_queue_;
  std::size_t queued_bytes_ = 0;
  std::size_t frames_in_flight_ = 0;  // at the front of write_queue_, being written
  std::vector<asio::const_buffer> write_buffers_;
  bool hang_up_ = false;  // close once the current reply is sent
  bool deferred_ = false;  // the current request is answered later (autotune)
  bool closing_ = false;
  bool closed_ = false;
  bool handshake_done_ = false;
  bool subscribed_ = false;
  std::uint32_t decimation_ = 1;
  std::string client_name_;
  asio::steady_timer timer_;
  std::chrono::steady_clock::time_point last_frame_;  // of the last complete request
  std::size_t partial_bytes_ = 0;  // received since the last complete frame (server budget)
  // Samples dropped for this client and not yet announced: [first, end).
  std::optional<v1::GapNotice> pending_gap_;
};

}  // namespace tribo::daemon
