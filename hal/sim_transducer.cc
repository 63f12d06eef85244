#include "hal/sim_transducer.h"

#include <limits>

namespace tribo::hal {

std::uint32_t sensor_status_of(const sim::StepReport& report) {
  return (report.substep_cap_hit ? kSubstepCapHit : kSensorOk) | (report.snapped ? kLateralSnapDown : kSensorOk) |
         (report.handover ? kDriveHandover : kSensorOk);
}

SimTransducer::SimTransducer(const sim::InstrumentParams& params, std::uint64_t seed,
                             double loop_rate_hz, bool pace_to_wall_clock,
                             std::vector<sim::FaultSpec> faults)
    : params_(params), fault_specs_(std::move(faults)), pace_to_wall_clock_(pace_to_wall_clock),
      period_s_(1.0 / loop_rate_hz) {
  begin_session(seed);
}

// Everything as if the backend had just been built with this seed: the
// plant at rest, the noise and the fault schedule from t = 0.
void SimTransducer::begin_session(std::uint64_t seed) {
  instrument_ = std::make_unique<sim::SimInstrument>(params_, seed);
  faults_ = std::make_unique<sim::FaultInjector>(fault_specs_, seed);
  command_ = DriveCommand{};
  status_bits_ = 0;
  report_ = {};
  ticks_ = 0;
  pacer_.reset();
  if (pace_to_wall_clock_) pacer_ = std::make_unique<WallClockPacer>(period_s_, &wake_);
  faults_->advance(0.0, sim::DriveInput{});
}

IoResult SimTransducer::read(SensorFrame& frame) {
  if (faults_->link_down() || faults_->read_timeout()) {
    // As a real backend does (hal/transducer.h): a failed read hands on no stale value.
    constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
    frame = SensorFrame{kNaN, kNaN, kNaN, kNaN, status_bits_};
    return faults_->link_down() ? IoResult::kLinkDown : IoResult::kTimeout;
  }
  const sim::Measurement m =
      faults_->empty() ? instrument_->measurement() : faults_->corrupt(instrument_->measurement());
  frame = SensorFrame{m.normal_force_n, m.normal_displacement_m, m.lateral_force_n,
                      m.lateral_position_m, status_bits_, m.lateral_position_record_noise_m};
  return IoResult::kOk;
}

IoResult SimTransducer::write(const DriveCommand& command) {
  if (faults_->link_down()) return IoResult::kLinkDown;  // the drive holds its last value
  command_ = command;
  return IoResult::kOk;
}

void SimTransducer::wait_next_tick() {
  const sim::DriveInput commanded{command_.normal_force_n, command_.lateral_force_n};
  report_ = instrument_->step(faults_->empty() ? commanded : faults_->actuate(commanded), period_s_);
  ++ticks_;
  // Tick times as the controller counts them (k periods), not a running sum.
  if (!faults_->empty()) faults_->advance(static_cast<double>(ticks_) * period_s_, commanded);
  status_bits_ = sensor_status_of(report_);
  if (pacer_) pacer_->wait();
}

}  // namespace tribo::hal
