// One client connection: reads frames, answers requests, queues outgoing
// frames. Lives on the io_context thread only.
#pragma once

#include <array>
#include <deque>
#include <memory>
#include <string>

#include <asio.hpp>

#include "proto/framing.h"
#include "tribo/v1/api.pb.h"

namespace tribo::daemon {

class ApiServer;
class InstrumentService;

class ClientSession : public std::enable_shared_from_this<ClientSession> {
 public:
  ClientSession(asio::ip::tcp::socket socket, ApiServer& server, InstrumentService& service,
                std::size_t max_frame_bytes);

  void start() { read_more(); }
  void send(std::shared_ptr<const std::string> frame);
  void send(const v1::ServerMessage& message);
  void close_after_writes();
  void close();

  bool subscribed() const { return subscribed_; }
  std::uint32_t decimation() const { return decimation_; }

 private:
  void read_more();
  void on_bytes(std::size_t n);
  void handle(const std::string& frame);
  void dispatch(const v1::ClientMessage& request, v1::ServerMessage& reply);
  void write_next();

  asio::ip::tcp::socket socket_;
  ApiServer& server_;
  InstrumentService& service_;
  wire::FrameDecoder decoder_;
  std::size_t max_frame_bytes_;
  std::array<char, 64 * 1024> read_buffer_{};
  std::deque<std::shared_ptr<const std::string>> write_queue_;
  bool writing_ = false;
  bool closing_ = false;
  bool closed_ = false;
  bool subscribed_ = false;
  std::uint32_t decimation_ = 1;
};

}  // namespace tribo::daemon
