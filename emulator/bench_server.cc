#include "emulator/bench_server.h"

#include <arpa/inet.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <thread>

#include <spdlog/spdlog.h>

#include "hal/modbus_blocks.h"
#include "hal/modbus_link.h"
#include "sim/instrument_params.h"

namespace tribo::bench {

namespace {

constexpr std::uint8_t kWriteMultipleRegisters = 0x10;
constexpr std::uint8_t kWriteSingleRegister = 0x06;
constexpr std::uint8_t kReadHoldingRegisters = 0x03;
constexpr std::uint8_t kReadInputRegisters = 0x04;
constexpr std::uint8_t kReadWriteRegisters = 0x17;

unsigned be16(const std::uint8_t* p) { return static_cast<unsigned>(p[0]) << 8 | p[1]; }

bool overlaps(unsigned a, unsigned a_count, unsigned b, unsigned b_count) {
  return a < b + b_count && b < a + a_count;
}

std::vector<v1::BenchFault> fault_list(const v1::BenchConfig& b) {
  return {b.faults().begin(), b.faults().end()};
}

}  // namespace

BenchServer::BenchServer(const BenchSetup& setup)
    : setup_(setup),
      map_(hal::register_map_from_config(setup.modbus.modbus().register_map())),
      instrument_(map_, sim::instrument_params_from_config(setup.physics.sim()),
                  1.0 / setup.modbus.controller().loop_rate_hz(), setup.physics.sim().seed()),
      faults_(fault_list(setup.bench)) {
  const v1::BenchConfig& b = setup_.bench;
  rtu_ = !b.rtu().device().empty();
  if (rtu_) {
    const hal::LinkSettings s = [&] {
      v1::ModbusConfig c;
      *c.mutable_rtu() = b.rtu();
      return hal::link_settings_from_config(c);
    }();
    ctx_ = modbus_new_rtu(s.device.c_str(), s.baud, s.parity, s.data_bits, s.stop_bits);
    if (ctx_ == nullptr || modbus_set_slave(ctx_, static_cast<int>(setup_.modbus.modbus().unit_id())) != 0 ||
        modbus_connect(ctx_) != 0) {
      throw std::runtime_error("cannot open " + s.device + ": " + modbus_strerror(errno));
    }
    return;
  }
  ctx_ = modbus_new_tcp(b.bind_address().c_str(), static_cast<int>(b.port()));
  if (ctx_ == nullptr) throw std::runtime_error(std::string("modbus_new_tcp: ") + modbus_strerror(errno));
  listen_socket_ = modbus_tcp_listen(ctx_, 8);
  if (listen_socket_ < 0) {
    throw std::runtime_error("cannot listen on " + b.bind_address() + ":" + std::to_string(b.port()) + ": " +
                             modbus_strerror(errno));
  }
  sockaddr_in bound{};
  socklen_t size = sizeof bound;
  getsockname(listen_socket_, reinterpret_cast<sockaddr*>(&bound), &size);
  port_ = ntohs(bound.sin_port);
}

BenchServer::~BenchServer() {
  for (int c : clients_) close(c);
  if (listen_socket_ >= 0) close(listen_socket_);
  if (rtu_ && ctx_ != nullptr) modbus_close(ctx_);
  if (ctx_ != nullptr) modbus_free(ctx_);
}

std::string BenchServer::endpoint() const {
  if (rtu_) return setup_.bench.rtu().device();
  return setup_.bench.bind_address() + ":" + std::to_string(port_);
}

void BenchServer::run(const std::atomic<bool>& stop) {
  std::vector<pollfd> fds;
  while (!stop.load()) {
    fds.clear();
    if (rtu_) {
      fds.push_back({modbus_get_socket(ctx_), POLLIN, 0});
    } else {
      fds.push_back({listen_socket_, POLLIN, 0});
      for (int c : clients_) fds.push_back({c, POLLIN, 0});
    }
    if (poll(fds.data(), fds.size(), 100) <= 0) continue;
    if (rtu_) {
      if (fds[0].revents != 0 && !serve_one(modbus_get_socket(ctx_))) reopen_rtu();
      continue;
    }
    if (fds[0].revents & POLLIN) accept_client();
    for (std::size_t i = 1; i < fds.size(); ++i) {
      if (fds[i].revents != 0 && !serve_one(fds[i].fd)) close_client(fds[i].fd);
    }
  }
}

void BenchServer::accept_client() {
  int listener = listen_socket_;
  const int client = modbus_tcp_accept(ctx_, &listener);
  if (client < 0) return;
  const int one = 1;
  setsockopt(client, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  clients_.push_back(client);
  spdlog::info("client connected ({} connected)", clients_.size());
}

void BenchServer::close_client(int socket) {
  close(socket);
  clients_.erase(std::remove(clients_.begin(), clients_.end(), socket), clients_.end());
  spdlog::info("client disconnected ({} connected)", clients_.size());
}

void BenchServer::reopen_rtu() {
  modbus_close(ctx_);
  if (modbus_connect(ctx_) != 0) spdlog::error("cannot reopen {}: {}", endpoint(), modbus_strerror(errno));
}

bool BenchServer::serve_one(int socket) {
  std::uint8_t query[MODBUS_MAX_ADU_LENGTH];
  modbus_set_socket(ctx_, socket);
  const int length = modbus_receive(ctx_, query);
  if (length < 0) return rtu_;  // TCP: closed by the client or broken; RTU: a garbled frame, keep going
  if (length == 0) return true;  // not for this unit (RTU)
  return handle(query, length);
}

bool BenchServer::handle(const std::uint8_t* query, int length) {
  const int offset = modbus_get_header_length(ctx_);
  const std::uint8_t function = query[offset];
  const unsigned address = be16(query + offset + 1);
  const unsigned count = function == kWriteSingleRegister ? 1 : be16(query + offset + 3);
  const hal::SensorBlockMap& s = map_.sensors;
  const bool reads_table_of_sensors = (function == kReadInputRegisters && s.table == hal::RegisterTable::kInput) ||
                                      (function == kReadHoldingRegisters && s.table == hal::RegisterTable::kHolding);
  const bool writes = function == kWriteMultipleRegisters || function == kWriteSingleRegister ||
                      function == kReadWriteRegisters;
  RequestKind kind = RequestKind::kOther;
  if (reads_table_of_sensors && overlaps(address, count, s.address, s.count)) kind = RequestKind::kSensorRead;
  if (writes && overlaps(address, count, map_.drive.address, map_.drive.count)) kind = RequestKind::kDriveWrite;

  if (!rtu_) {
    // The unit id must be ours, as a gateway would check it.
    const int unit = query[offset - 1];
    if (unit != static_cast<int>(setup_.modbus.modbus().unit_id())) {
      modbus_reply_exception(ctx_, query, MODBUS_EXCEPTION_GATEWAY_TARGET);
      return true;
    }
  }

  const FaultDecision fault = faults_.on_request(instrument_.steps(), kind);
  switch (fault.action) {
    case FaultAction::kIgnore:
      return true;
    case FaultAction::kDrop:
      return false;
    case FaultAction::kException:
      modbus_reply_exception(ctx_, query, static_cast<unsigned>(fault.exception_code));
      return true;
    case FaultAction::kDelay:
      std::this_thread::sleep_for(std::chrono::duration<double>(fault.delay_s));
      break;
    case FaultAction::kCorrupt: {
      instrument_.toggle_corruption();
      modbus_reply(ctx_, query, length, instrument_.mapping());
      instrument_.toggle_corruption();
      return true;
    }
    case FaultAction::kFreeze:
      modbus_reply(ctx_, query, length, instrument_.mapping());  // stored, acknowledged, not stepped
      return true;
    case FaultAction::kAnswer:
      break;
  }
  if (writes) return reply_write(query, length);
  modbus_reply(ctx_, query, length, instrument_.mapping());
  return true;
}

bool BenchServer::reply_write(const std::uint8_t* query, int length) {
  const int offset = modbus_get_header_length(ctx_);
  const std::uint8_t function = query[offset];
  const unsigned address = be16(query + offset + 1);
  const unsigned count = function == kWriteSingleRegister ? 1 : be16(query + offset + 3);
  const hal::DriveBlockMap& d = map_.drive;
  const bool drive = overlaps(address, count, d.address, d.count);
  const bool session = map_.session_address && overlaps(address, count, *map_.session_address, hal::kSessionRegisters);
  if (!drive && !session) {
    modbus_reply(ctx_, query, length, instrument_.mapping());
    return true;
  }
  // The drive and session blocks act as a whole: one write-multiple of exactly the block.
  const unsigned block_address = drive ? d.address : *map_.session_address;
  const unsigned block_count = drive ? d.count : hal::kSessionRegisters;
  if (function != kWriteMultipleRegisters || address != block_address || count != block_count) {
    modbus_reply_exception(ctx_, query, MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
    return true;
  }
  const std::uint8_t* data = query + offset + 6;
  if (drive) {
    const std::uint16_t words[2] = {static_cast<std::uint16_t>(be16(data + 2 * d.sequence_offset)),
                                    static_cast<std::uint16_t>(be16(data + 2 * (d.sequence_offset + 1)))};
    const std::uint32_t sequence = hal::uint32_from_registers(words, map_.low_word_first);
    if (instrument_.drive_repeats(sequence)) {
      modbus_reply(ctx_, query, length, instrument_.mapping());
      return true;
    }
    if (!instrument_.drive_steps(sequence)) {
      if (out_of_sequence_++ % 1000 == 0) {
        spdlog::warn("drive write with sequence {} refused: the plant is at {} ({} refused so far)", sequence,
                     instrument_.sequence(), out_of_sequence_);
      }
      modbus_reply_exception(ctx_, query, MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
      return true;
    }
    modbus_reply(ctx_, query, length, instrument_.mapping());
    instrument_.step_from_drive_block();  // after the answer: the client computes meanwhile
    return true;
  }
  modbus_reply(ctx_, query, length, instrument_.mapping());
  std::uint16_t* block = instrument_.table(hal::RegisterTable::kHolding) + *map_.session_address;
  const hal::SessionValues values = hal::decode_session_block(map_, block);
  if (values.command == hal::kSessionReset) {
    instrument_.reset(values.seed);
    faults_.rearm();
    block[4] = 0;  // done
    spdlog::info("session: plant reset with seed {}", values.seed);
  }
  return true;
}

}  // namespace tribo::bench
