// `tribo run --meta KEY=VALUE`: the user's free-form run metadata.
#pragma once

#include <string>

#include "tribo/v1/api.pb.h"

namespace tribo::client {

// Parses "key=value" into annotations.extra; returns a message naming the
// problem, or "" on success.
std::string add_annotation(v1::RunAnnotations& annotations, const std::string& key_value);

}  // namespace tribo::client
