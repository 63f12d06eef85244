// The readable result of a run: tribo.v1.RunSummary built from the streamed
// run, printed as text for people or as JSON (proto field names) for scripts.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "analysis/metrics/run_metrics.h"
#include "analysis/metrics/scratch_metrics.h"
#include "analysis/metrics/tip_tilt.h"
#include "client/tribo_client.h"
#include "tribo/v1/summary.pb.h"

namespace tribo::client {

// From every sample in memory.
v1::RunSummary summarize_run(const RunResult& run);

// The same summary fed one segment at a time, in run order (a segment: the
// consecutive samples of one segment index, safe unload left out; see
// client/segment_reader.h). With every sample of every segment (stride 1) it
// is identical to summarize_run's; a segment given thinned (every stride-th
// sample) is marked so (sample_stride).
class RunSummarizer {
 public:
  explicit RunSummarizer(const RunDocuments& run);
  void add_segment(const v1::SampleBlock& samples, std::uint32_t stride = 1);
  v1::RunSummary finish(std::uint64_t sample_count) const;

 private:
  struct Scratch {
    analysis::SlidingSegmentMetrics metrics;
    analysis::SlidingCheck check;
    std::uint32_t stride = 1;
  };
  const RunDocuments& run_;
  analysis::TipTiltAccumulator tilt_;
  std::vector<Scratch> scratches_;  // tilt-corrected at the end, once the tilt is known
  std::vector<v1::OscillationSummary> oscillations_;
};

// The summary of a run written to run_dir (samples.csv), read back a segment
// at a time with at most cap_samples held for one segment (longer segments
// are thinned: client/segment_reader.h). nullopt and error if the file cannot
// be read. peak_samples_held (optional): the most samples held at once.
std::optional<v1::RunSummary> summarize_recording(const RunDocuments& run, const std::filesystem::path& run_dir,
                                                  std::uint64_t cap_samples, std::string& error,
                                                  std::uint64_t* peak_samples_held = nullptr);

std::string summary_text(const v1::RunSummary& summary);
std::string summary_json(const v1::RunSummary& summary);

}  // namespace tribo::client
