#include "daemon/api_server.h"

#include <spdlog/spdlog.h>

#include "daemon/client_session.h"
#include "proto/framing.h"
#include "proto/sample_record.h"

namespace tribo::daemon {

ApiServer::ApiServer(asio::io_context& io, const v1::ServerConfig& config)
    : io_(io),
      acceptor_(io, asio::ip::tcp::endpoint(asio::ip::make_address(config.bind_address()),
                                            static_cast<std::uint16_t>(config.port()))),
      max_frame_bytes_(config.max_frame_bytes()),
      close_deadline_(io) {}

ApiServer::~ApiServer() = default;

void ApiServer::start_accepting() { accept_next(); }

void ApiServer::accept_next() {
  acceptor_.async_accept([this](std::error_code ec, asio::ip::tcp::socket socket) {
    if (ec) {
      if (ec != asio::error::operation_aborted) spdlog::warn("accept failed: {}", ec.message());
      if (acceptor_.is_open()) accept_next();
      return;
    }
    std::error_code ignored;
    socket.set_option(asio::ip::tcp::no_delay(true), ignored);
    auto session = std::make_shared<ClientSession>(std::move(socket), *this, *service_, max_frame_bytes_);
    sessions_.push_back(session);
    session->start();
    accept_next();
  });
}

void ApiServer::close_gracefully(std::chrono::milliseconds deadline) {
  asio::post(io_, [this, deadline] {
    closing_ = true;
    std::error_code ignored;
    acceptor_.close(ignored);
    const auto sessions = sessions_;  // close_after_writes may remove from sessions_
    for (const auto& s : sessions) s->close_after_writes();
    if (sessions_.empty()) return;
    close_deadline_.expires_after(deadline);
    close_deadline_.async_wait([this](std::error_code ec) {
      if (ec) return;  // every session closed in time
      const auto remaining = sessions_;
      for (const auto& s : remaining) s->close();
    });
  });
}

void ApiServer::remove(ClientSession* session) {
  sessions_.remove_if([session](const auto& s) { return s.get() == session; });
  if (closing_ && sessions_.empty()) close_deadline_.cancel();
}

namespace {

std::shared_ptr<const std::string> frame_of(const v1::ServerMessage& message) {
  auto frame = std::make_shared<std::string>();
  wire::append_frame(message, ~std::size_t{0}, *frame);
  return frame;
}

// Every n-th sample of block by sequence number.
v1::SampleBlock decimated(const v1::SampleBlock& block, std::uint32_t n) {
  v1::SampleBlock out;
  out.set_run_id(block.run_id());
  bool first = true;
  for (int i = 0; i < sample_count(block); ++i) {
    const std::uint64_t seq = block.first_sequence() + static_cast<std::uint64_t>(i);
    if (seq % n != 0) continue;
    if (first) out.set_first_sequence(seq);
    first = false;
    append_sample(sample_at(block, i), out);
  }
  return out;
}

}  // namespace

void ApiServer::broadcast(std::shared_ptr<const std::string> frame,
                          std::shared_ptr<const v1::SampleBlock> samples) {
  asio::post(io_, [this, frame = std::move(frame), samples = std::move(samples)] {
    const auto sessions = sessions_;
    for (const auto& s : sessions) {
      if (!s->subscribed()) continue;
      if (!samples || s->decimation() <= 1) {
        s->send(frame);
        continue;
      }
      v1::ServerMessage message;
      *message.mutable_samples() = decimated(*samples, s->decimation());
      if (sample_count(message.samples()) > 0) s->send(message);
    }
  });
}

void ApiServer::on_run_start(const v1::RunStart& start) {
  v1::ServerMessage message;
  *message.mutable_run_start() = start;
  broadcast(frame_of(message), nullptr);
}

void ApiServer::on_samples(const v1::SampleBlock& block) {
  v1::ServerMessage message;
  *message.mutable_samples() = block;
  broadcast(frame_of(message), std::make_shared<const v1::SampleBlock>(block));
}

void ApiServer::on_run_stop(const v1::RunStop& stop) {
  v1::ServerMessage message;
  *message.mutable_run_stop() = stop;
  broadcast(frame_of(message), nullptr);
}

}  // namespace tribo::daemon
