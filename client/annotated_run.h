// `tribo run`'s session: run_protocol (client/tribo_client.h) with a whole
// StartRun (seed and the user's annotations: sample, tip, operator, notes),
// and a hook that may send requests (abort) on the controlling connection
// between documents.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "client/tribo_client.h"

namespace tribo::client {

// Loads, subscribes, starts with `start`, and collects the run until it stops
// (as run_protocol). on_document sees every run document; it runs on the
// caller's thread between reads, so it may call client.request().
RunResult run_protocol_with(TriboClient& client, const v1::Protocol& protocol, const v1::StartRun& start,
                            const std::function<void(const v1::ServerMessage&)>& on_document = {});

// Parses "key=value" into annotations.extra; returns a message naming the
// problem, or "" on success.
std::string add_annotation(v1::RunAnnotations& annotations, const std::string& key_value);

}  // namespace tribo::client
