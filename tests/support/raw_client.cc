#include "tests/support/raw_client.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <stdexcept>

namespace tribo::testing {

RawClient::RawClient(std::uint16_t port, int receive_buffer_bytes) {
  fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd_ < 0) throw std::runtime_error("socket failed");
  if (receive_buffer_bytes > 0) {
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &receive_buffer_bytes, sizeof receive_buffer_bytes);
  }
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd_);
    throw std::runtime_error("connect failed");
  }
}

RawClient::~RawClient() { close(); }

void RawClient::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

void RawClient::send_bytes(const std::string& bytes) {
  std::size_t sent = 0;
  while (sent < bytes.size()) {
    const ssize_t n = ::send(fd_, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) throw std::runtime_error("send failed");
    sent += static_cast<std::size_t>(n);
  }
}

void RawClient::send(const v1::ClientMessage& message) {
  std::string frame;
  wire::append_frame(message, wire::kDefaultMaxFrameBytes, frame);
  send_bytes(frame);
}

std::optional<v1::ServerMessage> RawClient::read(int timeout_ms) {
  if (!held_.empty()) {
    v1::ServerMessage m = std::move(held_.front());
    held_.pop_front();
    return m;
  }
  return read_frame(timeout_ms);
}

std::optional<v1::ServerMessage> RawClient::read_frame(int timeout_ms) {
  std::string frame;
  for (;;) {
    const wire::DecodeStatus status = decoder_.next(frame);
    if (status == wire::DecodeStatus::kFrame) break;
    if (status != wire::DecodeStatus::kNeedMore) return std::nullopt;
    if (unfed_.empty()) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, timeout_ms) <= 0) return std::nullopt;
      std::array<char, 65536> buf;
      const ssize_t n = ::recv(fd_, buf.data(), buf.size(), 0);
      if (n <= 0) return std::nullopt;
      unfed_.assign(buf.data(), static_cast<std::size_t>(n));
    }
    unfed_.erase(0, decoder_.feed(unfed_));
  }
  v1::ServerMessage message;
  if (!message.ParseFromString(frame)) return std::nullopt;
  return message;
}

bool RawClient::closed_by_peer(int timeout_ms) {
  std::array<char, 65536> buf;
  for (;;) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, timeout_ms) <= 0) return false;
    const ssize_t n = ::recv(fd_, buf.data(), buf.size(), 0);
    if (n <= 0) return true;
  }
}

v1::ServerMessage RawClient::request(v1::ClientMessage message) {
  const std::uint64_t id = next_id_++;
  message.set_request_id(id);
  send(message);
  for (;;) {
    auto reply = read_frame(20000);
    if (!reply) throw std::runtime_error("no reply to request " + std::to_string(id));
    if (reply->request_id() == id) return *reply;
    if (reply->request_id() == 0 && !reply->has_error()) held_.push_back(std::move(*reply));
  }
}

v1::ClientMessage hello_message(v1::Role role, const std::string& token, std::uint32_t api_version) {
  v1::ClientMessage m;
  m.mutable_hello()->set_api_version(api_version);
  m.mutable_hello()->set_client_name("test");
  m.mutable_hello()->set_role(role);
  m.mutable_hello()->set_token(token);
  return m;
}

}  // namespace tribo::testing
