// Runs of tribo's simulated instrument for the diagnosis tests: the shipped
// identification protocol (config/protocols/identification.textproto) in the
// real-time loop in-process (tests/daemon/service_test_support.h,
// run_in_loop), on the default config with one edit, and the recorded
// samples as the analysis reads a recorded run (analysis/input/series_input.h).
//
// The base config differs from config/tribod.textproto in two documented
// ways: the lateral loop weights its setpoint in P (b = 1, the protocol's
// note: the 40 µm/s passes outlast the default loop's lag only then), and
// the tip is not tilted (tilt is one effect of the vocabulary, switched on
// by the tilt test like every other; see tests/analysis/diagnosis_sim_test.cc).
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "analysis/input/measured_series.h"
#include "tribo/v1/daemon_config.pb.h"

namespace tribo::testing {

using ConfigEdit = std::function<void(v1::DaemonConfig&)>;

// The base config of the identification runs (see above).
v1::DaemonConfig identification_config(const ConfigEdit& edit = {});

// The same two changes on the fitted contact
// (config/instruments/fitted_contact.textproto: elasto-plastic presliding and
// rate-and-state with the direct effect on the tip's velocity, curve-fitted to
// Table 5.1), with its dwell strengthening off so that a run holds the contact
// law alone. The contact-choice tests and their figures were written on it.
v1::DaemonConfig fitted_contact_identification_config(const ConfigEdit& edit = {});

// The same two changes on the default instrument (config/tribod.textproto),
// with its dwell term off: the runs of the reliability maps
// (config/campaigns/identification_reliability*.toml).
v1::DaemonConfig default_instrument_identification_config(const ConfigEdit& edit = {});

// The identification protocol on the simulated instrument with this config:
// lateral position, lateral force (the sensor's: friction plus the plate's
// inertia m a, the tilt, and the sensor noise), normal force, setpoint, from
// the first load ramp to the end of the unloading (the unloaded approach and
// return are left out); velocity and acceleration derived from the position.
analysis::MeasuredSeries simulated_identification_run(const v1::DaemonConfig& config, std::uint64_t seed = 1);

// The same record as tribo-fit reads a run directory, before any motion is
// derived (analysis::diagnose_series estimates it).
analysis::MeasuredSeries simulated_identification_record(const v1::DaemonConfig& config, std::uint64_t seed = 1);

// A shipped config (path from the source tree, e.g. "/config/tribod.textproto")
// as it is, then edited.
v1::DaemonConfig shipped_config(const std::string& file, const ConfigEdit& edit = {});

// Any shipped protocol (config/protocols/<protocol_file>) recorded as above:
// the loaded segments, from the first after the approach to the last before
// the return.
analysis::MeasuredSeries simulated_record(const v1::DaemonConfig& config, const std::string& protocol_file,
                                          std::uint64_t seed = 1);

}  // namespace tribo::testing
