#include "client/tribo_client.h"

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

TriboClient::TriboClient(const Address& address) : connection_(std::make_unique<Connection>()) {
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

TriboClient::~TriboClient() = default;

v1::ServerMessage TriboClient::read_message() {
  Connection& c = *connection_;
  std::string frame;
  for (;;) {
    const wire::DecodeStatus status = c.decoder.next(frame);
    if (status == wire::DecodeStatus::kFrame) break;
    if (status != wire::DecodeStatus::kNeedMore) {
      throw ClientError(connection_error("the daemon sent an invalid frame"));
    }
    if (c.unfed.empty()) {
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
  wire::append_frame(message, wire::kDefaultMaxFrameBytes, frame);
  std::error_code ec;
  asio::write(connection_->socket, asio::buffer(frame), ec);
  if (ec) throw ClientError(connection_error("cannot send to tribod: " + ec.message()));
  for (;;) {
    v1::ServerMessage reply = read_message();
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
    v1::ServerMessage message = read_message();
    if (message.request_id() == 0) return message;
  }
}

RunResult run_protocol(TriboClient& client, const v1::Protocol& protocol,
                       std::optional<std::uint64_t> seed,
                       const std::function<void(const v1::SampleBlock&)>& on_samples) {
  RunResult result;
  v1::ClientMessage hello;
  hello.mutable_hello()->set_api_version(wire::kApiVersion);
  hello.mutable_hello()->set_client_name("tribo");
  client.request(hello);

  v1::ClientMessage load;
  *load.mutable_load_protocol()->mutable_protocol() = protocol;
  result.loaded = client.request(load).load_protocol();

  v1::ClientMessage subscribe;
  subscribe.mutable_subscribe();
  client.request(subscribe);

  v1::ClientMessage start;
  if (seed) start.mutable_start_run()->set_seed(*seed);
  else start.mutable_start_run();
  const std::string run_id = client.request(start).start_run().run_id();

  for (;;) {
    v1::ServerMessage event = client.next_event();
    if (event.has_run_start() && event.run_start().run_id() == run_id) {
      result.start = event.run_start();
    } else if (event.has_samples() && event.samples().run_id() == run_id) {
      const v1::SampleBlock& block = event.samples();
      const auto received = static_cast<std::uint64_t>(sample_count(result.samples));
      if (block.first_sequence() > received) result.missing_samples += block.first_sequence() - received;
      append_block(block, result.samples);
      if (on_samples) on_samples(block);
    } else if (event.has_run_stop() && event.run_stop().run_id() == run_id) {
      result.stop = event.run_stop();
      break;
    }
  }
  result.samples.set_run_id(run_id);
  return result;
}

}  // namespace tribo::client
