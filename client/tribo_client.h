// A blocking client for tribod's socket API, used by the `tribo` CLI and by
// tests. Replies are matched to requests by request id; run documents that
// arrive meanwhile are queued for next_event().
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "tribo/v1/api.pb.h"

namespace tribo::client {

// A failed request: the daemon's typed error, or a transport failure
// (code INTERNAL, field "connection").
class ClientError : public std::runtime_error {
 public:
  explicit ClientError(v1::Error error);
  const v1::Error& error() const { return error_; }

 private:
  v1::Error error_;
};

struct Address {
  std::string host;
  std::uint16_t port = 0;
};

// "host:port" or "port"; nullopt if malformed.
std::optional<Address> parse_address(const std::string& text);
// TRIBO_ADDRESS if set, else the daemon's default.
Address default_address();

class TriboClient {
 public:
  // Connects; throws ClientError on failure.
  explicit TriboClient(const Address& address);
  ~TriboClient();
  TriboClient(const TriboClient&) = delete;
  TriboClient& operator=(const TriboClient&) = delete;

  // Sends the request (its request_id is assigned here) and returns the reply.
  // Throws ClientError if the reply is an error.
  v1::ServerMessage request(v1::ClientMessage message);

  // The next run document (request_id 0); blocks. Throws ClientError on EOF.
  v1::ServerMessage next_event();

 private:
  v1::ServerMessage read_message();
  struct Connection;
  std::unique_ptr<Connection> connection_;
  std::uint64_t next_request_id_ = 1;
  std::deque<v1::ServerMessage> events_;
};

struct RunResult {
  v1::LoadProtocolReply loaded;
  v1::RunStart start;
  v1::SampleBlock samples;  // every sample, in sequence order
  v1::RunStop stop;
  std::uint64_t missing_samples = 0;  // sequence gaps seen while streaming
};

// Loads the protocol, subscribes, starts, and collects the run until it
// stops. on_samples (optional) sees each block as it arrives.
RunResult run_protocol(TriboClient& client, const v1::Protocol& protocol,
                       std::optional<std::uint64_t> seed,
                       const std::function<void(const v1::SampleBlock&)>& on_samples = {});

}  // namespace tribo::client
