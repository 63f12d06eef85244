#include "tests/analysis/sim_identification_run.h"

#include <stdexcept>
#include <vector>

#include "analysis/input/series_input.h"
#include "tests/daemon/service_test_support.h"

namespace tribo::testing {

namespace {

v1::DaemonConfig identification_config_from(const std::string& file, const ConfigEdit& edit) {
  return shipped_config(file, [&](v1::DaemonConfig& config) {
    config.mutable_controller()->mutable_lateral_displacement()->set_setpoint_weight_p(1.0);
    config.mutable_sim()->mutable_tip()->mutable_tilt_offset()->set_enabled(false);
    if (edit) edit(config);
  });
}

}  // namespace

v1::DaemonConfig identification_config(const ConfigEdit& edit) {
  // The contact these tests were written for: plain LuGre, kept as config/instruments/lugre_plain.textproto.
  return identification_config_from("/config/instruments/lugre_plain.textproto", edit);
}

v1::DaemonConfig fitted_contact_identification_config(const ConfigEdit& edit) {
  return identification_config_from("/config/instruments/fitted_contact.textproto", [&](v1::DaemonConfig& c) {
    c.mutable_sim()->mutable_friction()->mutable_dwell_stiction()->set_enabled(false);
    if (edit) edit(c);
  });
}

v1::DaemonConfig default_instrument_identification_config(const ConfigEdit& edit) {
  return identification_config_from("/config/tribod.textproto", [&](v1::DaemonConfig& c) {
    c.mutable_sim()->mutable_friction()->mutable_dwell_stiction()->set_enabled(false);
    if (edit) edit(c);
  });
}

v1::DaemonConfig shipped_config(const std::string& file, const ConfigEdit& edit) {
  v1::DaemonConfig config;
  if (auto error = daemon::load_daemon_config(std::string(TRIBO_SOURCE_DIR) + file, config)) {
    throw std::runtime_error(*error);
  }
  if (edit) edit(config);
  return config;
}

analysis::MeasuredSeries simulated_identification_record(const v1::DaemonConfig& config, std::uint64_t seed) {
  return simulated_record(config, "identification.textproto", seed);
}

analysis::MeasuredSeries simulated_record(const v1::DaemonConfig& config, const std::string& protocol_file,
                                          std::uint64_t seed) {
  const v1::Protocol protocol = daemon::testing::load_protocol_file(protocol_file);
  const daemon::testing::LoopRun run = daemon::testing::run_in_loop(config, protocol, {}, seed);
  if (run.outcome.end != daemon::RunEnd::kCompleted) {
    throw std::runtime_error(protocol_file + " run did not complete: " + daemon::trip_description(run.outcome.trip));
  }
  if (run.samples.empty()) throw std::runtime_error(protocol_file + " run recorded nothing");
  // Segment 0 is the unloaded approach, the last the unloaded return.
  const std::uint32_t last = run.samples.back().segment_index;
  std::vector<Sample> loaded;
  for (const Sample& s : run.samples) {
    if (s.segment_index >= 1 && s.segment_index < last) loaded.push_back(s);
  }
  return analysis::series_from_samples(loaded, protocol_file + " run (simulated)");
}

analysis::MeasuredSeries simulated_identification_run(const v1::DaemonConfig& config, std::uint64_t seed) {
  analysis::MeasuredSeries series = simulated_identification_record(config, seed);
  analysis::derive_motion(series, 0);
  return series;
}

}  // namespace tribo::testing
