#include "hal/sim_transducer.h"

namespace tribo::hal {

SimTransducer::SimTransducer(const sim::InstrumentParams& params, std::uint64_t seed,
                             double loop_rate_hz, bool pace_to_wall_clock)
    : instrument_(params, seed), period_s_(1.0 / loop_rate_hz) {
  if (pace_to_wall_clock) pacer_ = std::make_unique<WallClockPacer>(period_s_);
}

IoResult SimTransducer::read(SensorFrame& frame) {
  const sim::Measurement& m = instrument_.measurement();
  frame = SensorFrame{m.normal_force_n, m.normal_displacement_m, m.lateral_force_n,
                      m.lateral_position_m, status_bits_};
  return IoResult::kOk;
}

IoResult SimTransducer::write(const DriveCommand& command) {
  command_ = command;
  return IoResult::kOk;
}

void SimTransducer::wait_next_tick() {
  const sim::StepReport report =
      instrument_.step(sim::DriveInput{command_.normal_force_n, command_.lateral_force_n}, period_s_);
  status_bits_ = (report.substep_cap_hit ? kSubstepCapHit : kSensorOk) |
                 (report.snapped ? kLateralSnapDown : kSensorOk) |
                 (report.handover ? kDriveHandover : kSensorOk);
  if (pacer_) pacer_->wait();
}

}  // namespace tribo::hal
