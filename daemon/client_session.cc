#include "daemon/client_session.h"

#include <spdlog/spdlog.h>

#include "daemon/api_server.h"
#include "daemon/instrument_service.h"
#include "proto/api_defaults.h"

namespace tribo::daemon {

namespace {

using wire::kApiVersion;

void set_error(v1::ServerMessage& reply, v1::ErrorCode code, std::string field, std::string message) {
  v1::Error* e = reply.mutable_error();
  e->set_code(code);
  e->set_field(std::move(field));
  e->set_message(std::move(message));
}

}  // namespace

ClientSession::ClientSession(asio::ip::tcp::socket socket, ApiServer& server,
                             InstrumentService& service, std::size_t max_frame_bytes)
    : socket_(std::move(socket)),
      server_(server),
      service_(service),
      decoder_(max_frame_bytes),
      max_frame_bytes_(max_frame_bytes) {}

void ClientSession::read_more() {
  socket_.async_read_some(asio::buffer(read_buffer_),
                          [self = shared_from_this()](std::error_code ec, std::size_t n) {
                            if (ec) return self->close();
                            self->on_bytes(n);
                          });
}

void ClientSession::on_bytes(std::size_t n) {
  std::string_view data(read_buffer_.data(), n);
  std::string frame;
  while (!closed_) {
    data.remove_prefix(decoder_.feed(data));
    wire::DecodeStatus status;
    while ((status = decoder_.next(frame)) == wire::DecodeStatus::kFrame) handle(frame);
    if (status == wire::DecodeStatus::kOversized || status == wire::DecodeStatus::kBadHeader) {
      v1::ServerMessage reply;
      set_error(reply, v1::MALFORMED_REQUEST, "",
                status == wire::DecodeStatus::kOversized
                    ? "frame of " + std::to_string(decoder_.announced_size()) +
                          " bytes exceeds the maximum of " + std::to_string(max_frame_bytes_)
                    : "invalid frame size prefix");
      send(reply);
      close_after_writes();
      return;
    }
    if (data.empty()) break;
  }
  if (!closed_ && !closing_) read_more();
}

void ClientSession::handle(const std::string& frame) {
  v1::ClientMessage request;
  v1::ServerMessage reply;
  if (!request.ParseFromString(frame)) {
    set_error(reply, v1::MALFORMED_REQUEST, "", "the frame is not a tribo.v1.ClientMessage");
  } else {
    reply.set_request_id(request.request_id());
    dispatch(request, reply);
  }
  send(reply);
}

void ClientSession::dispatch(const v1::ClientMessage& request, v1::ServerMessage& reply) {
  std::optional<v1::Error> error;
  switch (request.body_case()) {
    case v1::ClientMessage::kHello:
      if (request.hello().api_version() != kApiVersion) {
        set_error(reply, v1::UNSUPPORTED_VERSION, "hello.api_version",
                  "api_version " + std::to_string(request.hello().api_version()) +
                      " is not supported; this daemon speaks version " + std::to_string(kApiVersion));
        return;
      }
      reply.mutable_hello()->set_api_version(kApiVersion);
      reply.mutable_hello()->set_software_version(service_.software_version());
      reply.mutable_hello()->set_backend(service_.config().backend_case() == v1::DaemonConfig::kSim ? "sim" : "other");
      return;
    case v1::ClientMessage::kLoadProtocol:
      error = service_.load_protocol(request.load_protocol().protocol(), *reply.mutable_load_protocol());
      break;
    case v1::ClientMessage::kSubscribe:
      subscribed_ = true;
      decimation_ = std::max<std::uint32_t>(1, request.subscribe().decimation());
      reply.mutable_subscribe();
      return;
    case v1::ClientMessage::kStartRun: {
      std::optional<std::uint64_t> seed;
      if (request.start_run().has_seed()) seed = request.start_run().seed();
      error = service_.start_run(seed, *reply.mutable_start_run());
      break;
    }
    case v1::ClientMessage::kAbortRun:
      error = service_.abort_run(request.abort_run().reason());
      if (!error) reply.mutable_abort_run();
      break;
    case v1::ClientMessage::kGetStatus:
      *reply.mutable_status() = service_.status();
      return;
    case v1::ClientMessage::kSetGains:
      error = service_.set_gains(request.set_gains().loop(), request.set_gains().gains(),
                                 *reply.mutable_set_gains());
      break;
    case v1::ClientMessage::kGetGains:
      *reply.mutable_get_gains() = service_.gains();
      return;
    case v1::ClientMessage::kRearm:
      error = service_.rearm(*reply.mutable_rearm());
      break;
    case v1::ClientMessage::kEmergencyStop:
      error = service_.emergency_stop(request.emergency_stop().reason(), *reply.mutable_emergency_stop());
      break;
    case v1::ClientMessage::kAutotune:
      error = service_.autotune(request.autotune(), *reply.mutable_autotune());
      break;
    case v1::ClientMessage::BODY_NOT_SET:
      set_error(reply, v1::MALFORMED_REQUEST, "body", "the request has no body");
      return;
  }
  if (error) *reply.mutable_error() = *error;
}

void ClientSession::send(const v1::ServerMessage& message) {
  auto frame = std::make_shared<std::string>();
  if (!wire::append_frame(message, max_frame_bytes_, *frame)) {
    spdlog::error("reply of {} bytes exceeds the frame limit", message.ByteSizeLong());
    return;
  }
  send(std::move(frame));
}

void ClientSession::send(std::shared_ptr<const std::string> frame) {
  if (closed_) return;
  write_queue_.push_back(std::move(frame));
  if (!writing_) write_next();
}

void ClientSession::write_next() {
  if (write_queue_.empty()) {
    writing_ = false;
    if (closing_) close();
    return;
  }
  writing_ = true;
  asio::async_write(socket_, asio::buffer(*write_queue_.front()),
                    [self = shared_from_this()](std::error_code ec, std::size_t) {
                      if (ec) return self->close();
                      self->write_queue_.pop_front();
                      self->write_next();
                    });
}

void ClientSession::close_after_writes() {
  closing_ = true;
  if (!writing_) close();
}

void ClientSession::close() {
  if (closed_) return;
  closed_ = true;
  std::error_code ignored;
  socket_.shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
  socket_.close(ignored);
  write_queue_.clear();
  server_.remove(this);
}

}  // namespace tribo::daemon
