// Converts the simulated instrument's config (tribo.v1.SimConfig, SI) into the
// plain parameter structs of sim/, and checks it. Errors name the field and
// the limit.
#pragma once

#include <optional>
#include <string>

#include "sim/instrument.h"
#include "tribo/v1/sim_config.pb.h"

namespace tribo::sim {

InstrumentParams instrument_params_from_config(const v1::SimConfig& config);

// nullopt when the config is usable, else "sim.<field> = value: reason".
std::optional<std::string> validate_sim_config(const v1::SimConfig& config);

}  // namespace tribo::sim
