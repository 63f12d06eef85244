// The socket API: accepts TCP connections (127.0.0.1 by default), decodes
// length-delimited ClientMessage frames, dispatches them to the
// InstrumentService and streams run documents to subscribed clients. All
// session state lives on the io_context's thread; run documents arriving from
// the service's threads are posted onto it.
#pragma once

#include <chrono>
#include <cstdint>
#include <list>
#include <memory>

#include <asio.hpp>

#include "daemon/instrument_service.h"
#include "tribo/v1/daemon_config.pb.h"

namespace tribo::daemon {

class ClientSession;

class ApiServer : public RunEventSink {
 public:
  // Binds and listens; throws std::system_error if the address is unusable.
  ApiServer(asio::io_context& io, const v1::ServerConfig& config);
  ~ApiServer() override;

  void attach(InstrumentService& service) { service_ = &service; }
  void start_accepting();
  std::uint16_t port() const { return acceptor_.local_endpoint().port(); }

  // Stops accepting and closes every session once its queued frames are sent,
  // or at the latest after `deadline` (a client that never reads cannot hold
  // the daemon open). Thread-safe.
  void close_gracefully(std::chrono::milliseconds deadline);

  void on_run_start(const v1::RunStart& start) override;
  void on_samples(const v1::SampleBlock& block) override;
  void on_run_stop(const v1::RunStop& stop) override;

 private:
  friend class ClientSession;
  void accept_next();
  void broadcast(std::shared_ptr<const std::string> frame,
                 std::shared_ptr<const v1::SampleBlock> samples);
  void remove(ClientSession* session);

  asio::io_context& io_;
  asio::ip::tcp::acceptor acceptor_;
  std::size_t max_frame_bytes_;
  InstrumentService* service_ = nullptr;
  std::list<std::shared_ptr<ClientSession>> sessions_;
  asio::steady_timer close_deadline_;
  bool closing_ = false;
};

}  // namespace tribo::daemon
