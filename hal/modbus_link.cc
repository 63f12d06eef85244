#include "hal/modbus_link.h"

#include <arpa/inet.h>
#include <modbus/modbus.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <ctime>
#include <sstream>

#include <spdlog/spdlog.h>

namespace tribo::hal {

namespace {

std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

std::int64_t to_ns(double s) { return static_cast<std::int64_t>(std::llround(s * 1e9)); }

void set_timeout(modbus_t* ctx, double s, int (*setter)(modbus_t*, std::uint32_t, std::uint32_t)) {
  const auto us = static_cast<std::uint64_t>(std::llround(s * 1e6));
  setter(ctx, static_cast<std::uint32_t>(us / 1'000'000), static_cast<std::uint32_t>(us % 1'000'000));
}

const char* op_text(LinkOp op) {
  switch (op) {
    case LinkOp::kConnect: return "connect";
    case LinkOp::kReadSensors: return "read sensor block";
    case LinkOp::kWriteDrive: return "write drive block";
    case LinkOp::kReadIdentity: return "read identity block";
    case LinkOp::kWriteSession: return "write session block";
  }
  return "?";
}

bool is_exception(int err) { return err >= EMBXILFUN && err <= EMBXGTAR; }
bool is_protocol_error(int err) { return err >= EMBBADCRC && err <= EMBBADSLAVE; }

std::string ms(double s) {
  std::ostringstream out;
  out << s * 1e3 << " ms";
  return out.str();
}

constexpr std::uint64_t pack(LinkOp op, std::uint8_t failure, std::uint8_t sub, std::uint32_t detail) {
  return static_cast<std::uint64_t>(op) << 48 | static_cast<std::uint64_t>(failure) << 40 |
         static_cast<std::uint64_t>(sub) << 32 | detail;
}

}  // namespace

LinkSettings link_settings_from_config(const v1::ModbusConfig& c) {
  LinkSettings s;
  s.rtu = c.has_rtu();
  if (s.rtu) {
    s.device = c.rtu().device();
    s.baud = static_cast<int>(c.rtu().baud());
    s.parity = c.rtu().parity().empty() ? 'N' : c.rtu().parity()[0];
    s.data_bits = static_cast<int>(c.rtu().data_bits());
    s.stop_bits = static_cast<int>(c.rtu().stop_bits());
  } else {
    s.host = c.tcp().host();
    s.port = static_cast<int>(c.tcp().port());
  }
  s.unit_id = static_cast<int>(c.unit_id());
  s.response_timeout_s = c.response_timeout_s();
  s.byte_timeout_s = c.byte_timeout_s();
  s.max_consecutive_timeouts = c.max_consecutive_timeouts();
  s.backoff_min_s = c.reconnect_backoff_min_s();
  s.backoff_max_s = c.reconnect_backoff_max_s();
  s.log_interval_s = c.log_interval_s();
  return s;
}

std::optional<std::string> validate_link_config(const v1::ModbusConfig& c, const std::string& p) {
  const auto range = [&](const std::string& field, double value, double min, double max) -> std::optional<std::string> {
    if (value >= min && value <= max) return std::nullopt;
    std::ostringstream msg;
    msg << p << "." << field << " = " << value << ": must be in [" << min << ", " << max << "]";
    return msg.str();
  };
  switch (c.link_case()) {
    case v1::ModbusConfig::kTcp: {
      in_addr address{};
      if (inet_pton(AF_INET, c.tcp().host().c_str(), &address) != 1) {
        return p + ".tcp.host = \"" + c.tcp().host() + "\": must be a numeric IPv4 address";
      }
      if (auto e = range("tcp.port", c.tcp().port(), 1, 65535)) return e;
      break;
    }
    case v1::ModbusConfig::kRtu: {
      const auto& r = c.rtu();
      if (r.device().empty()) return p + ".rtu.device is empty";
      static constexpr unsigned kBauds[] = {1200,  2400,   4800,   9600,   19200,  38400,   57600,
                                            115200, 230400, 460800, 500000, 921600, 1000000, 2000000,
                                            3000000, 4000000};
      if (std::find(std::begin(kBauds), std::end(kBauds), r.baud()) == std::end(kBauds)) {
        return p + ".rtu.baud = " + std::to_string(r.baud()) +
               ": not a standard rate (1200, 2400, ..., 115200, 230400, ..., 4000000)";
      }
      if (r.parity() != "N" && r.parity() != "E" && r.parity() != "O") {
        return p + ".rtu.parity = \"" + r.parity() + "\": must be \"N\", \"E\" or \"O\"";
      }
      if (auto e = range("rtu.data_bits", r.data_bits(), 7, 8)) return e;
      if (auto e = range("rtu.stop_bits", r.stop_bits(), 1, 2)) return e;
      break;
    }
    case v1::ModbusConfig::LINK_NOT_SET:
      return p + ": no link (set tcp { ... } or rtu { ... })";
  }
  if (auto e = range("unit_id", c.unit_id(), 1, 247)) return e;
  if (auto e = range("response_timeout_s", c.response_timeout_s(), 1e-4, 10)) return e;
  if (auto e = range("byte_timeout_s", c.byte_timeout_s(), 1e-5, c.response_timeout_s())) return e;
  if (auto e = range("max_consecutive_timeouts", c.max_consecutive_timeouts(), 1, 1000)) return e;
  if (auto e = range("reconnect_backoff_min_s", c.reconnect_backoff_min_s(), 1e-3, 60)) return e;
  if (auto e = range("reconnect_backoff_max_s", c.reconnect_backoff_max_s(), c.reconnect_backoff_min_s(), 600))
    return e;
  if (auto e = range("log_interval_s", c.log_interval_s(), 0, 3600)) return e;
  return std::nullopt;
}

std::string describe_link(const LinkSettings& s) {
  std::ostringstream out;
  if (s.rtu) {
    out << "rtu " << s.device << " " << s.baud << " " << s.data_bits << s.parity << s.stop_bits;
  } else {
    out << "tcp " << s.host << ":" << s.port;
  }
  out << " unit " << s.unit_id;
  return out.str();
}

ModbusLink::ModbusLink(LinkSettings settings) : settings_(std::move(settings)), backoff_s_(settings_.backoff_min_s) {
  ctx_ = settings_.rtu ? modbus_new_rtu(settings_.device.c_str(), settings_.baud, settings_.parity,
                                        settings_.data_bits, settings_.stop_bits)
                       : modbus_new_tcp(settings_.host.c_str(), settings_.port);
  if (ctx_ == nullptr) {
    refused_ = true;
    set_error(pack(LinkOp::kConnect, static_cast<std::uint8_t>(Failure::kConnect), 0,
                   static_cast<std::uint32_t>(errno)));
    spdlog::error("modbus {}: cannot create the context: {}", describe_link(settings_), modbus_strerror(errno));
    return;
  }
  modbus_set_slave(ctx_, settings_.unit_id);
  modbus_set_error_recovery(ctx_, MODBUS_ERROR_RECOVERY_NONE);
  set_timeout(ctx_, settings_.response_timeout_s, modbus_set_response_timeout);
  set_timeout(ctx_, settings_.byte_timeout_s, modbus_set_byte_timeout);
}

ModbusLink::~ModbusLink() {
  if (ctx_ == nullptr) return;
  if (connected()) modbus_close(ctx_);
  modbus_free(ctx_);
}

bool ModbusLink::connect_if_due() {
  if (connected()) return true;
  if (refused_) return false;
  const std::int64_t now = now_ns();
  if (now < next_attempt_ns_) return false;
  if (connections_ > 0 || failures_in_a_row_ > 0) reconnect_attempts_.fetch_add(1, std::memory_order_relaxed);
  if (modbus_connect(ctx_) == 0) {
    connected_.store(true, std::memory_order_relaxed);
    ++connections_;
    consecutive_timeouts_ = 0;
    consecutive_bad_frames_ = 0;
    backoff_s_ = settings_.backoff_min_s;
    if (connections_ == 1) {
      spdlog::info("modbus {}: connected", describe_link(settings_));
    } else {
      spdlog::info("modbus {}: reconnected", describe_link(settings_));
    }
    return true;
  }
  const int err = errno;
  modbus_close(ctx_);
  note_failure(LinkOp::kConnect, Failure::kConnect, err);
  next_attempt_ns_ = now_ns() + to_ns(backoff_s_);
  backoff_s_ = std::min(2 * backoff_s_, settings_.backoff_max_s);
  return false;
}

LinkResult ModbusLink::read(LinkOp op, RegisterTable table, unsigned address, unsigned count, std::uint16_t* dest) {
  if (!connect_if_due()) return LinkResult::kLinkDown;
  const std::int64_t started = now_ns();
  const int rc = table == RegisterTable::kInput
                     ? modbus_read_input_registers(ctx_, static_cast<int>(address), static_cast<int>(count), dest)
                     : modbus_read_registers(ctx_, static_cast<int>(address), static_cast<int>(count), dest);
  return finish(op, rc, started);
}

LinkResult ModbusLink::write(LinkOp op, unsigned address, unsigned count, const std::uint16_t* src) {
  if (!connect_if_due()) return LinkResult::kLinkDown;
  const std::int64_t started = now_ns();
  const int rc = modbus_write_registers(ctx_, static_cast<int>(address), static_cast<int>(count), src);
  return finish(op, rc, started);
}

LinkResult ModbusLink::finish(LinkOp op, int rc, std::int64_t started_ns) {
  const int err = errno;
  const std::int64_t io_ns = now_ns() - started_ns;
  last_io_ns_.store(io_ns, std::memory_order_relaxed);
  if (io_ns > max_io_ns_.load(std::memory_order_relaxed)) max_io_ns_.store(io_ns, std::memory_order_relaxed);
  if (rc != -1) {
    transactions_.fetch_add(1, std::memory_order_relaxed);
    consecutive_timeouts_ = 0;
    consecutive_bad_frames_ = 0;
    note_success();
    return LinkResult::kOk;
  }
  if (err == ETIMEDOUT) {
    timeouts_.fetch_add(1, std::memory_order_relaxed);
    note_failure(op, Failure::kTimeout, 0);
    // A late answer must not be taken for the next request's.
    modbus_flush(ctx_);
    if (++consecutive_timeouts_ >= settings_.max_consecutive_timeouts) {
      close_link(op, Failure::kTooManyTimeouts, static_cast<int>(consecutive_timeouts_));
      return LinkResult::kLinkDown;
    }
    return LinkResult::kTimeout;
  }
  if (is_exception(err)) {
    exceptions_.fetch_add(1, std::memory_order_relaxed);
    note_failure(op, Failure::kException, err - MODBUS_ENOBASE);
    return LinkResult::kException;
  }
  if (is_protocol_error(err)) {
    bad_frames_.fetch_add(1, std::memory_order_relaxed);
    note_failure(op, Failure::kProtocol, err);
    modbus_flush(ctx_);
    // An answer to an earlier request (one that came after its timeout and
    // the flush) puts every later answer one behind: each transaction then
    // reads its predecessor's answer, and a flush right after it finds the
    // stream empty. Reconnecting starts the stream afresh.
    if (++consecutive_bad_frames_ >= settings_.max_consecutive_timeouts) {
      close_link(op, Failure::kTooManyBadFrames, static_cast<int>(consecutive_bad_frames_));
      return LinkResult::kLinkDown;
    }
    return LinkResult::kBadFrame;
  }
  close_link(op, Failure::kLinkLost, err);
  return LinkResult::kLinkDown;
}

void ModbusLink::close_link(LinkOp op, Failure why, int detail) {
  modbus_close(ctx_);
  connected_.store(false, std::memory_order_relaxed);
  link_losses_.fetch_add(1, std::memory_order_relaxed);
  note_failure(op, why, detail);
  backoff_s_ = settings_.backoff_min_s;
  next_attempt_ns_ = now_ns() + to_ns(backoff_s_);
}

void ModbusLink::report_frame_fault(LinkOp op, FrameFault fault, std::uint32_t detail) {
  bad_frames_.fetch_add(1, std::memory_order_relaxed);
  set_error(pack(op, static_cast<std::uint8_t>(Failure::kFrame), static_cast<std::uint8_t>(fault), detail));
  note_failure(op, Failure::kFrame, -1);
}

void ModbusLink::refuse(LinkOp op, FrameFault fault, std::uint32_t detail) {
  refused_ = true;
  if (connected()) {
    modbus_close(ctx_);
    connected_.store(false, std::memory_order_relaxed);
  }
  const std::uint64_t packed =
      pack(op, static_cast<std::uint8_t>(Failure::kRefused), static_cast<std::uint8_t>(fault), detail);
  set_error(packed);
  spdlog::error("modbus {}: {}; the link stays closed", describe_link(settings_), error_text(packed));
}

void ModbusLink::note_failure(LinkOp op, Failure failure, std::int64_t detail) {
  if (detail >= 0) set_error(pack(op, static_cast<std::uint8_t>(failure), 0, static_cast<std::uint32_t>(detail)));
  const std::int64_t now = now_ns();
  if (failures_in_a_row_++ == 0) failing_since_ns_ = now;
  // While the link keeps failing, one line per log interval says how many were not logged.
  if (now - last_log_ns_ < to_ns(settings_.log_interval_s)) {
    ++suppressed_logs_;
    return;
  }
  last_log_ns_ = now;
  const std::string text = error_text(last_error_.load(std::memory_order_relaxed));
  if (suppressed_logs_ > 0) {
    spdlog::warn("modbus {}: {} ({} more failures since the last report, {} in a row)", describe_link(settings_),
                 text, suppressed_logs_, failures_in_a_row_);
  } else {
    spdlog::warn("modbus {}: {}", describe_link(settings_), text);
  }
  suppressed_logs_ = 0;
}

void ModbusLink::set_error(std::uint64_t packed) {
  last_error_.store(packed, std::memory_order_relaxed);
  std::uint64_t none = 0;
  first_error_.compare_exchange_strong(none, packed, std::memory_order_relaxed);
}

void ModbusLink::note_success() {
  if (failures_in_a_row_ == 0) return;
  const std::int64_t now = now_ns();
  if (now - last_recovery_log_ns_ >= to_ns(settings_.log_interval_s)) {
    last_recovery_log_ns_ = now;
    spdlog::info("modbus {}: answering again after {} failures in {:.3f} s", describe_link(settings_),
                 failures_in_a_row_, static_cast<double>(now - failing_since_ns_) * 1e-9);
  }
  failures_in_a_row_ = 0;
}

std::string ModbusLink::error_text(std::uint64_t packed) const {
  if (packed == 0) return "";
  const auto op = static_cast<LinkOp>(packed >> 48 & 0xFF);
  const auto failure = static_cast<Failure>(packed >> 40 & 0xFF);
  const auto sub = static_cast<FrameFault>(packed >> 32 & 0xFF);
  const auto detail = static_cast<std::uint32_t>(packed & 0xFFFFFFFF);
  std::string text = std::string(op_text(op)) + ": ";
  switch (failure) {
    case Failure::kNone:
      return "";
    case Failure::kTimeout:
      return text + "no answer within the response timeout (" + ms(settings_.response_timeout_s) + ")";
    case Failure::kException:
      return text + "the device answered with exception " + std::to_string(detail) + " (" +
             modbus_strerror(static_cast<int>(detail) + MODBUS_ENOBASE) + ")";
    case Failure::kProtocol:
      return text + "malformed answer (" + modbus_strerror(static_cast<int>(detail)) + ")";
    case Failure::kLinkLost:
      return text + "connection lost (" + modbus_strerror(static_cast<int>(detail)) + ")";
    case Failure::kTooManyTimeouts:
      return text + std::to_string(detail) + " timeouts in a row; connection closed to reconnect";
    case Failure::kTooManyBadFrames:
      return text + std::to_string(detail) + " malformed answers in a row; connection closed to reconnect";
    case Failure::kConnect:
      return "connect " + describe_link(settings_) + ": " + modbus_strerror(static_cast<int>(detail));
    case Failure::kFrame:
    case Failure::kRefused:
      switch (sub) {
        case FrameFault::kChecksum:
          return text + "corrupt answer (checksum mismatch)";
        case FrameFault::kStale:
          return text + "stale data (sequence " + std::to_string(detail) + " did not advance)";
        case FrameFault::kIdentity:
          return text + "the device is not the configured instrument (" +
                 (detail == 0 ? std::string("wrong magic or map version")
                              : "sample period " + std::to_string(detail) + " ns differs from the loop period") +
                 ")";
      }
  }
  return text + "unknown failure";
}

BackendHealth ModbusLink::health() const {
  BackendHealth h;
  h.connected = connected();
  h.transactions = transactions_.load(std::memory_order_relaxed);
  h.timeouts = timeouts_.load(std::memory_order_relaxed);
  h.exceptions = exceptions_.load(std::memory_order_relaxed);
  h.bad_frames = bad_frames_.load(std::memory_order_relaxed);
  h.link_losses = link_losses_.load(std::memory_order_relaxed);
  h.reconnect_attempts = reconnect_attempts_.load(std::memory_order_relaxed);
  h.last_io_s = static_cast<double>(last_io_ns_.load(std::memory_order_relaxed)) * 1e-9;
  h.max_io_s = static_cast<double>(max_io_ns_.load(std::memory_order_relaxed)) * 1e-9;
  h.last_error = error_text(last_error_.load(std::memory_order_relaxed));
  h.first_error = error_text(first_error_.load(std::memory_order_relaxed));
  return h;
}

}  // namespace tribo::hal
