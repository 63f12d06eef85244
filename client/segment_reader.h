// Reads a recorded samples.csv back one protocol segment at a time, so that
// a run of any length is summarised in bounded memory. A segment here is what
// analysis/metrics/segment_spans.h calls a span: the consecutive samples of one
// segment index, without those of a safe unload (which end a span).
//
// Memory is bounded by a cap on the samples held for one segment. A longer
// segment is thinned as it is read: when the cap is reached, every second
// held sample is dropped and from then on only every stride-th sample
// (counted from the segment's first) is kept, the stride doubling each time
// the cap is reached again. Its metrics then come from that uniform subset
// (the summary says so); every other segment is analysed from every sample.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include "tribo/v1/api.pb.h"

namespace tribo::client {

// 2^20 samples of 72 bytes: at most ~75 MB (plus one page of 8192 rows), a
// 17-minute segment at 1 kHz, 105 s at 10 kHz.
inline constexpr std::uint64_t kSegmentCapSamples = 1 << 20;

struct SegmentSamples {
  const v1::SampleBlock& samples;  // the kept samples, in order
  std::uint32_t stride = 1;        // 1: every sample of the segment
  std::uint64_t total = 0;         // the segment's samples, kept or not
};

struct SegmentReadResult {
  std::uint64_t rows = 0;               // all rows of the file, safe unload included
  std::uint64_t peak_samples_held = 0;  // segment buffer plus the page being read
};

// Calls on_segment for each segment in file order. Returns false and sets
// error when the file cannot be read or a row is malformed.
bool for_each_segment(const std::filesystem::path& run_dir, std::uint64_t cap_samples,
                      const std::function<void(const SegmentSamples&)>& on_segment, SegmentReadResult& result,
                      std::string& error);

}  // namespace tribo::client
