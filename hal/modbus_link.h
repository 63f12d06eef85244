// One Modbus connection (libmodbus, TCP or RTU) as the backend's tick sees it:
// single transactions bounded by the response and byte timeouts, modbus_flush
// after a failed one, the link closed after a run of timeouts or a broken
// connection and reopened with exponential backoff, error counters, last and
// maximum transaction time, and rate-limited logging while it fails.
//
// Nothing here blocks longer than one transaction (or one connection attempt,
// itself bounded by the response timeout) and nothing allocates on the
// success path. Health is kept in atomics so other threads may read it.
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>
#include <string>

#include "hal/modbus_register_map.h"
#include "hal/transducer.h"
#include "tribo/v1/modbus_config.pb.h"

struct _modbus;

namespace tribo::hal {

struct LinkSettings {
  bool rtu = false;
  std::string host;  // TCP
  int port = 502;
  std::string device;  // RTU
  int baud = 115200;
  char parity = 'N';
  int data_bits = 8;
  int stop_bits = 1;
  int unit_id = 1;
  double response_timeout_s = 0.02;
  double byte_timeout_s = 0.005;
  unsigned max_consecutive_timeouts = 3;
  double backoff_min_s = 0.01;
  double backoff_max_s = 1.0;
  double log_interval_s = 1.0;
};

LinkSettings link_settings_from_config(const v1::ModbusConfig& config);
// Checks the link part of the config (not the register map); errors name the field.
std::optional<std::string> validate_link_config(const v1::ModbusConfig& config, const std::string& prefix = "modbus");
// "tcp 127.0.0.1:1502 unit 1" or "rtu /dev/ttyUSB0 115200 8N1 unit 1".
std::string describe_link(const LinkSettings& settings);

// What a transaction was for, to say so in errors and logs.
enum class LinkOp : std::uint8_t { kConnect, kReadSensors, kWriteDrive, kReadIdentity, kWriteSession };

enum class LinkResult {
  kOk,
  kTimeout,    // no complete answer in time (flushed)
  kException,  // the device answered with a Modbus exception
  kBadFrame,   // malformed answer (flushed)
  kLinkDown,   // not connected, or the connection broke (closed; reconnect scheduled)
};

// Why an answer that arrived was unusable, found by the caller.
enum class FrameFault : std::uint8_t { kChecksum, kStale, kIdentity };

class ModbusLink {
 public:
  explicit ModbusLink(LinkSettings settings);
  ~ModbusLink();
  ModbusLink(const ModbusLink&) = delete;
  ModbusLink& operator=(const ModbusLink&) = delete;

  // True when connected; while disconnected it tries to connect if the
  // backoff allows (one attempt, bounded by the response timeout).
  bool connect_if_due();

  // One transaction. While disconnected it first calls connect_if_due() and
  // returns kLinkDown without other I/O if that fails.
  LinkResult read(LinkOp op, RegisterTable table, unsigned address, unsigned count, std::uint16_t* dest);
  LinkResult write(LinkOp op, unsigned address, unsigned count, const std::uint16_t* src);

  // The caller found an answer unusable: counted as a bad frame of op; detail
  // goes into the error text (e.g. the sequence seen).
  void report_frame_fault(LinkOp op, FrameFault fault, std::uint32_t detail);

  // Closes the link for good (e.g. the device is not the one configured):
  // every transaction returns kLinkDown from now on.
  void refuse(LinkOp op, FrameFault fault, std::uint32_t detail);

  bool connected() const { return connected_.load(std::memory_order_relaxed); }
  // Successful connections so far; a change tells the caller it reconnected.
  std::uint64_t connections() const { return connections_; }

  BackendHealth health() const;
  const LinkSettings& settings() const { return settings_; }

 private:
  enum class Failure : std::uint8_t {
    kNone, kTimeout, kException, kProtocol, kLinkLost, kTooManyTimeouts, kConnect, kFrame, kRefused,
    kTooManyBadFrames
  };

  LinkResult finish(LinkOp op, int rc, std::int64_t started_ns);
  void close_link(LinkOp op, Failure why, int detail);
  void note_failure(LinkOp op, Failure failure, std::int64_t detail);
  void set_error(std::uint64_t packed);
  void note_success();
  std::string error_text(std::uint64_t packed) const;

  LinkSettings settings_;
  _modbus* ctx_ = nullptr;
  bool refused_ = false;
  std::uint64_t connections_ = 0;
  unsigned consecutive_timeouts_ = 0;
  unsigned consecutive_bad_frames_ = 0;
  double backoff_s_;
  std::int64_t next_attempt_ns_ = 0;

  // Rate-limited logging (loop thread only).
  std::int64_t last_log_ns_ = INT64_MIN / 2;
  std::int64_t last_recovery_log_ns_ = INT64_MIN / 2;
  std::uint64_t suppressed_logs_ = 0;
  std::uint64_t failures_in_a_row_ = 0;
  std::int64_t failing_since_ns_ = 0;

  // Health, read from other threads.
  std::atomic<bool> connected_{false};
  std::atomic<std::uint64_t> transactions_{0};
  std::atomic<std::uint64_t> timeouts_{0};
  std::atomic<std::uint64_t> exceptions_{0};
  std::atomic<std::uint64_t> bad_frames_{0};
  std::atomic<std::uint64_t> link_losses_{0};
  std::atomic<std::uint64_t> reconnect_attempts_{0};
  std::atomic<std::int64_t> last_io_ns_{0};
  std::atomic<std::int64_t> max_io_ns_{0};
  std::atomic<std::uint64_t> last_error_{0};  // op, failure and detail packed
  std::atomic<std::uint64_t> first_error_{0};
};

}  // namespace tribo::hal
