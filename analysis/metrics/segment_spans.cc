#include "analysis/metrics/segment_spans.h"

#include <cmath>

namespace tribo::analysis {

namespace {
constexpr double kMovingThresholdM = 1e-9;
}

std::vector<SegmentSpan> segment_spans(const v1::SampleBlock& b) {
  std::vector<SegmentSpan> spans;
  for (int i = 0; i < b.time_s_size(); ++i) {
    if (b.status_flags(i) & v1::SAFE_UNLOAD) continue;
    if (!spans.empty() && spans.back().last == i - 1 && b.segment_index(spans.back().first) == b.segment_index(i)) {
      spans.back().last = i;
    } else {
      spans.push_back({i, i});
    }
  }
  return spans;
}

bool lateral_setpoint_moves(const v1::SampleBlock& b, const SegmentSpan& s) {
  return std::fabs(b.lateral_setpoint_m(s.last) - b.lateral_setpoint_m(s.first)) > kMovingThresholdM;
}

}  // namespace tribo::analysis
