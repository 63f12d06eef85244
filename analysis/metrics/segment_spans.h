// A recorded tribo run cut into its protocol segments, as the run metrics,
// the scratch metrics and the tilt estimate read it.
#pragma once

#include <vector>

#include "tribo/v1/api.pb.h"

namespace tribo::analysis {

struct SegmentSpan {
  int first = 0;
  int last = 0;  // inclusive
};

// Contiguous runs of samples with the same segment index; samples of a safe
// unload (after a stop or trip) are left out.
std::vector<SegmentSpan> segment_spans(const v1::SampleBlock& samples);

// The lateral setpoint travels more than 1 nm over the span (else a hold).
bool lateral_setpoint_moves(const v1::SampleBlock& samples, const SegmentSpan& span);

}  // namespace tribo::analysis
