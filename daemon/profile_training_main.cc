// The build's profile run (cmake/profile_guided.cmake): one protocol on one
// simulated instrument config, unpaced, through the profiling copies of the
// simulated instrument and the tick path, whose counts GCC then optimises the
// shipped ones by. Prints what it ran; exits non-zero if the run did not
// complete, so a profile of a faulted run never reaches the build.
//
//   tribo_profile_training CONFIG PROTOCOL SEED
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "daemon/daemon_config.h"
#include "daemon/protocol_validator.h"
#include "daemon/unpaced_run.h"
#include "proto/text_format_file.h"

namespace {

int fail(const std::string& what) {
  std::fprintf(stderr, "tribo_profile_training: %s\n", what.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace tribo;
  if (argc != 4) return fail("usage: tribo_profile_training CONFIG PROTOCOL SEED");
  v1::DaemonConfig config;
  if (auto error = daemon::load_daemon_config(argv[1], config)) return fail(*error);
  v1::Protocol protocol;
  if (auto error = wire::load_text_proto_file(argv[2], protocol)) return fail(*error);
  const daemon::ProtocolCheck check = daemon::validate_protocol(protocol, config);
  if (!check.ok()) return fail(check.errors.front().field + ": " + check.errors.front().message);
  try {
    const daemon::UnpacedRun run = daemon::run_unpaced(config, check.load_function, std::strtoull(argv[3], nullptr, 10));
    if (run.outcome.end != daemon::RunEnd::kCompleted) return fail("the run did not complete: " + daemon::trip_description(run.outcome.trip));
    std::printf("profile run: %zu samples, %.0f s simulated\n", run.samples.size(),
                run.samples.empty() ? 0.0 : run.samples.back().time_s);
  } catch (const std::exception& e) {
    return fail(e.what());
  }
  return 0;
}
