#include "hal/modbus_transducer.h"

#include <cmath>
#include <ctime>
#include <limits>

#include <spdlog/spdlog.h>

namespace tribo::hal {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void invalidate(SensorFrame& frame) {
  frame = SensorFrame{kNaN, kNaN, kNaN, kNaN, 0};
}

IoResult io_result(LinkResult r) {
  switch (r) {
    case LinkResult::kOk: return IoResult::kOk;
    case LinkResult::kLinkDown: return IoResult::kLinkDown;
    case LinkResult::kTimeout:
    case LinkResult::kException:
    case LinkResult::kBadFrame: break;
  }
  return IoResult::kTimeout;
}

// Serial-number arithmetic: the sequence may wrap.
bool newer(std::uint32_t a, std::uint32_t b) { return static_cast<std::int32_t>(a - b) > 0; }

std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace

ModbusTransducer::ModbusTransducer(const LinkSettings& link, const RegisterMap& map, double loop_rate_hz,
                                   std::uint64_t seed)
    : link_(link), map_(map), period_s_(1.0 / loop_rate_hz), seed_(seed),
      session_pending_(map.session_address.has_value()),
      over_range_log_{static_cast<std::int64_t>(link.log_interval_s * 1e9)},
      clamp_log_{static_cast<std::int64_t>(link.log_interval_s * 1e9)} {
  spdlog::info("modbus {}: loop {} Hz; quantisation at zero: lateral position {:.3g} m, lateral force {:.3g} N",
               describe_link(link), loop_rate_hz, sensor_resolution(map_.sensors.lateral_position, 0.0),
               sensor_resolution(map_.sensors.lateral_force, 0.0));
  prepare_link();
}

IoResult ModbusTransducer::prepare_link() {
  if (!link_.connect_if_due()) return IoResult::kLinkDown;
  if (link_.connections() != connections_seen_) {
    connections_seen_ = link_.connections();
    identity_pending_ = map_.identity.has_value();
  }
  if (identity_pending_) {
    if (const IoResult r = check_identity(); r != IoResult::kOk) return r;
  }
  if (session_pending_) return start_session();
  return IoResult::kOk;
}

IoResult ModbusTransducer::check_identity() {
  std::array<std::uint16_t, kIdentityRegisters> regs{};
  const LinkResult r = link_.read(LinkOp::kReadIdentity, map_.identity->table, map_.identity->address,
                                  kIdentityRegisters, regs.data());
  if (r != LinkResult::kOk) return io_result(r);
  const IdentityValues id = decode_identity_block(map_, regs.data());
  const auto period_ns = static_cast<std::uint32_t>(std::llround(period_s_ * 1e9));
  if (id.magic != kIdentityMagic || id.version != kRegisterMapVersion) {
    link_.refuse(LinkOp::kReadIdentity, FrameFault::kIdentity, 0);
    return IoResult::kLinkDown;
  }
  if (id.sample_period_ns != period_ns) {
    link_.refuse(LinkOp::kReadIdentity, FrameFault::kIdentity, id.sample_period_ns);
    return IoResult::kLinkDown;
  }
  identity_pending_ = false;
  return IoResult::kOk;
}

IoResult ModbusTransducer::start_session() {
  std::array<std::uint16_t, kSessionRegisters> regs{};
  encode_session_block(map_, SessionValues{seed_, kSessionReset}, regs.data());
  const LinkResult r = link_.write(LinkOp::kWriteSession, *map_.session_address, kSessionRegisters, regs.data());
  if (r != LinkResult::kOk) return io_result(r);
  session_pending_ = false;
  last_used_sequence_.reset();  // the plant starts again at sequence 0
  return IoResult::kOk;
}

IoResult ModbusTransducer::read(SensorFrame& frame) {
  if (!pacer_) pacer_.emplace(period_s_, &wake_);
  if (const IoResult r = prepare_link(); r != IoResult::kOk) {
    invalidate(frame);
    return r;
  }
  const SensorBlockMap& s = map_.sensors;
  const LinkResult r = link_.read(LinkOp::kReadSensors, s.table, s.address, s.count, sensor_registers_.data());
  if (r != LinkResult::kOk) {
    invalidate(frame);
    return io_result(r);
  }
  const SensorBlockValues v = decode_sensor_block(map_, sensor_registers_.data());
  if (!v.checksum_ok) {
    link_.report_frame_fault(LinkOp::kReadSensors, FrameFault::kChecksum, 0);
    invalidate(frame);
    return IoResult::kTimeout;
  }
  last_seen_sequence_ = v.sequence;
  if (last_used_sequence_ && !newer(v.sequence, *last_used_sequence_)) {
    link_.report_frame_fault(LinkOp::kReadSensors, FrameFault::kStale, v.sequence);
    invalidate(frame);
    return IoResult::kTimeout;
  }
  last_used_sequence_ = v.sequence;
  frame = v.frame;
  if (std::isfinite(frame.lateral_position_m)) positions_.lateral_position_m = frame.lateral_position_m;
  if (std::isfinite(frame.normal_displacement_m)) positions_.normal_displacement_m = frame.normal_displacement_m;
  if (v.over_range) note_over_range(v);
  return IoResult::kOk;
}

IoResult ModbusTransducer::write(const DriveCommand& command) {
  // Never drive a device whose identity or session is not established.
  if (!link_.connected() || identity_pending_ || session_pending_) return IoResult::kLinkDown;
  if (!encode_drive_block(map_, last_seen_sequence_ + 1, command, positions_, drive_registers_.data()) &&
      clamp_log_.due(now_ns())) {
    spdlog::warn("modbus: drive command ({} N normal, {} N lateral) clamped to the register range",
                 command.normal_force_n, command.lateral_force_n);
  }
  const DriveBlockMap& d = map_.drive;
  return io_result(link_.write(LinkOp::kWriteDrive, d.address, d.count, drive_registers_.data()));
}

void ModbusTransducer::begin_session(std::uint64_t seed) {
  seed_ = seed;
  session_pending_ = map_.session_address.has_value();
  pacer_.reset();
}

void ModbusTransducer::wait_next_tick() {
  if (!pacer_) pacer_.emplace(period_s_, &wake_);
  pacer_->wait();
}

void ModbusTransducer::note_over_range(const SensorBlockValues& v) {
  if (!over_range_log_.due(now_ns())) return;
  spdlog::warn("modbus: sensor over range at sequence {} (lateral position {} m, lateral force {} N, "
               "normal force {} N, normal displacement {} m)",
               v.sequence, v.frame.lateral_position_m, v.frame.lateral_force_n, v.frame.normal_force_n,
               v.frame.normal_displacement_m);
}

}  // namespace tribo::hal
