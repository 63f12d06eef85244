// The readable result of a run: tribo.v1.RunSummary built from the streamed
// run, printed as text for people or as JSON (proto field names) for scripts.
#pragma once

#include <string>

#include "client/tribo_client.h"
#include "tribo/v1/summary.pb.h"

namespace tribo::client {

v1::RunSummary summarize_run(const RunResult& run);
std::string summary_text(const v1::RunSummary& summary);
std::string summary_json(const v1::RunSummary& summary);

}  // namespace tribo::client
