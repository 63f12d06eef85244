#include "client/annotated_run.h"

#include <algorithm>

#include "proto/sample_record.h"

namespace tribo::client {

namespace {

// As tribo_client.cc's: orders blocks by sequence and concatenates them;
// counts what is missing.
v1::SampleBlock concatenate(std::vector<v1::SampleBlock> blocks, std::uint64_t& missing) {
  std::sort(blocks.begin(), blocks.end(),
            [](const auto& a, const auto& b) { return a.first_sequence() < b.first_sequence(); });
  v1::SampleBlock out;
  missing = 0;
  std::uint64_t next = 0;
  for (const auto& b : blocks) {
    if (sample_count(b) == 0 || b.first_sequence() + static_cast<std::uint64_t>(sample_count(b)) <= next) continue;
    if (b.first_sequence() > next) missing += b.first_sequence() - next;
    if (b.first_sequence() < next) {  // overlaps what we have: take the new tail only
      v1::SampleBlock tail;
      for (int i = static_cast<int>(next - b.first_sequence()); i < sample_count(b); ++i) {
        append_sample(sample_at(b, i), tail);
      }
      append_block(tail, out);
    } else {
      append_block(b, out);
    }
    next = b.first_sequence() + static_cast<std::uint64_t>(sample_count(b));
  }
  return out;
}

}  // namespace

RunResult run_protocol_with(TriboClient& client, const v1::Protocol& protocol, const v1::StartRun& start_run,
                            const std::function<void(const v1::ServerMessage&)>& on_document) {
  RunResult result;
  v1::ClientMessage load;
  *load.mutable_load_protocol()->mutable_protocol() = protocol;
  result.loaded = client.request(load).load_protocol();

  v1::ClientMessage subscribe;
  subscribe.mutable_subscribe();
  client.request(subscribe);

  v1::ClientMessage start;
  *start.mutable_start_run() = start_run;
  const std::string run_id = client.request(start).start_run().run_id();

  std::vector<v1::SampleBlock> blocks;
  for (;;) {
    v1::ServerMessage event = client.next_event();
    if (on_document) on_document(event);
    if (event.has_run_start() && event.run_start().run_id() == run_id) {
      result.start = event.run_start();
    } else if (event.has_run_descriptor() && event.run_descriptor().run_id() == run_id) {
      result.descriptor = event.run_descriptor();
    } else if (event.has_samples() && event.samples().run_id() == run_id) {
      blocks.push_back(std::move(*event.mutable_samples()));
    } else if (event.has_segment_event() && event.segment_event().run_id() == run_id) {
      result.segment_events.push_back(event.segment_event());
    } else if (event.has_fault() && event.fault().run_id() == run_id) {
      result.faults.push_back(event.fault());
    } else if (event.has_gap() && event.gap().run_id() == run_id) {
      result.gaps.push_back(event.gap());
    } else if (event.has_run_stop() && event.run_stop().run_id() == run_id) {
      result.stop = event.run_stop();
      break;
    }
  }
  // What the stream missed is in the recording.
  for (const auto& gap : result.gaps) {
    blocks.push_back(fetch_samples(client, run_id, gap.first_sequence(), gap.end_sequence()));
    result.fetched_samples += static_cast<std::uint64_t>(sample_count(blocks.back()));
  }
  std::uint64_t holes = 0;
  result.samples = concatenate(std::move(blocks), holes);
  const auto have = static_cast<std::uint64_t>(sample_count(result.samples));
  result.missing_samples = result.stop.sample_count() > have ? result.stop.sample_count() - have : holes;
  result.samples.set_run_id(run_id);
  return result;
}

std::string add_annotation(v1::RunAnnotations& annotations, const std::string& key_value) {
  const auto eq = key_value.find('=');
  if (eq == std::string::npos || eq == 0) return "--meta " + key_value + " is not KEY=VALUE";
  (*annotations.mutable_extra())[key_value.substr(0, eq)] = key_value.substr(eq + 1);
  return "";
}

}  // namespace tribo::client
