#include "client/segment_reader.h"

#include <algorithm>

#include "proto/run_files.h"
#include "proto/sample_record.h"

namespace tribo::client {

namespace {

// The segment being gathered, thinned to stay within the cap.
class SegmentBuffer {
 public:
  explicit SegmentBuffer(std::uint64_t cap) : cap_(std::max<std::uint64_t>(cap, 2)) {}

  bool empty() const { return total_ == 0; }
  std::uint32_t segment() const { return segment_; }
  std::uint64_t held() const { return static_cast<std::uint64_t>(sample_count(kept_)); }
  std::uint64_t peak_held() const { return peak_; }

  void add(const Sample& s) {
    if (total_ == 0) segment_ = s.segment_index;
    if (total_++ % stride_ != 0) return;
    append_sample(s, kept_);
    peak_ = std::max(peak_, held());
    if (held() >= cap_) thin();
  }

  void emit(const std::function<void(const SegmentSamples&)>& on_segment) {
    if (total_ == 0) return;
    on_segment(SegmentSamples{kept_, stride_, total_});
    kept_.Clear();
    total_ = 0;
    stride_ = 1;
  }

 private:
  // Keeps the samples at even positions: those whose index in the segment is
  // a multiple of the doubled stride.
  void thin() {
    v1::SampleBlock half;
    for (int i = 0; i < sample_count(kept_); i += 2) append_sample(sample_at(kept_, i), half);
    kept_.Swap(&half);
    stride_ *= 2;
  }

  const std::uint64_t cap_;
  v1::SampleBlock kept_;
  std::uint64_t total_ = 0;
  std::uint32_t stride_ = 1;
  std::uint32_t segment_ = 0;
  std::uint64_t peak_ = 0;
};

}  // namespace

bool for_each_segment(const std::filesystem::path& run_dir, std::uint64_t cap_samples,
                      const std::function<void(const SegmentSamples&)>& on_segment, SegmentReadResult& result,
                      std::string& error) {
  result = {};
  SegmentBuffer segment(cap_samples);
  wire::RowIndex index;
  bool after_unload = false;  // a safe unload's samples end a span
  for (std::uint64_t from = 0;;) {
    v1::SampleBlock page;
    wire::RowsRead read;
    if (!wire::read_sample_rows(run_dir, {from, wire::RowIndex::kStride}, page, read, error, &index)) return false;
    const int n = sample_count(page);
    for (int i = 0; i < n; ++i) {
      const Sample s = sample_at(page, i);
      if (s.status_flags & v1::SAFE_UNLOAD) {
        after_unload = true;
        continue;
      }
      if (!segment.empty() && (after_unload || s.segment_index != segment.segment())) segment.emit(on_segment);
      after_unload = false;
      segment.add(s);
    }
    // An upper bound: the largest segment so far beside this page.
    result.peak_samples_held = std::max(result.peak_samples_held, segment.peak_held() + static_cast<std::uint64_t>(n));
    result.rows += static_cast<std::uint64_t>(n);
    from += static_cast<std::uint64_t>(n);
    if (n == 0 || read.end_of_file) break;
  }
  segment.emit(on_segment);
  return true;
}

}  // namespace tribo::client
