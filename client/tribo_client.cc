#include "client/tribo_client.h"

#include <poll.h>

#include <chrono>

#include <algorithm>
#include <array>
#include <cstdlib>

#include <asio.hpp>

#include "proto/api_defaults.h"
#include "proto/framing.h"
#include "proto/sample_record.h"

namespace tribo::client {

namespace {

v1::Error connection_error(const std::string& message) {
  v1::Error e;
  e.set_code(v1::INTERNAL);
  e.set_field("connection");
  e.set_message(message);
  return e;
}

}  // namespace

ClientError::ClientError(v1::Error error)
    : std::runtime_error(error.field().empty() ? error.message()
                                               : error.field() + ": " + error.message()),
      error_(std::move(error)) {}

std::optional<Address> parse_address(const std::string& text) {
  const auto colon = text.rfind(':');
  const std::string host = colon == std::string::npos ? wire::kDefaultHost : text.substr(0, colon);
  const std::string port = colon == std::string::npos ? text : text.substr(colon + 1);
  char* end = nullptr;
  const unsigned long value = std::strtoul(port.c_str(), &end, 10);
  if (port.empty() || *end != '\0' || value == 0 || value > 65535 || host.empty()) return std::nullopt;
  return Address{host, static_cast<std::uint16_t>(value)};
}

std::string default_token() {
  const char* env = std::getenv("TRIBO_TOKEN");
  return env == nullptr ? std::string() : std::string(env);
}

Address default_address() {
  if (const char* env = std::getenv("TRIBO_ADDRESS")) {
    if (auto a = parse_address(env)) return *a;
  }
  return Address{wire::kDefaultHost, wire::kDefaultPort};
}

struct TriboClient::Connection {
  asio::io_context io;
  asio::ip::tcp::socket socket{io};
  wire::FrameDecoder decoder{wire::kDefaultMaxFrameBytes};
  std::array<char, 64 * 1024> buffer{};
  std::string_view unfed;  // bytes read but not yet taken by the decoder
};

TriboClient::TriboClient(const Address& address)
    : connection_(std::make_unique<Connection>()), max_frame_bytes_(wire::kDefaultMaxFrameBytes) {
  std::error_code ec;
  asio::ip::tcp::resolver resolver(connection_->io);
  const auto endpoints = resolver.resolve(address.host, std::to_string(address.port), ec);
  if (!ec) asio::connect(connection_->socket, endpoints, ec);
  if (ec) {
    throw ClientError(connection_error("cannot connect to tribod at " + address.host + ":" +
                                       std::to_string(address.port) + ": " + ec.message()));
  }
  connection_->socket.set_option(asio::ip::tcp::no_delay(true), ec);
}

TriboClient::TriboClient(const Address& address, const SessionOptions& options) : TriboClient(address) {
  set_timeouts(options.request_timeout_ms, options.event_timeout_ms);
  hello(options);
}

TriboClient::~TriboClient() = default;

v1::HelloReply TriboClient::hello(const SessionOptions& options) {
  v1::ClientMessage message;
  v1::Hello* hello = message.mutable_hello();
  hello->set_api_version(wire::kApiVersion);
  hello->set_client_name(options.client_name);
  hello->set_role(options.role);
  hello->set_token(options.token);
  v1::HelloReply reply = request(message).hello();
  if (reply.max_frame_bytes() > 0) max_frame_bytes_ = std::min<std::size_t>(reply.max_frame_bytes(), wire::kDefaultMaxFrameBytes);
  control_lease_s_ = reply.control_lease_s();
  return reply;
}

v1::ServerMessage TriboClient::read_message(int timeout_ms) {
  Connection& c = *connection_;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  std::string frame;
  for (;;) {
    const wire::DecodeStatus status = c.decoder.next(frame);
    if (status == wire::DecodeStatus::kFrame) break;
    if (status != wire::DecodeStatus::kNeedMore) {
      throw ClientError(connection_error("the daemon sent an invalid frame"));
    }
    if (c.unfed.empty()) {
      if (timeout_ms > 0) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
        pollfd p{c.socket.native_handle(), POLLIN, 0};
        if (left.count() <= 0 || ::poll(&p, 1, static_cast<int>(left.count())) == 0) {
          throw ClientError(connection_error("tribod did not answer within " + std::to_string(timeout_ms) + " ms"));
        }
      }
      std::error_code ec;
      const std::size_t n = c.socket.read_some(asio::buffer(c.buffer), ec);
      if (ec) throw ClientError(connection_error("connection to tribod lost: " + ec.message()));
      c.unfed = std::string_view(c.buffer.data(), n);
    }
    c.unfed.remove_prefix(c.decoder.feed(c.unfed));
  }
  v1::ServerMessage message;
  if (!message.ParseFromString(frame)) {
    throw ClientError(connection_error("the daemon sent an undecodable message"));
  }
  return message;
}

