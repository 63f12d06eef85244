#include "daemon/client_session.h"

#include <spdlog/spdlog.h>

#include "daemon/api_server.h"
#include "daemon/field_bounds.h"
#include "daemon/instrument_service.h"
#include "daemon/run_archive.h"
#include "proto/api_defaults.h"
#include "proto/sample_record.h"

namespace tribo::daemon {

namespace {

using wire::kApiVersion;

// Frames the daemon sends may be as large as a client accepts by default.
constexpr std::size_t kMaxOutgoingFrameBytes = wire::kDefaultMaxFrameBytes;
constexpr std::size_t kMaxFramesPerWrite = 64;

void set_error(v1::ServerMessage& reply, v1::ErrorCode code, std::string field, std::string message) {
  v1::Error* e = reply.mutable_error();
  e->set_code(code);
  e->set_field(std::move(field));
  e->set_message(std::move(message));
}

// Commands that move the instrument or change what it will do: only the
// controlling session may send them. Add instrument commands here.
bool is_control_command(v1::ClientMessage::BodyCase body) {
  switch (body) {
    case v1::ClientMessage::kLoadProtocol:
    case v1::ClientMessage::kStartRun:
    case v1::ClientMessage::kAbortRun:
    case v1::ClientMessage::kSetGains:  // EmergencyStop stays open to every client
    case v1::ClientMessage::kRearm:
    case v1::ClientMessage::kAutotune:
      return true;
    default:
      return false;
  }
}

std::shared_ptr<const std::string> frame_of(const v1::ServerMessage& message) {
  auto frame = std::make_shared<std::string>();
  wire::append_frame(message, ~std::size_t{0}, *frame);
  return frame;
}

// Every sample of block whose sequence number is a multiple of n.
v1::SampleBlock decimated(const v1::SampleBlock& block, std::uint32_t n) {
  v1::SampleBlock out;
  out.set_run_id(block.run_id());
  out.set_publish_time_unix_ns(block.publish_time_unix_ns());
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

std::shared_ptr<const std::string> SampleFrames::frame(std::uint32_t decimation) {
  if (decimation <= 1) return full_;
  for (const auto& [n, frame] : decimated_) {
    if (n == decimation) return frame;
  }
  v1::ServerMessage message;
  *message.mutable_samples() = decimated(*block_, decimation);
  auto frame = sample_count(message.samples()) > 0 ? frame_of(message) : nullptr;
  decimated_.emplace_back(decimation, frame);
  return frame;
}

ClientSession::ClientSession(asio::ip::tcp::socket socket, ApiServer& server,
                             InstrumentService& service, SessionLimits limits)
    : socket_(std::move(socket)),
      server_(server),
      service_(service),
      decoder_(limits.max_frame_bytes),
      limits_(limits),
      timer_(socket_.get_executor()) {}

void ClientSession::start() {
  last_frame_ = std::chrono::steady_clock::now();
  arm_timer();
  read_more();
}

// Handshake and idle timeouts: a connection that never says Hello, or that
// neither sends a complete request nor subscribes for idle_timeout, is
// closed; it cannot hold a slot (or a half-sent frame's memory) for ever.
void ClientSession::arm_timer() {
  if (closed_) return;
  timer_.expires_after(std::chrono::milliseconds(200));
  timer_.async_wait([self = shared_from_this()](std::error_code ec) {
    if (ec || self->closed_) return;
    const auto now = std::chrono::steady_clock::now();
    const auto silent = now - self->last_frame_;
    if (!self->handshake_done_ && silent > self->limits_.handshake_timeout) {
      spdlog::info("closing a connection that sent no hello within {} s",
                   std::chrono::duration<double>(self->limits_.handshake_timeout).count());
      return self->close();
    }
    if (self->handshake_done_ && !self->subscribed_ && silent > self->limits_.idle_timeout) {
      spdlog::info("closing client '{}': no request for {} s", self->client_name_,
                   std::chrono::duration<double>(self->limits_.idle_timeout).count());
      return self->close();
    }
    self->server_.check_lease(*self, now);
    self->arm_timer();
  });
}

void ClientSession::read_more() {
  socket_.async_read_some(asio::buffer(read_buffer_),
                          [self = shared_from_this()](std::error_code ec, std::size_t n) {
                            if (ec) return self->close();
                            self->on_bytes(n);
                          });
}

void ClientSession::on_bytes(std::size_t n) {
  if (process(std::string_view(read_buffer_.data(), n))) read_more();
}

bool ClientSession::process(std::string_view data) {
  const std::size_t n = data.size();
  std::string frame;
  // The bytes of a frame not yet complete count against the server's budget
  // for all connections: many slowly sent large frames cannot exhaust memory.
  if (!server_.reserve_partial(partial_bytes_, n)) {
    spdlog::warn("client '{}': half-received frames exceed the server's budget; closing it", client_name_);
    close();
    return false;
  }
  while (!closed_ && !closing_) {
    data.remove_prefix(decoder_.feed(data));
    wire::DecodeStatus status;
    while (!closing_ && (status = decoder_.next(frame)) == wire::DecodeStatus::kFrame) {
      server_.release_partial(partial_bytes_);
      last_frame_ = std::chrono::steady_clock::now();
      handle(frame);
    }
    if (closing_) return false;
    if (status == wire::DecodeStatus::kOversized || status == wire::DecodeStatus::kBadHeader) {
      v1::ServerMessage reply;
      set_error(reply, v1::MALFORMED_REQUEST, "",
                status == wire::DecodeStatus::kOversized
                    ? "frame of " + std::to_string(decoder_.announced_size()) +
                          " bytes exceeds the maximum of " + std::to_string(limits_.max_frame_bytes)
                    : "invalid frame size prefix");
      send(reply);
      close_after_writes();
      return false;
    }
    if (data.empty()) break;
  }
  return !closed_ && !closing_;
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
  if (deferred_) {
    deferred_ = false;  // answered later, from the loop's completion
    return;
  }
  send(reply);
  if (hang_up_) close_after_writes();
}

void ClientSession::dispatch(const v1::ClientMessage& request, v1::ServerMessage& reply) {
  const auto body = request.body_case();
  if (body == v1::ClientMessage::BODY_NOT_SET) {
    return set_error(reply, v1::MALFORMED_REQUEST, "body", "the request has no body (or one this daemon does not know)");
  }
  if (body == v1::ClientMessage::kHello) return hello(request.hello(), reply);
  if (!handshake_done_) {
    return set_error(reply, v1::HANDSHAKE_REQUIRED, "hello", "send hello (api_version " +
                                                                 std::to_string(kApiVersion) + ") first");
  }
  // Aborting is stopping, not steering: it ends the run through the normal
  // stop sequence. So a session without control may abort a run another
  // session controls (`tribo abort` beside a hung `tribo run`): any local
  // client when the daemon has no control token (as any may take control
  // then), and otherwise only one that shows the token.
  const std::string& abort_token = request.abort_run().token();
  const bool open_abort = body == v1::ClientMessage::kAbortRun && !server_.controls(*this) &&
                          (!server_.token_required() ||
                           (!abort_token.empty() && server_.token_matches(*this, abort_token)));
  if (is_control_command(body) && !server_.controls(*this) && !open_abort) {
    if (body == v1::ClientMessage::kAbortRun && !request.abort_run().token().empty()) {
      return set_error(reply, v1::UNAUTHENTICATED, "abort_run.token", "the token is wrong");
    }
    return set_error(reply, v1::PERMISSION_DENIED, "role",
                     "this session is an observer; control commands need the CONTROLLER role "
                     "(an abort may instead carry the control token)");
  }
  server_.renew_lease(*this);
  // Strings a request carries are bounded before anything stores or logs them.
  // An emergency stop is never refused: its reason is cut instead.
  if (body != v1::ClientMessage::kLoadProtocol && body != v1::ClientMessage::kEmergencyStop) {
    const auto issues = check_field_bounds(request, "", 1);
    if (!issues.empty()) return set_error(reply, v1::INVALID_ARGUMENT, issues.front().field, issues.front().message);
  }
  std::optional<v1::Error> error;
  switch (body) {
    case v1::ClientMessage::kLoadProtocol:
      error = service_.load_protocol(request.load_protocol().protocol(), *reply.mutable_load_protocol());
      break;
    case v1::ClientMessage::kSubscribe:
      server_.catch_up(*this);
      subscribed_ = true;
      decimation_ = std::max<std::uint32_t>(1, request.subscribe().decimation());
      reply.mutable_subscribe();
      break;
    case v1::ClientMessage::kStartRun: {
      std::optional<std::uint64_t> seed;
      if (request.start_run().has_seed()) seed = request.start_run().seed();
      error = service_.start_run(seed, *reply.mutable_start_run(), request.start_run().annotations());
      break;
    }
    case v1::ClientMessage::kAbortRun:
      error = service_.abort_run(request.abort_run().reason().empty()
                                     ? std::string("aborted by client '" + client_name_ + "'")
                                     : printable_prefix(request.abort_run().reason(), kMaxTextBytes));
      if (!error) reply.mutable_abort_run()->set_run_id(service_.status().run_id());
      break;
    case v1::ClientMessage::kGetStatus:
      status(reply);
      break;
    case v1::ClientMessage::kClaimControl:
      error = server_.claim_control(*this, request.claim_control().token());
      if (error) error->set_field("claim_control." + error->field());
      else reply.mutable_claim_control();
      break;
    case v1::ClientMessage::kReleaseControl:
      server_.release_control(*this);
      reply.mutable_release_control();
      break;
    case v1::ClientMessage::kListRuns:
      *reply.mutable_list_runs() = server_.archive().list_runs(request.list_runs());
      break;
    case v1::ClientMessage::kGetRun:
      error = server_.archive().get_run(request.get_run(), *reply.mutable_get_run());
      break;
    case v1::ClientMessage::kFetchSamples:
      error = server_.archive().fetch_samples(request.fetch_samples(), *reply.mutable_fetch_samples());
      break;
    case v1::ClientMessage::kExportCsv:
      error = server_.archive().export_csv(request.export_csv(), *reply.mutable_export_csv());
      break;
    case v1::ClientMessage::kSetGains:
      error = service_.set_gains(request.set_gains().loop(), request.set_gains().gains(),
                                 *reply.mutable_set_gains());
      break;
    case v1::ClientMessage::kGetGains:
      *reply.mutable_get_gains() = service_.gains();
      break;
    case v1::ClientMessage::kRearm:
      // The check reads the instrument over several ticks in the supervised
      // loop; this thread answers other requests (an emergency stop) meanwhile.
      deferred_ = true;
      service_.rearm_async([self = shared_from_this(), id = request.request_id()](
                               std::optional<v1::Error> e, const v1::RearmReply& result) {
        v1::ServerMessage late;
        late.set_request_id(id);
        if (e) *late.mutable_error() = *e;
        else *late.mutable_rearm() = result;
        asio::post(self->socket_.get_executor(), [self, late = std::move(late)] { self->send(late); });
      });
      return;
    case v1::ClientMessage::kEmergencyStop:
      error = service_.emergency_stop(request.emergency_stop().reason(), *reply.mutable_emergency_stop());
      break;
    case v1::ClientMessage::kAutotune:
      // The experiment runs in the supervised loop; the reply follows when it
      // ends, and every other request (an emergency stop above all) is
      // answered meanwhile.
      deferred_ = true;
      service_.autotune_async(
          request.autotune(), [self = shared_from_this(), id = request.request_id()](
                                  std::optional<v1::Error> e, const v1::AutotuneReply& result) {
            v1::ServerMessage late;
            late.set_request_id(id);
            if (e) *late.mutable_error() = *e;
            else *late.mutable_autotune() = result;
            asio::post(self->socket_.get_executor(), [self, late = std::move(late)] { self->send(late); });
          });
      return;
    default:
      error = v1::Error();
      error->set_code(v1::MALFORMED_REQUEST);
      error->set_field("body");
      error->set_message("this daemon does not handle that request");
      break;
  }
  if (error) *reply.mutable_error() = *error;
}

void ClientSession::hello(const v1::Hello& hello, v1::ServerMessage& reply) {
  if (handshake_done_) {
    return set_error(reply, v1::WRONG_STATE, "hello", "the handshake is already done");
  }
  // Control characters would forge log lines: the name is logged often.
  client_name_ = printable_prefix(hello.client_name(), 64);
  if (hello.api_version() != kApiVersion) {
    set_error(reply, v1::UNSUPPORTED_VERSION, "hello.api_version",
              "api_version " + std::to_string(hello.api_version()) +
                  " is not supported; this daemon speaks version " + std::to_string(kApiVersion));
    hang_up_ = true;
    return;
  }
  if (hello.role() == v1::CONTROLLER) {
    if (auto error = server_.claim_control(*this, hello.token())) {
      error->set_field("hello." + error->field());
      *reply.mutable_error() = *error;
      return;
    }
  }
  handshake_done_ = true;
  v1::HelloReply* out = reply.mutable_hello();
  out->set_api_version(kApiVersion);
  out->set_software_version(service_.software_version());
  out->set_backend(service_.backend_name());
  out->set_role(server_.controls(*this) ? v1::CONTROLLER : v1::OBSERVER);
  for (const char* c : {"control", "decimation", "gap-notices", "segment-events", "faults", "fetch", "export", "list"}) {
    out->add_capabilities(c);
  }
  out->set_max_frame_bytes(static_cast<std::uint32_t>(limits_.max_frame_bytes));
  out->set_control_lease_s(limits_.control_lease_s);
}

void ClientSession::status(v1::ServerMessage& reply) {
  v1::StatusReply* status = reply.mutable_status();
  *status = service_.status();
  server_.fill_status(*this, *status);
}

void ClientSession::send(const v1::ServerMessage& message) {
  auto frame = std::make_shared<std::string>();
  if (!wire::append_frame(message, kMaxOutgoingFrameBytes, *frame)) {
    spdlog::error("reply of {} bytes exceeds the frame limit", message.ByteSizeLong());
    v1::ServerMessage error;
    error.set_request_id(message.request_id());
    set_error(error, v1::INTERNAL, "", "the reply would exceed the frame limit");
    frame->clear();
    wire::append_frame(error, kMaxOutgoingFrameBytes, *frame);
  }
  send(std::move(frame));
}

void ClientSession::send(std::shared_ptr<const std::string> frame) {
  if (closed_ || !frame) return;
  // Documents and replies are small; a client that lets them pile up far
  // beyond its sample budget is not reading at all.
  if (queued_bytes_ > 2 * limits_.queue_bytes + kMaxOutgoingFrameBytes) {
    spdlog::warn("client '{}' does not read its replies; closing it", client_name_);
    return close();
  }
  queue(std::move(frame));
}

void ClientSession::offer_samples(SampleFrames& frames) {
  if (closed_ || closing_) return;
  const v1::SampleBlock& block = frames.block();
  const std::uint64_t first = block.first_sequence();
  const std::uint64_t end = first + static_cast<std::uint64_t>(sample_count(block));
  auto frame = frames.frame(decimation_);
  if (!frame) return;  // nothing of this block at this decimation
  if (queued_bytes_ + frame->size() > limits_.queue_bytes) {
    if (!pending_gap_ || pending_gap_->run_id() != block.run_id()) {
      flush_gap();
      pending_gap_.emplace();
      pending_gap_->set_run_id(block.run_id());
      pending_gap_->set_first_sequence(first);
      // Promise the recording only while it is healthy.
      pending_gap_->set_reason(service_.recording_failed()
                                   ? "this client read too slowly; the recording has failed, so these samples "
                                     "may be lost"
                                   : "this client read too slowly; the samples are in the recording");
    }
    pending_gap_->set_end_sequence(end);
    return;
  }
  flush_gap();
  queue(std::move(frame));
}

void ClientSession::flush_gap() {
  if (!pending_gap_) return;
  v1::ServerMessage notice;
  *notice.mutable_gap() = std::move(*pending_gap_);
  pending_gap_.reset();
  server_.count_gap_notice();
  queue(frame_of(notice));
}

void ClientSession::queue(std::shared_ptr<const std::string> frame) {
  if (closed_) return;
  queued_bytes_ += frame->size();
  write_queue_.push_back(std::move(frame));
  if (frames_in_flight_ == 0) write_next();
}

// Writes up to kMaxFramesPerWrite queued frames in one gathered write.
void ClientSession::write_next() {
  if (write_queue_.empty()) {
    if (closing_) close();
    return;
  }
  write_buffers_.clear();
  for (const auto& frame : write_queue_) {
    if (write_buffers_.size() == kMaxFramesPerWrite) break;
    write_buffers_.push_back(asio::buffer(*frame));
  }
  frames_in_flight_ = write_buffers_.size();
  asio::async_write(socket_, write_buffers_, [self = shared_from_this()](std::error_code ec, std::size_t) {
    if (ec) return self->close();
    for (; self->frames_in_flight_ > 0; --self->frames_in_flight_) {
      self->queued_bytes_ -= self->write_queue_.front()->size();
      self->write_queue_.pop_front();
    }
    self->write_next();
  });
}

void ClientSession::close_after_writes() {
  closing_ = true;
  if (frames_in_flight_ == 0) close();
}

void ClientSession::close() {
  if (closed_) return;
  closed_ = true;
  server_.release_partial(partial_bytes_);
  timer_.cancel();
  std::error_code ignored;
  socket_.shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
  socket_.close(ignored);
  write_queue_.clear();
  queued_bytes_ = 0;
  frames_in_flight_ = 0;
  server_.remove(this);
}

}  // namespace tribo::daemon
