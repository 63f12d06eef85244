#include "daemon/api_server.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include <spdlog/spdlog.h>

#include "daemon/client_session.h"
#include "proto/framing.h"
#include "proto/sample_record.h"

namespace tribo::daemon {

namespace {

constexpr std::size_t kDefaultClientQueueBytes = 8u << 20;
constexpr std::size_t kDefaultMaxClients = 256;
constexpr double kDefaultHandshakeTimeoutS = 5;
constexpr double kDefaultIdleTimeoutS = 300;
constexpr std::size_t kDefaultMaxPartialBytes = 64u << 20;
constexpr std::uint32_t kFreeTokenFailures = 5;  // before the back-off starts

std::shared_ptr<const std::string> frame_of(const v1::ServerMessage& message) {
  auto frame = std::make_shared<std::string>();
  wire::append_frame(message, ~std::size_t{0}, *frame);
  return frame;
}

v1::Error make_error(v1::ErrorCode code, std::string field, std::string message) {
  v1::Error e;
  e.set_code(code);
  e.set_field(std::move(field));
  e.set_message(std::move(message));
  return e;
}

}  // namespace

std::string resolve_control_token(const v1::ServerConfig& config) {
  const std::string env = config.control_token_env().empty() ? kDefaultTokenEnv : config.control_token_env();
  if (const char* value = std::getenv(env.c_str()); value != nullptr && *value != '\0') return value;
  return config.control_token();
}

std::optional<std::string> check_bind_policy(const v1::ServerConfig& config, const std::string& token) {
  std::error_code ec;
  const asio::ip::address address = asio::ip::make_address(config.bind_address(), ec);
  if (ec) return "server.bind_address = \"" + config.bind_address() + "\" is not an IP address";
  if (address.is_loopback() || !token.empty()) return std::nullopt;
  return "server.bind_address = \"" + config.bind_address() +
         "\" is not a loopback address: set server.control_token or $" +
         (config.control_token_env().empty() ? std::string(kDefaultTokenEnv) : config.control_token_env()) +
         " before serving the instrument beyond this machine";
}

ApiServer::ApiServer(asio::io_context& io, const v1::ServerConfig& config, std::string control_token)
    : io_(io),
      acceptor_(io, asio::ip::tcp::endpoint(asio::ip::make_address(config.bind_address()),
                                            static_cast<std::uint16_t>(config.port()))),
      config_(config),
      control_token_(std::move(control_token)),
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
    SessionLimits limits;
    limits.max_frame_bytes = config_.max_frame_bytes();
    limits.queue_bytes = config_.client_queue_bytes() > 0 ? config_.client_queue_bytes() : kDefaultClientQueueBytes;
    const auto seconds = [](double s, double fallback) {
      return std::chrono::duration_cast<std::chrono::steady_clock::duration>(
          std::chrono::duration<double>(s > 0 ? s : fallback));
    };
    limits.handshake_timeout = seconds(config_.handshake_timeout_s(), kDefaultHandshakeTimeoutS);
    limits.idle_timeout = seconds(config_.idle_timeout_s(), kDefaultIdleTimeoutS);
    limits.control_lease_s = config_.control_lease_s() > 0 ? config_.control_lease_s() : 0;
    auto session = std::make_shared<ClientSession>(std::move(socket), *this, *service_, limits);
    const std::size_t max_clients = config_.max_clients() > 0 ? config_.max_clients() : kDefaultMaxClients;
    if (sessions_.size() >= max_clients) {
      // Full: a connection that has not said Hello yet makes room (the
      // oldest such). Silent sockets cannot lock out `tribo estop`.
      for (const auto& s : sessions_) {
        if (!s->handshake_done()) {
          spdlog::warn("{} connections: closing the oldest that has not said hello", sessions_.size());
          auto victim = s;
          victim->close();
          break;
        }
      }
    }
    sessions_.push_back(session);
    if (sessions_.size() > max_clients) {
      v1::ServerMessage refusal;
      *refusal.mutable_error() = make_error(v1::PERMISSION_DENIED, "server.max_clients",
                                            "too many clients: the limit is " + std::to_string(max_clients));
      session->send(refusal);
      session->close_after_writes();
    } else {
      session->start();
    }
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
  if (controller_ == session) lose_controller(*session, "disconnected");
  if (closing_ && sessions_.empty()) close_deadline_.cancel();
}

bool ApiServer::token_matches(ClientSession& session, const std::string& token) {
  if (!token_required()) return true;
  const auto now = std::chrono::steady_clock::now();
  if (token_failures_ >= kFreeTokenFailures && now < token_retry_after_) return false;  // backing off
  // Constant time in the token's content: every byte is compared.
  unsigned char diff = token.size() == control_token_.size() ? 0 : 1;
  for (std::size_t i = 0; i < token.size(); ++i) {
    diff |= static_cast<unsigned char>(token[i] ^ control_token_[i % std::max<std::size_t>(1, control_token_.size())]);
  }
  if (diff == 0) {
    token_failures_ = 0;
    return true;
  }
  ++token_failures_;
  if (token_failures_ >= kFreeTokenFailures) {
    // 0.1 s, doubling, at most 10 s between attempts (for every client).
    const double wait_s = std::min(10.0, 0.1 * std::pow(2.0, std::min<std::uint32_t>(token_failures_ - kFreeTokenFailures, 10)));
    token_retry_after_ = now + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                   std::chrono::duration<double>(wait_s));
  }
  ++token_failures_unlogged_;
  if (now - last_token_log_ > std::chrono::seconds(10)) {
    spdlog::warn("wrong control token from client '{}' ({} wrong tokens since the last report)", session.name(),
                 token_failures_unlogged_);
    token_failures_unlogged_ = 0;
    last_token_log_ = now;
  }
  return false;
}