v1::ServerMessage TriboClient::request(v1::ClientMessage message) {
  const std::uint64_t id = next_request_id_++;
  message.set_request_id(id);
  std::string frame;
  if (!wire::append_frame(message, max_frame_bytes_, frame)) {
    // Sending it would only make the daemon hang up; say why instead.
    v1::Error e;
    e.set_code(v1::INVALID_ARGUMENT);
    e.set_field("frame");
    e.set_message("the request is " + std::to_string(message.ByteSizeLong()) +
                  " bytes, above the daemon's frame limit of " + std::to_string(max_frame_bytes_) + " bytes");
    throw ClientError(e);
  }
  std::error_code ec;
  asio::write(connection_->socket, asio::buffer(frame), ec);
  if (ec) throw ClientError(connection_error("cannot send to tribod: " + ec.message()));
  for (;;) {
    v1::ServerMessage reply = read_message(request_timeout_ms_);
    if (reply.request_id() == 0 && !reply.has_error()) {
      events_.push_back(std::move(reply));
      continue;
    }
    if (reply.has_error()) throw ClientError(reply.error());
    if (reply.request_id() == id) return reply;
  }
}

v1::ServerMessage TriboClient::next_event() {
  if (!events_.empty()) {
    v1::ServerMessage event = std::move(events_.front());
    events_.pop_front();
    return event;
  }
  for (;;) {
    v1::ServerMessage message = read_message(event_timeout_ms_);
    if (message.request_id() == 0) return message;
  }
}

namespace {

// Orders blocks by sequence and concatenates them; counts what is missing.
v1::SampleBlock concatenate(std::vector<v1::SampleBlock> blocks, std::uint64_t& missing) {
  std::sort(blocks.begin(), blocks.end(),
            [](const auto& a, const auto& b) { return a.first_sequence() < b.first_sequence(); });
  v1::SampleBlock out;
  missing = 0;
  std::uint64_t next = 0;
  for (const auto& b : blocks) {
    if (sample_count(b) == 0 || b.first_sequence() + static_cast<std::uint64_t>(sample_count(b)) <= next) continue;
    if (b.first_sequence() > next) missing += b.first_sequence() - next;
    if (b.first_sequence() < next) {  // overlaps what we have: take the new tail only
      v1::SampleBlock tail;
      for (int i = static_cast<int>(next - b.first_sequence()); i < sample_count(b); ++i) {
        append_sample(sample_at(b, i), tail);
      }
      append_block(tail, out);
    } else {
      append_block(b, out);
    }
    next = b.first_sequence() + static_cast<std::uint64_t>(sample_count(b));
  }
  return out;
}

}  // namespace

RunResult run_protocol(TriboClient& client, const v1::Protocol& protocol,
                       std::optional<std::uint64_t> seed,
                       const std::function<void(const v1::ServerMessage&)>& on_document) {
  v1::StartRun start;
  if (seed) start.set_seed(*seed);
  return run_protocol(client, protocol, start, on_document);
}

v1::RunMetadata RunDocuments::metadata() const {
  v1::RunMetadata m;
  *m.mutable_start() = start;
  *m.mutable_stop() = stop;
  *m.mutable_run_descriptor() = descriptor;
  for (const auto& e : segment_events) *m.add_segment_events() = e;
  for (const auto& f : faults) *m.add_faults() = f;
  return m;
}

RunDocuments stream_run(TriboClient& client, const v1::Protocol& protocol, const v1::StartRun& start_run,
                        const std::function<void(const v1::SampleBlock&)>& on_samples,
                        const std::function<void(const v1::ServerMessage&)>& on_document) {
  RunDocuments result;
  v1::ClientMessage load;
  *load.mutable_load_protocol()->mutable_protocol() = protocol;
  result.loaded = client.request(load).load_protocol();

  v1::ClientMessage subscribe;
  subscribe.mutable_subscribe();
  client.request(subscribe);

  v1::ClientMessage start;
  *start.mutable_start_run() = start_run;
  result.run_id = client.request(start).start_run().run_id();
  const std::string& run_id = result.run_id;

  // A lease (server.control_lease_s) needs a request now and then: the
  // stream brings a document at least every 50 ms while the run goes.
  const auto lease = std::chrono::duration<double>(client.control_lease_s() / 3);
  auto next_heartbeat = std::chrono::steady_clock::now() + lease;
  for (;;) {
    if (client.control_lease_s() > 0 && std::chrono::steady_clock::now() >= next_heartbeat) {
      v1::ClientMessage heartbeat;
      heartbeat.mutable_get_status();
      client.request(heartbeat);
      next_heartbeat = std::chrono::steady_clock::now() + lease;
    }
    v1::ServerMessage event = client.next_event();
    if (on_document) on_document(event);
    if (event.has_run_start() && event.run_start().run_id() == run_id) {
      result.start = event.run_start();
    } else if (event.has_run_descriptor() && event.run_descriptor().run_id() == run_id) {
      result.descriptor = event.run_descriptor();
    } else if (event.has_samples() && event.samples().run_id() == run_id) {
      on_samples(event.samples());
    } else if (event.has_segment_event() && event.segment_event().run_id() == run_id) {
      result.segment_events.push_back(event.segment_event());
    } else if (event.has_fault() && event.fault().run_id() == run_id) {
      result.faults.push_back(event.fault());
    } else if (event.has_gap() && event.gap().run_id() == run_id) {
      result.gaps.push_back(event.gap());
    } else if (event.has_run_stop() && event.run_stop().run_id() == run_id) {
      result.stop = event.run_stop();
      break;
    }
  }
  return result;
}

