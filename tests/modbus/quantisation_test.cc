// The quantisation budget of the register map, without the network: the
// simulated instrument seen through a map (every sensor value and drive
// command crosses its counts, scaling and linearisation as over Modbus) runs
// the real run loop. The shipped 32-bit map leaves the friction result as it
// is; a 16-bit map (0.5 nm position steps) biases it, for a physical reason:
// the lateral loop sits on a staircase instead of a dithered measurement.
#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <vector>

#include "analysis/metrics/run_metrics.h"
#include "daemon/controller.h"
#include "daemon/protocol_validator.h"
#include "daemon/run_loop.h"
#include "daemon/safety_supervisor.h"
#include "hal/modbus_blocks.h"
#include "hal/sim_transducer.h"
#include "proto/sample_record.h"
#include "proto/text_format_file.h"
#include "sim/instrument_params.h"
#include "tests/modbus/modbus_support.h"

namespace tribo {
namespace {

using testing::short_scratch;

// The simulated backend behind a register map, in process.
class MappedSimTransducer : public hal::Transducer {
 public:
  MappedSimTransducer(const v1::DaemonConfig& sim_config, const hal::RegisterMap& map, std::uint64_t seed)
      : sim_(sim::instrument_params_from_config(sim_config.sim()), seed, sim_config.controller().loop_rate_hz(),
             false),
        map_(map),
        sensors_(map.sensors.count),
        drive_(map.drive.count) {}

  std::string_view backend_name() const override { return "mapped-sim"; }
  double period_s() const override { return sim_.period_s(); }

  hal::IoResult read(hal::SensorFrame& frame) override {
    hal::SensorFrame raw;
    sim_.read(raw);
    hal::encode_sensor_block(map_, sequence_, static_cast<std::uint16_t>(raw.status_bits), raw, sensors_.data());
    frame = hal::decode_sensor_block(map_, sensors_.data()).frame;
    measured_ = {frame.lateral_position_m, frame.normal_displacement_m};
    return hal::IoResult::kOk;
  }

  hal::IoResult write(const hal::DriveCommand& command) override {
    // As in tribo-bench: an electrostatic drive channel (not the shipped map,
    // whose drive block carries force) gets the voltage from the measured gap
    // and the force from the true one.
    hal::encode_drive_block(map_, ++sequence_, command, measured_, drive_.data());
    const sim::InstrumentTruth& truth = sim_.instrument().truth();
    return sim_.write(
        hal::decode_drive_block(map_, drive_.data(), {truth.lateral.position_m, truth.normal.displacement_m})
            .command);
  }

  void wait_next_tick() override { sim_.wait_next_tick(); }
  void interrupt_wait() override { sim_.interrupt_wait(); }

 private:
  hal::SimTransducer sim_;
  hal::RegisterMap map_;
  std::vector<std::uint16_t> sensors_, drive_;
  std::uint32_t sequence_ = 0;
  hal::AxisPositions measured_;
};

analysis::SlidingSegmentMetrics scratch_metrics(hal::Transducer& transducer, const v1::DaemonConfig& config) {
  const daemon::ProtocolCheck check = daemon::validate_protocol(short_scratch(), config);
  if (!check.ok()) throw std::runtime_error(check.errors.front().message);
  const daemon::RunLoopConfig loop = daemon::run_loop_config_from(config);
  daemon::SpscQueue<Sample> queue(1 << 13);
  daemon::RunControl control;
  daemon::RunTelemetry telemetry;
  const daemon::RunOutcome outcome = daemon::execute_run(transducer, check.load_function, loop, queue, control, telemetry);
  if (outcome.end != daemon::RunEnd::kCompleted) {
    throw std::runtime_error("the run did not complete: " + daemon::trip_description(outcome.trip));
  }
  v1::SampleBlock block;
  Sample s;
  while (queue.try_pop(s)) append_sample(s, block);
  const auto metrics = analysis::sliding_segment_metrics(block);
  if (metrics.size() != 1) throw std::runtime_error("expected one scratch");
  return metrics.front();
}

TEST(ModbusQuantisation, ShippedMapKeepsTheFrictionAndASixteenBitMapBiasesIt) {
  const v1::DaemonConfig config = testing::sim_daemon_config();
  const v1::ModbusRegisterMap shipped = testing::modbus_daemon_config().modbus().register_map();
  v1::ModbusRegisterMap coarse = shipped;  // a 16-bit ADC over the same ±10.24 V: 0.5 nm steps
  coarse.mutable_sensors()->mutable_lateral_position()->set_type(v1::INT16);
  coarse.mutable_sensors()->mutable_lateral_position()->set_volts_per_count(10.24 / 32768);
  coarse.mutable_sensors()->mutable_lateral_position()->set_address(4);

  hal::SimTransducer plain(sim::instrument_params_from_config(config.sim()), 3, config.controller().loop_rate_hz(),
                           false);
  MappedSimTransducer fine(config, hal::register_map_from_config(shipped), 3);
  MappedSimTransducer rough(config, hal::register_map_from_config(coarse), 3);
  const auto reference = scratch_metrics(plain, config);
  const auto through_map = scratch_metrics(fine, config);
  const auto through_coarse_map = scratch_metrics(rough, config);
  std::printf("mean friction: sim %.4f µN, 32-bit map %.4f µN, 16-bit map %.4f µN (%+.2f %%)\n",
              reference.mean_friction_n * 1e6, through_map.mean_friction_n * 1e6,
              through_coarse_map.mean_friction_n * 1e6,
              100 * (through_coarse_map.mean_friction_n / reference.mean_friction_n - 1));

  // Within quantisation: one force step of disagreement per sample at most.
  const double lsb = config.sim().sensors().lateral_force_resolution_n();
  const double tolerance = lsb / std::sqrt(static_cast<double>(reference.steady_samples));
  EXPECT_NEAR(through_map.mean_friction_n, reference.mean_friction_n, tolerance);
  // The coarse map fails that comparison by far: its 0.5 nm steps, inside the
  // position loop, dither the contact and move the friction by more than 1 %
  // (measured: -15 % with the default contact, -5 % with plain LuGre: both
  // lose friction under dither).
  EXPECT_GT(std::fabs(through_coarse_map.mean_friction_n / reference.mean_friction_n - 1), 0.01);
}

}  // namespace
}  // namespace tribo
