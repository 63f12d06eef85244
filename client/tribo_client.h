// A blocking client for tribod's socket API, used by the `tribo` CLI, the
// benchmarks and tests. Replies are matched to requests by request id; run
// documents that arrive meanwhile are queued for next_event().
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "proto/run_files.h"
#include "tribo/v1/api.pb.h"

namespace tribo::client {

// A failed request: the daemon's typed error, or a transport failure
// (code INTERNAL, field "connection").
class ClientError : public std::runtime_error {
 public:
  explicit ClientError(v1::Error error);
  const v1::Error& error() const { return error_; }
  bool connection_lost() const { return error_.field() == "connection"; }

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
// TRIBO_TOKEN if set, else empty.
std::string default_token();

struct SessionOptions {
  std::string client_name = "tribo";
  v1::Role role = v1::OBSERVER;
  std::string token;  // the daemon's control token, for role CONTROLLER
  // How long a request waits for its reply, and next_event() for a document
  // (0: for ever). A daemon that stops answering is an error, not a hang.
  int request_timeout_ms = 60000;
  int event_timeout_ms = 0;
};

class TriboClient {
 public:
  // Connects; throws ClientError on failure. The first request must be hello().
  explicit TriboClient(const Address& address);
  // Connects and says hello; throws ClientError if either fails.
  TriboClient(const Address& address, const SessionOptions& options);
  ~TriboClient();
  TriboClient(const TriboClient&) = delete;
  TriboClient& operator=(const TriboClient&) = delete;

  v1::HelloReply hello(const SessionOptions& options);

  // Sends the request (its request_id is assigned here) and returns the reply.
  // Throws ClientError if the reply is an error.
  v1::ServerMessage request(v1::ClientMessage message);

  // The next run document (request_id 0); blocks (at most the event
  // timeout). Throws ClientError on EOF or timeout.
  v1::ServerMessage next_event();

  // From the daemon's HelloReply: its frame limit (a larger request is
  // refused here, before anything is sent) and the control lease.
  std::size_t max_frame_bytes() const { return max_frame_bytes_; }
  double control_lease_s() const { return control_lease_s_; }
  void set_timeouts(int request_timeout_ms, int event_timeout_ms) {
    request_timeout_ms_ = request_timeout_ms;
    event_timeout_ms_ = event_timeout_ms;
  }

 private:
  v1::ServerMessage read_message(int timeout_ms);
  struct Connection;
  std::unique_ptr<Connection> connection_;
  std::uint64_t next_request_id_ = 1;
  std::deque<v1::ServerMessage> events_;
  std::size_t max_frame_bytes_;
  double control_lease_s_ = 0;
  int request_timeout_ms_ = 60000;
  int event_timeout_ms_ = 0;
};

// A run's documents as the client saw them, without its samples.
struct RunDocuments {
  std::string run_id;  // from the StartRun reply
  v1::LoadProtocolReply loaded;
  v1::RunStart start;
  v1::RunDescriptor descriptor;
  std::vector<v1::SegmentEvent> segment_events;
  std::vector<v1::Fault> faults;
  std::vector<v1::GapNotice> gaps;  // what the stream missed
  v1::RunStop stop;
  std::uint64_t fetched_samples = 0;  // fetched back from the recording after gaps
  std::uint64_t missing_samples = 0;  // still missing (0 unless the recording lacks them)

  // The documents as metadata.json holds them.
  v1::RunMetadata metadata() const;
};

struct RunResult : RunDocuments {
  v1::SampleBlock samples;  // every sample, in sequence order (gaps filled from the recording)
};

// Loads the protocol, subscribes, starts, and passes each streamed sample
// block to on_samples as it arrives (in sequence order, with the holes the
// gap notices announce) until the run stops. Holds no samples itself: the
// caller fills the gaps from the recording (fetch_sample_pages). The client
// must hold control; on_document sees every run document first.
RunDocuments stream_run(TriboClient& client, const v1::Protocol& protocol, const v1::StartRun& start,
                        const std::function<void(const v1::SampleBlock&)>& on_samples,
                        const std::function<void(const v1::ServerMessage&)>& on_document = {});

// stream_run keeping every sample in memory (tests, tools, short runs;
// `tribo run` writes them to disk as they arrive instead): collects the run
// until it stops; fetches whatever the stream missed from the recording. The client
// must hold control. on_document (optional) sees every run document as it
// arrives.
// `start` carries the seed and the user's annotations; on_document runs on
// the caller's thread between reads, so it may send requests (abort).
RunResult run_protocol(TriboClient& client, const v1::Protocol& protocol, const v1::StartRun& start,
                       const std::function<void(const v1::ServerMessage&)>& on_document = {});
RunResult run_protocol(TriboClient& client, const v1::Protocol& protocol,
                       std::optional<std::uint64_t> seed,
                       const std::function<void(const v1::ServerMessage&)>& on_document = {});

// Samples [from, end) of a recorded run, page by page as the daemon sends
// them (end = UINT64_MAX: to the end of what is recorded now).
void fetch_sample_pages(TriboClient& client, const std::string& run_id, std::uint64_t from, std::uint64_t end,
                        const std::function<void(const v1::SampleBlock&)>& on_page);
// The same, gathered into one block.
v1::SampleBlock fetch_samples(TriboClient& client, const std::string& run_id, std::uint64_t from,
                              std::uint64_t end);

// A whole recorded run: its metadata and every recorded sample.
wire::RecordedRun fetch_run(TriboClient& client, const std::string& run_id);

// Writes the run's samples.csv to out as the daemon recorded it; returns the
// number of rows.
std::uint64_t export_csv(TriboClient& client, const std::string& run_id, std::ostream& out);

// The control API (the client must hold control for set_gains).
v1::GetGainsReply get_gains(TriboClient& client);
// One loop's gains from a GetGains reply, or nullopt if it lacks the loop.
std::optional<v1::PidGains> loop_gains(const v1::GetGainsReply& reply, v1::ControlLoop loop);
v1::SetGainsReply set_gains(TriboClient& client, v1::ControlLoop loop, const v1::PidGains& gains);

}  // namespace tribo::client
