// The experiments of the friction compensation (docs/friction_compensation.md),
// shared by its tests (tests/daemon/friction_compensation_test.cc) and the
// figures program (bench/friction_compensation_figures.cc): runs through the
// daemon's own validator and real-time loop in this process, on the backend
// the config selects (the simulated instrument, or tribo-bench over Modbus),
// and the figures read from what the instrument records.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "daemon/friction_report.h"
#include "daemon/run_loop.h"
#include "proto/sample_record.h"
#include "tribo/v1/api.pb.h"
#include "tribo/v1/daemon_config.pb.h"
#include "tribo/v1/protocol.pb.h"

namespace tribo::testing {

// A protocol file of config/protocols/, parsed (throws on failure).
v1::Protocol shipped_protocol(const std::string& name);
// The protocol with the report compensating every displacement segment (as
// `tribo run --friction-model`); an empty report: the protocol unchanged.
v1::Protocol with_friction_model(v1::Protocol protocol, const std::string& report_json,
                                 const std::string& report_file = "report.json");

struct InProcessRun {
  std::vector<Sample> samples;           // the record
  v1::RunStart start;                    // the start document tribod would write
  daemon::RunOutcome outcome;
  std::string end_reason;                // a trip's or an abort's description, else empty
  double loop_period_s = 0;
  // Per loop tick, simulated backend only (empty otherwise): the plate's true
  // position and the compensation's share of the lateral drive.
  std::vector<double> true_position_m;
  std::vector<double> compensation_n;
  std::vector<double> true_friction_n;   // the contact's friction on the tip (+: against +x motion)
  std::vector<double> true_tilt_n;       // the tilt's push on the tip, N tan(theta) towards +x
  std::vector<double> drive_n;           // the lateral drive commanded (PID output plus the compensation)
};

// Validates (throws with the first error) and runs the protocol unpaced
// (paced for a Modbus backend) with the seed.
InProcessRun run_in_process(const v1::DaemonConfig& config, const v1::Protocol& protocol, std::uint64_t seed);

// A run recorded by tribod or `tribo run --out` (metadata.json and
// samples.csv; no per-tick truth). Throws if it cannot be read.
InProcessRun recorded_run(const std::string& run_dir);
// The same from its documents: the start document, the samples and the stop.
InProcessRun recorded_run(const v1::RunStart& start, const v1::SampleBlock& samples, const v1::RunStop& stop);

// The record's velocity: the least-squares slope of the recorded position
// over a centred window of half_width samples each side (at the edges, the
// window that fits), m/s.
std::vector<double> record_velocity(const std::vector<Sample>& samples, std::size_t first, std::size_t end,
                                    std::size_t half_width);

// Break-away of one sliding segment from rest.
struct BreakawayFigures {
  double commanded_m_per_s = 0;
  double overshoot = 0;          // peak of the record's velocity (full 10 ms windows) / commanded
  double true_overshoot = 0;     // the tip's true velocity over 1 ms (simulated backend; else NaN)
  double time_to_speed_s = 0;    // from the segment's start to the record's velocity first reaching the commanded
  double peak_lateral_force_n = 0;  // largest |recorded lateral force| in the segment
  // The stiction peak as the run summary takes it, the highest 20 ms mean of
  // the recorded lateral force along the motion; and (simulated backend, else
  // NaN) the same of what the transducer would read were there no inertia,
  // the contact's true friction less the tilt's push.
  double stiction_peak_n = 0;
  double true_stiction_peak_n = 0;
};
BreakawayFigures breakaway_figures(const InProcessRun& run, std::uint32_t segment);

// Tracking of the lateral position (setpoint - recorded position) in the
// segments named `name` (all passes): in steady sliding (the last 40 % of
// each) and after each reversal (the first 0.5 s of every pass but the first).
struct TrackingFigures {
  double steady_rms_m = 0;
  double steady_mean_abs_m = 0;  // |mean| of each steady window, averaged: the loop's lag
  double reversal_rms_m = 0;
  double reversal_max_m = 0;
};
TrackingFigures tracking_figures(const InProcessRun& run, const std::string& name);

// The segment indices whose name starts with prefix.
std::vector<std::uint32_t> segments_named(const InProcessRun& run, const std::string& prefix);

// The extremes a run reached, against the supervisor's limits.
struct RunExtremes {
  double max_abs_lateral_force_n = 0;   // recorded
  double max_abs_compensation_n = 0;    // per tick (simulated backend)
  bool tripped = false;
  std::string trip;                     // the trip's description
};
RunExtremes run_extremes(const InProcessRun& run);

// The scorecard's stick-slip experiment (scorecard/experiments.h,
// stick_slip_ratio), with the compensation: a 20 s scratch at velocity under
// 1 mN with the position loop at loop_rate_hz (below 100 Hz integral action
// only, ki = 500 N/(m s)), the tip's largest true advance per 0.1 s over the
// second half over the commanded advance (> 3: stick-slip). model null: none.
double stick_slip_ratio(const v1::DaemonConfig& config, const daemon::IdentifiedFriction* model,
                        double loop_rate_hz, double velocity_m_per_s, std::uint64_t seed);

// The report with every friction level (mu_c/Fc, mu_s/Fs, Fv, dwell_dFs)
// times level_factor and sigma0 times stiffness_factor: a model identified
// wrongly, for the robustness figures. Throws on a report that is not JSON.
std::string scaled_report(const std::string& report_json, double level_factor, double stiffness_factor);

}  // namespace tribo::testing