void ApiServer::renew_lease(ClientSession& session) {
  if (controller_ != &session || !(config_.control_lease_s() > 0)) return;
  lease_expiry_ = std::chrono::steady_clock::now() +
                  std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                      std::chrono::duration<double>(config_.control_lease_s()));
}

void ApiServer::check_lease(ClientSession& session, std::chrono::steady_clock::time_point now) {
  if (controller_ != &session || !(config_.control_lease_s() > 0) || now < lease_expiry_) return;
  lose_controller(session, "its control lease lapsed (no request within server.control_lease_s)");
}

void ApiServer::lose_controller(ClientSession& session, const char* why) {
  if (controller_ != &session) return;
  controller_ = nullptr;
  const bool abort = config_.on_controller_loss() != v1::CONTINUE_RUN;
  if (!closing_ && run_active_) {
    spdlog::warn("the controlling client '{}' {} during run {}: {}", session.name(), why, run_id_,
                 abort ? "aborting it" : "the run continues");
    if (abort) (void)service_->abort_run(std::string("the controlling client ") + why);
  } else {
    spdlog::info("the controlling client '{}' {}", session.name(), why);
  }
}

bool ApiServer::reserve_partial(std::size_t& held, std::size_t n) {
  const std::size_t limit = config_.max_pending_bytes() > 0 ? config_.max_pending_bytes() : kDefaultMaxPartialBytes;
  if (partial_bytes_ + n > limit) return false;
  partial_bytes_ += n;
  held += n;
  return true;
}

void ApiServer::release_partial(std::size_t& held) {
  partial_bytes_ -= std::min(partial_bytes_, held);
  held = 0;
}

std::optional<v1::Error> ApiServer::claim_control(ClientSession& session, const std::string& token) {
  if (!token_matches(session, token)) {
    return make_error(v1::UNAUTHENTICATED, "token",
                      token.empty() ? "control needs the daemon's token" : "the token is wrong (or tried too often)");
  }
  if (controller_ != nullptr && controller_ != &session) {
    return make_error(v1::PERMISSION_DENIED, "role",
                      "client '" + controller_->name() + "' holds control; one controller at a time");
  }
  controller_ = &session;
  renew_lease(session);
  return std::nullopt;
}

void ApiServer::release_control(ClientSession& session) {
  if (controller_ == &session) controller_ = nullptr;
}

void ApiServer::fill_status(const ClientSession& session, v1::StatusReply& status) const {
  std::uint32_t observers = 0;
  for (const auto& s : sessions_) {
    if (s->handshake_done() && s.get() != controller_) ++observers;
  }
  status.set_observers(observers);
  status.set_controller_connected(controller_ != nullptr);
  status.set_role(controls(session) ? v1::CONTROLLER : v1::OBSERVER);
  status.set_gap_notices(gap_notices_);
}

void ApiServer::catch_up(ClientSession& session) {
  if (!run_active_ || session.subscribed()) return;
  session.send(run_start_frame_);
  if (descriptor_frame_) session.send(descriptor_frame_);
  if (next_sequence_ == 0) return;
  v1::ServerMessage gap;
  gap.mutable_gap()->set_run_id(run_id_);
  gap.mutable_gap()->set_first_sequence(0);
  gap.mutable_gap()->set_end_sequence(next_sequence_);
  gap.mutable_gap()->set_reason("published before this client subscribed");
  session.send(gap);
  ++gap_notices_;
}

void ApiServer::broadcast(const v1::ServerMessage& document, std::function<void()> first) {
  asio::post(io_, [this, frame = frame_of(document), stop = document.has_run_stop(),
                   first = std::move(first)] {
    if (first) first();
    const auto sessions = sessions_;
    for (const auto& s : sessions) {
      if (!s->subscribed()) continue;
      if (stop) s->flush_gap();
      s->send(frame);
    }
  });
}

void ApiServer::on_run_start(const v1::RunStart& start) {
  v1::ServerMessage message;
  *message.mutable_run_start() = start;
  broadcast(message, [this, frame = frame_of(message), id = start.run_id()] {
    run_active_ = true;
    run_id_ = id;
    next_sequence_ = 0;
    run_start_frame_ = frame;
    descriptor_frame_.reset();
  });
}

void ApiServer::on_descriptor(const v1::RunDescriptor& descriptor) {
  v1::ServerMessage message;
  *message.mutable_run_descriptor() = descriptor;
  broadcast(message, [this, frame = frame_of(message)] { descriptor_frame_ = frame; });
}

void ApiServer::on_samples(const v1::SampleBlock& block) {
  // Serialized here, off the io thread; shared by every session that takes
  // all samples.
  v1::ServerMessage message;
  *message.mutable_samples() = block;
  auto frames = std::make_shared<SampleFrames>(std::make_shared<const v1::SampleBlock>(block),
                                               frame_of(message));
  asio::post(io_, [this, frames = std::move(frames)] {
    next_sequence_ = frames->block().first_sequence() + static_cast<std::uint64_t>(sample_count(frames->block()));
    const auto sessions = sessions_;
    for (const auto& s : sessions) {
      if (s->subscribed()) s->offer_samples(*frames);
    }
  });
}

void ApiServer::on_segment_event(const v1::SegmentEvent& event) {
  v1::ServerMessage message;
  *message.mutable_segment_event() = event;
  broadcast(message);
}

void ApiServer::on_fault(const v1::Fault& fault) {
  v1::ServerMessage message;
  *message.mutable_fault() = fault;
  broadcast(message);
}

void ApiServer::on_run_stop(const v1::RunStop& stop) {
  v1::ServerMessage message;
  *message.mutable_run_stop() = stop;
  broadcast(message, [this] { run_active_ = false; });
}

}  // namespace tribo::daemon