RunResult run_protocol(TriboClient& client, const v1::Protocol& protocol, const v1::StartRun& start_run,
                       const std::function<void(const v1::ServerMessage&)>& on_document) {
  std::vector<v1::SampleBlock> blocks;
  RunResult result;
  static_cast<RunDocuments&>(result) = stream_run(
      client, protocol, start_run, [&](const v1::SampleBlock& b) { blocks.push_back(b); }, on_document);
  const std::string& run_id = result.run_id;
  // Resume: what the stream missed is in the recording.
  for (const auto& gap : result.gaps) {
    blocks.push_back(fetch_samples(client, run_id, gap.first_sequence(), gap.end_sequence()));
    result.fetched_samples += static_cast<std::uint64_t>(sample_count(blocks.back()));
  }
  std::uint64_t holes = 0;
  result.samples = concatenate(std::move(blocks), holes);
  const auto have = static_cast<std::uint64_t>(sample_count(result.samples));
  result.missing_samples = result.stop.sample_count() > have ? result.stop.sample_count() - have : holes;
  result.samples.set_run_id(run_id);
  return result;
}

void fetch_sample_pages(TriboClient& client, const std::string& run_id, std::uint64_t from, std::uint64_t end,
                        const std::function<void(const v1::SampleBlock&)>& on_page) {
  while (from < end) {
    v1::ClientMessage request;
    v1::FetchSamples* fetch = request.mutable_fetch_samples();
    fetch->set_run_id(run_id);
    fetch->set_from_sequence(from);
    if (end != ~std::uint64_t{0}) fetch->set_max_samples(end - from);
    const v1::ServerMessage reply = client.request(request);
    const v1::FetchSamplesReply& page = reply.fetch_samples();
    on_page(page.samples());
    if (page.next_sequence() == from) break;  // nothing more recorded
    from = page.next_sequence();
    if (page.end_of_recording()) break;
  }
}

v1::SampleBlock fetch_samples(TriboClient& client, const std::string& run_id, std::uint64_t from,
                              std::uint64_t end) {
  v1::SampleBlock out;
  out.set_run_id(run_id);
  out.set_first_sequence(from);
  fetch_sample_pages(client, run_id, from, end, [&](const v1::SampleBlock& page) { append_block(page, out); });
  return out;
}

wire::RecordedRun fetch_run(TriboClient& client, const std::string& run_id) {
  wire::RecordedRun run;
  v1::ClientMessage request;
  request.mutable_get_run()->set_run_id(run_id);
  run.metadata = client.request(request).get_run().metadata();
  run.samples = fetch_samples(client, run_id, 0, ~std::uint64_t{0});
  return run;
}

std::uint64_t export_csv(TriboClient& client, const std::string& run_id, std::ostream& out) {
  std::uint64_t from = 0;
  for (;;) {
    v1::ClientMessage request;
    request.mutable_export_csv()->set_run_id(run_id);
    request.mutable_export_csv()->set_from_sequence(from);
    const v1::ServerMessage reply = client.request(request);
    const v1::ExportCsvReply& page = reply.export_csv();
    out << page.csv();
    if (page.next_sequence() == from || page.end_of_recording()) return page.next_sequence();
    from = page.next_sequence();
  }
}

v1::GetGainsReply get_gains(TriboClient& client) {
  v1::ClientMessage request;
  request.mutable_get_gains();
  return client.request(request).get_gains();
}

std::optional<v1::PidGains> loop_gains(const v1::GetGainsReply& reply, v1::ControlLoop loop) {
  for (const auto& l : reply.loops()) {
    if (l.loop() == loop) return l.gains();
  }
  return std::nullopt;
}

v1::SetGainsReply set_gains(TriboClient& client, v1::ControlLoop loop, const v1::PidGains& gains) {
  v1::ClientMessage request;
  request.mutable_set_gains()->set_loop(loop);
  *request.mutable_set_gains()->mutable_gains() = gains;
  return client.request(request).set_gains();
}

}  // namespace tribo::client
