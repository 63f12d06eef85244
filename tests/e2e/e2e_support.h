// Shared by the end-to-end tests: protocols, configs written to a temp dir,
// and a log of the run documents one client received.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "client/tribo_client.h"
#include "proto/sample_record.h"
#include "proto/text_format_file.h"
#include "tests/sim/sim_test_support.h"
#include "tests/support/daemon_process.h"
#include "tests/support/raw_client.h"

namespace tribo::testing {

inline const std::string kStandardProtocolPath =
    std::string(TRIBO_SOURCE_DIR) + "/config/protocols/standard_scratch.textproto";

inline v1::Protocol standard_protocol() {
  v1::Protocol p;
  if (auto e = wire::load_text_proto_file(kStandardProtocolPath, p)) throw std::runtime_error(*e);
  return p;
}

// The standard scratch in 3 s: approach 0.5, load 0.5, scratch +2 -> +2.5 µm
// in 1 s, unload 0.5, return 0.5.
inline v1::Protocol short_protocol() {
  v1::Protocol p = standard_protocol();
  p.set_name("short-scratch");
  const double durations[] = {0.5, 0.5, 1.0, 0.5, 0.5};
  for (int i = 0; i < 5; ++i) p.mutable_segments(i)->set_duration_s(durations[i]);
  p.mutable_segments(2)->mutable_lateral()->set_end_um(2.5);
  p.mutable_segments(3)->mutable_lateral()->set_end_um(2.5);
  return p;
}

inline client::SessionOptions controller_session(const std::string& token = "") {
  client::SessionOptions s;
  s.client_name = "test controller";
  s.role = v1::CONTROLLER;
  s.token = token;
  return s;
}

inline client::SessionOptions observer_session() {
  client::SessionOptions s;
  s.client_name = "test observer";
  return s;
}

// Writes config into dir/tribod.textproto; returns the path.
inline std::string write_config(const TempDir& dir, const v1::DaemonConfig& config) {
  const auto path = dir.path() / "tribod.textproto";
  std::ofstream(path) << wire::to_text_proto(config);
  return path.string();
}

inline v1::DaemonConfig paced_config() {
  v1::DaemonConfig c = default_config();
  c.mutable_controller()->set_pace_to_wall_clock(true);
  return c;
}

// Every run document one client received, in order of arrival.
struct StreamLog {
  std::vector<v1::ServerMessage> documents;
  std::vector<v1::SampleBlock> blocks;
  std::vector<v1::GapNotice> gaps;
  std::vector<v1::SegmentEvent> events;
  std::vector<v1::Fault> faults;
  std::optional<v1::RunStart> start;
  std::optional<v1::RunDescriptor> descriptor;
  std::optional<v1::RunStop> stop;

  void add(const v1::ServerMessage& d) {
    documents.push_back(d);
    if (d.has_run_start()) start = d.run_start();
    if (d.has_run_descriptor()) descriptor = d.run_descriptor();
    if (d.has_samples()) blocks.push_back(d.samples());
    if (d.has_gap()) gaps.push_back(d.gap());
    if (d.has_segment_event()) events.push_back(d.segment_event());
    if (d.has_fault()) faults.push_back(d.fault());
    if (d.has_run_stop()) stop = d.run_stop();
  }
};

// Reads documents until the run stops (or the connection fails).
inline StreamLog read_until_stop(RawClient& client) {
  StreamLog log;
  while (!log.stop) {
    auto d = client.read();
    if (!d) break;
    if (d->request_id() == 0) log.add(*d);
  }
  return log;
}

// The sequence numbers a client at this decimation should see from [0, n)
// are exactly those delivered plus those announced missing, each once, in
// increasing order. Returns a description of the first violation, or "".
inline std::string check_coverage(const StreamLog& log, std::uint64_t n, std::uint32_t decimation) {
  struct Range {
    std::uint64_t first, end;
  };
  std::vector<Range> ranges;
  std::uint64_t last = 0;
  bool any = false;
  for (const auto& b : log.blocks) {
    for (int i = 0; i < sample_count(b); ++i) {
      const std::uint64_t seq = b.first_sequence() + static_cast<std::uint64_t>(i) * (decimation);
      if (any && seq <= last) return "sequence " + std::to_string(seq) + " after " + std::to_string(last);
      last = seq;
      any = true;
    }
    const auto count = static_cast<std::uint64_t>(sample_count(b));
    ranges.push_back({b.first_sequence(), b.first_sequence() + (count - 1) * decimation + 1});
  }
  for (const auto& g : log.gaps) ranges.push_back({g.first_sequence(), g.end_sequence()});
  std::sort(ranges.begin(), ranges.end(), [](const Range& a, const Range& b) { return a.first < b.first; });
  std::uint64_t next = 0;  // first sequence not yet covered
  for (const auto& r : ranges) {
    // No sequence this client should see may lie in [next, r.first).
    const std::uint64_t expected = (next + decimation - 1) / decimation * decimation;
    if (r.first > expected) return "hole before " + std::to_string(r.first) + " (covered up to " + std::to_string(next) + ")";
    if (r.first < next) return "overlap at " + std::to_string(r.first);
    next = r.end;
  }
  if ((next + decimation - 1) / decimation * decimation < n) return "covered only up to " + std::to_string(next) + " of " + std::to_string(n);
  return "";
}

}  // namespace tribo::testing
