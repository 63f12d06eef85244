#include "client/run_progress.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "proto/sample_record.h"

namespace tribo::client {

namespace {

constexpr auto kRedrawInterval = std::chrono::milliseconds(100);
constexpr int kBarWidth = 8;

}  // namespace

void RunProgress::on_document(const v1::ServerMessage& d) {
  if (d.has_run_descriptor()) descriptor_ = d.run_descriptor();
  if (d.has_gap()) gaps_ += d.gap().end_sequence() - d.gap().first_sequence();
  if (d.has_segment_event()) {
    const auto& e = d.segment_event();
    unloading_ = e.kind() == v1::UNLOAD_BEGIN;
    segment_index_ = e.segment_index();
    segment_ = e.segment_name();
  }
  if (d.has_samples() && sample_count(d.samples()) > 0) {
    // Friction: the lateral force along the commanded motion.
    const auto& b = d.samples();
    const int n = sample_count(b);
    const double motion = b.lateral_setpoint_m(n - 1) - b.lateral_setpoint_m(0);
    const double sign = motion > 0 ? 1.0 : motion < 0 ? -1.0 : 1.0;
    double lateral = 0, normal = 0;
    for (int i = 0; i < n; ++i) {
      lateral += b.lateral_force_n(i);
      normal += b.normal_force_n(i);
    }
    friction_n_ = sign * lateral / n;
    normal_n_ = normal / n;
    time_s_ = b.time_s(n - 1);
  }
  const auto now = std::chrono::steady_clock::now();
  if (!d.has_samples() || now - last_draw_ < kRedrawInterval) return;
  last_draw_ = now;
  std::fprintf(out_, "\r%s\033[K", line().c_str());
  std::fflush(out_);
  drawn_ = true;
}

std::string RunProgress::line() const {
  const double total = descriptor_.duration_s();
  const double fraction = total > 0 ? std::clamp(time_s_ / total, 0.0, 1.0) : 0.0;
  const int filled = static_cast<int>(std::lround(fraction * kBarWidth));
  std::string bar(static_cast<std::size_t>(filled), '#');
  bar.resize(kBarWidth, '-');
  // Segments count from 1 here and in the text summary (JSON and samples.csv
  // count segment_index from 0).
  const std::string text = fmt::format("[{}] {:3.0f}% seg {}/{} {:<12.12} {:.0f}/{:.0f} s F {:.1f} µN N {:.0f} µN{}",
                                       bar, fraction * 100, segment_index_ + 1, descriptor_.segment_names_size(),
                                       unloading_ ? "unloading" : segment_, time_s_, total, friction_n_ * 1e6,
                                       normal_n_ * 1e6, gaps_ > 0 ? " gap" : "");
  return fit_columns(text, kMaxColumns);
}

std::string fit_columns(const std::string& text, std::size_t columns) {
  std::size_t seen = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    // Count UTF-8 lead bytes: one column per code point (µ, °).
    if ((static_cast<unsigned char>(text[i]) & 0xC0) == 0x80) continue;
    if (seen == columns) return text.substr(0, i);
    ++seen;
  }
  return text;
}

void RunProgress::finish() {
  if (!drawn_) return;
  std::fprintf(out_, "\r\033[K");
  std::fflush(out_);
}

}  // namespace tribo::client
