// The socket API: accepts TCP connections (127.0.0.1 by default), decodes
// length-delimited ClientMessage frames, dispatches them to the
// InstrumentService and streams run documents to subscribed clients. All
// session state lives on the io_context's thread; run documents arriving from
// the service's threads are posted onto it.
//
// Who may do what: any number of observers; at most one session holds
// control, having shown the control token (when one is configured). When the
// controlling session goes away mid-run, server.on_controller_loss decides:
// abort the run safely, or let it continue.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <optional>
#include <string>

#include <asio.hpp>

#include "daemon/instrument_service.h"
#include "daemon/run_archive.h"
#include "tribo/v1/daemon_config.pb.h"

namespace tribo::daemon {

class ClientSession;

inline constexpr const char* kDefaultTokenEnv = "TRIBOD_CONTROL_TOKEN";

// The control token: $<control_token_env> when set and not empty, else the
// config's control_token (may be empty: no token).
std::string resolve_control_token(const v1::ServerConfig& config);

// Binding outside the loopback range without a token would hand the
// instrument to the network: that is refused. Returns the reason, or nullopt.
std::optional<std::string> check_bind_policy(const v1::ServerConfig& config, const std::string& token);

class ApiServer : public RunEventSink {
 public:
  // Binds and listens; throws std::system_error if the address is unusable.
  ApiServer(asio::io_context& io, const v1::ServerConfig& config, std::string control_token);
  ~ApiServer() override;

  void attach(InstrumentService& service) {
    service_ = &service;
    archive_.emplace(service.config().recorder().data_dir());
  }
  void start_accepting();
  std::uint16_t port() const { return acceptor_.local_endpoint().port(); }

  // Stops accepting and closes every session once its queued frames are sent,
  // or at the latest after `deadline` (a client that never reads cannot hold
  // the daemon open). Thread-safe.
  void close_gracefully(std::chrono::milliseconds deadline);

  void on_run_start(const v1::RunStart& start) override;
  void on_descriptor(const v1::RunDescriptor& descriptor) override;
  void on_samples(const v1::SampleBlock& block) override;
  void on_segment_event(const v1::SegmentEvent& event) override;
  void on_fault(const v1::Fault& fault) override;
  void on_run_stop(const v1::RunStop& stop) override;

 private:
  friend class ClientSession;
  void accept_next();
  // Sends document to every subscribed session, after `first` (io thread).
  void broadcast(const v1::ServerMessage& document, std::function<void()> first = {});
  void remove(ClientSession* session);

  // For sessions (io thread).
  std::optional<v1::Error> claim_control(ClientSession& session, const std::string& token);
  // Whether token is the daemon's (constant-time; failures are rate-limited
  // and their logging throttled). No token configured: any token matches.
  bool token_matches(ClientSession& session, const std::string& token);
  // The controller's lease: renewed by each request it sends; when it lapses
  // the session loses control and on_controller_loss applies.
  void renew_lease(ClientSession& session);
  void check_lease(ClientSession& session, std::chrono::steady_clock::time_point now);
  void lose_controller(ClientSession& session, const char* why);
  // The budget of half-received frame bytes over all connections.
  bool reserve_partial(std::size_t& held, std::size_t n);
  void release_partial(std::size_t& held);
  void release_control(ClientSession& session);
  bool controls(const ClientSession& session) const { return controller_ == &session; }
  bool token_required() const { return !control_token_.empty(); }
  // Marks the session subscribed and brings it up to date with a run in
  // progress: its start, its descriptor and a gap notice for what it missed.
  void catch_up(ClientSession& session);
  void count_gap_notice() { ++gap_notices_; }
  void fill_status(const ClientSession& session, v1::StatusReply& status) const;
  RunArchive& archive() { return *archive_; }

  asio::io_context& io_;
  asio::ip::tcp::acceptor acceptor_;
  v1::ServerConfig config_;
  std::string control_token_;
  InstrumentService* service_ = nullptr;
  std::optional<RunArchive> archive_;
  std::list<std::shared_ptr<ClientSession>> sessions_;
  ClientSession* controller_ = nullptr;
  asio::steady_timer close_deadline_;
  bool closing_ = false;
  std::uint64_t gap_notices_ = 0;
  // The run being streamed, for late subscribers (io thread).
  std::shared_ptr<const std::string> run_start_frame_, descriptor_frame_;
  std::string run_id_;
  std::uint64_t next_sequence_ = 0;
  bool run_active_ = false;
  std::chrono::steady_clock::time_point lease_expiry_;
  std::size_t partial_bytes_ = 0, max_partial_bytes_ = 0;
  // Wrong tokens: after a few, further attempts wait out a back-off.
  std::uint32_t token_failures_ = 0;
  std::chrono::steady_clock::time_point token_retry_after_;
  std::chrono::steady_clock::time_point last_token_log_;
  std::uint64_t token_failures_unlogged_ = 0;
};

}  // namespace tribo::daemon
