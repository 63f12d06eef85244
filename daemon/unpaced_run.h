// A whole run on the simulated instrument in the calling thread, unpaced:
// what tribod's run thread does (daemon/instrument_service.cc, run_main)
// minus recording and publishing, with the transducer tribod builds for the
// same config and seed, so the samples are tribod's recording bit for bit.
// For in-process runs (tribo_native.simulate) and the build's profile run.
#pragma once

#include <cstdint>
#include <vector>

#include "daemon/load_function.h"
#include "daemon/run_loop.h"
#include "proto/sample_record.h"
#include "tribo/v1/daemon_config.pb.h"

namespace tribo::daemon {

struct UnpacedRun {
  std::vector<Sample> samples;
  RunOutcome outcome;
};

// Throws std::runtime_error when the config names no backend tribod can build.
UnpacedRun run_unpaced(const v1::DaemonConfig& config, const LoadFunction& load_function, std::uint64_t seed);

}  // namespace tribo::daemon
