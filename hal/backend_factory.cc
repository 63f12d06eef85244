#include "hal/backend_factory.h"

#include "hal/sim_transducer.h"
#include "sim/fault_injection.h"
#include "sim/instrument_params.h"

namespace tribo::hal {

std::unique_ptr<Transducer> make_transducer(const v1::DaemonConfig& config, std::uint64_t seed) {
  switch (config.backend_case()) {
    case v1::DaemonConfig::kSim:
      return std::make_unique<SimTransducer>(sim::instrument_params_from_config(config.sim()), seed,
                                             config.controller().loop_rate_hz(),
                                             config.controller().pace_to_wall_clock(),
                                             sim::fault_schedule_from_config(config.sim().faults()));
    case v1::DaemonConfig::BACKEND_NOT_SET:
      break;
  }
  return nullptr;
}

std::optional<std::string> validate_backend_config(const v1::DaemonConfig& config) {
  switch (config.backend_case()) {
    case v1::DaemonConfig::kSim:
      return sim::validate_sim_config(config.sim());
    case v1::DaemonConfig::BACKEND_NOT_SET:
      break;
  }
  return "backend: no backend configured (set sim { ... })";
}

std::string backend_name(const v1::DaemonConfig& config) {
  switch (config.backend_case()) {
    case v1::DaemonConfig::kSim:
      return "sim";
    case v1::DaemonConfig::BACKEND_NOT_SET:
      break;
  }
  return "none";
}

}  // namespace tribo::hal
