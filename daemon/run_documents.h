// The run documents the daemon writes and publishes (api.proto: RunStart,
// RunDescriptor, SegmentEvent, RunStop's backend health), built from what the
// service holds. Everything that names a segment takes the name from the
// unrolled plan (load_function.segments()), never from the protocol's
// segment list, which has repeat blocks folded.
#pragma once

#include <cstdint>
#include <string_view>

#include "daemon/load_function.h"
#include "hal/transducer.h"
#include "tribo/v1/api.pb.h"

namespace tribo::daemon {

// The start document without run id and start time (the recorder and the
// service set them). gains: the gains in force, by ControlLoop - 1.
v1::RunStart make_run_start(const v1::Protocol& protocol, const v1::DaemonConfig& config,
                            const LoadFunction& load_function, const v1::PidGains (&gains)[4],
                            std::uint64_t seed, const std::string& software_version,
                            const v1::RunAnnotations& annotations);

v1::RunDescriptor make_descriptor(const LoadFunction& load_function);

// The event at a sample of the unrolled segment segment_index.
v1::SegmentEvent make_segment_event(const std::string& run_id, const LoadFunction& load_function,
                                    v1::SegmentEventKind kind, std::uint32_t segment_index,
                                    std::uint64_t sequence, double time_s);

v1::BackendHealth health_message(std::string_view backend, const hal::BackendHealth& h);

}  // namespace tribo::daemon
