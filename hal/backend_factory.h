// Builds the transducer backend that the daemon config selects. A run gets a
// fresh backend session; for the simulated one that means a plant at rest and
// noise generators seeded with the run's seed.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "hal/transducer.h"
#include "tribo/v1/daemon_config.pb.h"

namespace tribo::hal {

std::unique_ptr<Transducer> make_transducer(const v1::DaemonConfig& config, std::uint64_t seed);

// Checks the backend section of the config; errors name the field.
std::optional<std::string> validate_backend_config(const v1::DaemonConfig& config);

std::string backend_name(const v1::DaemonConfig& config);

}  // namespace tribo::hal
