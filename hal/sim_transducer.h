// The simulated backend: the instrument of sim/ behind the Transducer
// interface, stepped in lock-step with the controller (one plant period per
// tick), optionally paced to the wall clock.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "hal/transducer.h"
#include "hal/wall_clock_pacer.h"
#include "sim/fault_injection.h"
#include "sim/instrument.h"

namespace tribo::hal {

// The status bits (SensorStatus) a simulated instrument's step reports; the
// bench emulator serves the same bits in its status register.
std::uint32_t sensor_status_of(const sim::StepReport& report);

class SimTransducer : public Transducer {
 public:
  SimTransducer(const sim::InstrumentParams& params, std::uint64_t seed, double loop_rate_hz,
                bool pace_to_wall_clock, std::vector<sim::FaultSpec> faults = {});

  std::string_view backend_name() const override { return "sim"; }
  double period_s() const override { return period_s_; }
  IoResult read(SensorFrame& frame) override;
  IoResult write(const DriveCommand& command) override;
  void wait_next_tick() override;
  void interrupt_wait() override { wake_.wake(); }
  std::uint64_t overruns() const override {
    return (pacer_ ? pacer_->overruns() : 0) + faults_->overruns();
  }

  void begin_session(std::uint64_t seed) override;

  // The plant's true state: for tests and diagnostics, never for control.
  const sim::SimInstrument& instrument() const { return *instrument_; }
  // What the last tick's step reported (sub-steps, evaluations of the contact law).
  const sim::StepReport& last_report() const { return report_; }

 private:
  sim::InstrumentParams params_;
  std::vector<sim::FaultSpec> fault_specs_;
  bool pace_to_wall_clock_;
  std::unique_ptr<sim::SimInstrument> instrument_;
  double period_s_;
  DriveCommand command_;
  std::uint32_t status_bits_ = 0;
  sim::StepReport report_;
  TickWake wake_;  // outlives every pacer_: interrupt_wait() may come from any thread at any time
  std::unique_ptr<WallClockPacer> pacer_;
  std::unique_ptr<sim::FaultInjector> faults_;  // sim/fault_injection.h; empty: no faults
  std::uint64_t ticks_ = 0;
};

}  // namespace tribo::hal
