// Benchmarks of the socket API and the recorder:
//   BM_SerializeSampleBlock   samples/s framed (protobuf) by the drain thread
//   BM_RecorderCsvRows        samples/s formatted as CSV rows by the recorder
//   BM_DeliverToOneClient     samples/s published, sent over loopback and
//                             decoded by one client, in blocks of 1024
//   BM_PacedRun10kHz8Observers  a real tribod pacing a 10 kHz run to the wall
//                             clock with 8 observers: samples lost at the
//                             recorder, per-client delivery rate, latency
//                             (publish -> received) p50/p99
#include <benchmark/benchmark.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <thread>
#include <vector>

#include <asio.hpp>

#include "client/tribo_client.h"
#include "daemon/api_server.h"
#include "proto/framing.h"
#include "proto/sample_record.h"

#ifdef TRIBO_BENCH_WITH_DAEMON
#include "tests/e2e/e2e_support.h"
#endif

namespace {

using namespace tribo;

constexpr int kBlockSamples = 1024;

v1::SampleBlock make_block(std::uint64_t first_sequence) {
  v1::SampleBlock b;
  b.set_run_id("20260101-000000-000");
  b.set_first_sequence(first_sequence);
  for (int i = 0; i < kBlockSamples; ++i) {
    const double t = static_cast<double>(first_sequence + static_cast<std::uint64_t>(i)) * 1e-4;
    append_sample(Sample{t, 2, 1e-3, 0.99672e-3 + 1e-7 * std::sin(t * 7), 1.5e-7, 2e-6 + 5e-7 * t,
                         2e-6 + 5e-7 * t - 1.05e-7, 1.2738e-4 + 3e-6 * std::cos(t * 13), 0},
                  b);
  }
  return b;
}

std::uint64_t now_ns() {
  return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                        std::chrono::system_clock::now().time_since_epoch())
                                        .count());
}

void BM_SerializeSampleBlock(benchmark::State& state) {
  v1::ServerMessage message;
  *message.mutable_samples() = make_block(0);
  std::string frame;
  for (auto _ : state) {
    frame.clear();
    wire::append_frame(message, ~std::size_t{0}, frame);
    benchmark::DoNotOptimize(frame.data());
  }
  state.SetItemsProcessed(state.iterations() * kBlockSamples);
  state.counters["bytes_per_sample"] = static_cast<double>(frame.size()) / kBlockSamples;
}
BENCHMARK(BM_SerializeSampleBlock);

void BM_RecorderCsvRows(benchmark::State& state) {
  const v1::SampleBlock block = make_block(0);
  std::string csv;
  for (auto _ : state) {
    csv.clear();
    for (int i = 0; i < kBlockSamples; ++i) append_csv_row(sample_at(block, i), csv);
    benchmark::DoNotOptimize(csv.data());
  }
  state.SetItemsProcessed(state.iterations() * kBlockSamples);
  state.counters["bytes_per_sample"] = static_cast<double>(csv.size()) / kBlockSamples;
}
BENCHMARK(BM_RecorderCsvRows);

// The daemon's API server in-process, without a run: the benchmark thread
// plays the drain thread and publishes blocks; one client over loopback
// reads and decodes them. The publisher stays at most 32 blocks ahead of the
// client (well within the client's queue budget), so nothing is dropped.
void BM_DeliverToOneClient(benchmark::State& state) {
  v1::DaemonConfig config;
  config.mutable_server()->set_bind_address("127.0.0.1");
  config.mutable_server()->set_max_frame_bytes(4 << 20);
  config.mutable_recorder()->set_data_dir("/nonexistent");
  asio::io_context io;
  auto guard = asio::make_work_guard(io);
  tribo::daemon::ApiServer server(io, config.server(), "");
  tribo::daemon::InstrumentService service(config, "bench", server);
  server.attach(service);
  server.start_accepting();
  std::thread io_thread([&] { io.run(); });

  client::TriboClient client({"127.0.0.1", server.port()}, client::SessionOptions{});
  v1::ClientMessage subscribe;
  subscribe.mutable_subscribe();
  client.request(subscribe);
  std::atomic<std::uint64_t> received{0}, gaps{0};
  std::atomic<bool> stop{false};
  std::thread reader([&] {
    while (!stop.load()) {
      const v1::ServerMessage m = client.next_event();
      if (m.has_samples()) received += static_cast<std::uint64_t>(sample_count(m.samples()));
      if (m.has_gap()) ++gaps;
      if (m.has_run_stop()) break;
    }
  });

  std::vector<v1::SampleBlock> blocks;
  for (int i = 0; i < 64; ++i) blocks.push_back(make_block(0));
  std::uint64_t published = 0;
  for (auto _ : state) {
    v1::SampleBlock& b = blocks[published / kBlockSamples % blocks.size()];
    b.set_first_sequence(published);
    server.on_samples(b);
    published += kBlockSamples;
    while (published - received.load() > 32 * kBlockSamples) std::this_thread::yield();
  }
  while (received.load() < published && gaps.load() == 0) std::this_thread::yield();
  state.SetItemsProcessed(static_cast<std::int64_t>(received.load()));
  state.counters["gap_notices"] = static_cast<double>(gaps.load());
  v1::RunStop stop_document;
  stop.store(true);
  server.on_run_stop(stop_document);
  reader.join();
  server.close_gracefully(std::chrono::milliseconds(100));
  guard.reset();
  io_thread.join();
}
BENCHMARK(BM_DeliverToOneClient)->UseRealTime()->MinTime(2.0);

#ifdef TRIBO_BENCH_WITH_DAEMON
double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(p * static_cast<double>(v.size() - 1))];
}

// A 10 s protocol recorded at 10 kHz (the loop rate), paced to the wall
// clock, with 8 observers taking every sample.
void BM_PacedRun10kHz8Observers(benchmark::State& state) {
  constexpr int kObservers = 8;
  for (auto _ : state) {
    tribo::testing::TempDir data, cfg;
    tribo::testing::DaemonProcess tribod(data.path(), tribo::testing::write_config(cfg, tribo::testing::paced_config()));
    v1::Protocol protocol = tribo::testing::standard_protocol();
    protocol.set_acquisition_rate_hz(10000);
    const double durations[] = {2, 2, 4, 1, 1};
    for (int i = 0; i < 5; ++i) protocol.mutable_segments(i)->set_duration_s(durations[i]);
    protocol.mutable_segments(2)->mutable_lateral()->set_end_um(4);
    protocol.mutable_segments(3)->mutable_lateral()->set_end_um(4);

    struct Observer {
      std::uint64_t samples = 0, gaps = 0;
      std::vector<double> latency_ms;
      std::uint64_t first_ns = 0, last_ns = 0;
    };
    std::vector<Observer> observers(kObservers);
    std::vector<std::unique_ptr<tribo::testing::RawClient>> sockets;
    for (int i = 0; i < kObservers; ++i) {
      sockets.push_back(std::make_unique<tribo::testing::RawClient>(tribod.port()));
      sockets.back()->request(tribo::testing::hello_message());
      v1::ClientMessage sub;
      sub.mutable_subscribe();
      sockets.back()->request(sub);
    }
    std::vector<std::thread> readers;
    for (int i = 0; i < kObservers; ++i) {
      readers.emplace_back([&, i] {
        Observer& o = observers[static_cast<std::size_t>(i)];
        for (;;) {
          auto m = sockets[static_cast<std::size_t>(i)]->read(60000);
          if (!m || m->has_run_stop()) break;
          const std::uint64_t t = now_ns();
          if (m->has_gap()) o.gaps += m->gap().end_sequence() - m->gap().first_sequence();
          if (!m->has_samples()) continue;
          if (o.first_ns == 0) o.first_ns = t;
          o.last_ns = t;
          o.samples += static_cast<std::uint64_t>(sample_count(m->samples()));
          o.latency_ms.push_back(static_cast<double>(t - m->samples().publish_time_unix_ns()) * 1e-6);
        }
      });
    }
    client::TriboClient controller({"127.0.0.1", tribod.port()}, tribo::testing::controller_session());
    const client::RunResult run = client::run_protocol(controller, protocol, std::nullopt);
    for (auto& t : readers) t.join();
    v1::ClientMessage status_request;
    status_request.mutable_get_status();
    const v1::StatusReply status = controller.request(status_request).status();

    std::vector<double> all_latency;
    double min_rate = 1e18, max_rate = 0, lost_to_clients = 0;
    for (const auto& o : observers) {
      all_latency.insert(all_latency.end(), o.latency_ms.begin(), o.latency_ms.end());
      const double span_s = static_cast<double>(o.last_ns - o.first_ns) * 1e-9;
      const double rate = span_s > 0 ? static_cast<double>(o.samples) / span_s : 0;
      min_rate = std::min(min_rate, rate);
      max_rate = std::max(max_rate, rate);
      lost_to_clients += static_cast<double>(o.gaps);
    }
    state.counters["expected_samples"] = 100000;
    state.counters["recorded_samples"] = static_cast<double>(status.samples_recorded());
    state.counters["dropped_before_recorder"] = static_cast<double>(status.samples_dropped());
    state.counters["exit_success"] = run.stop.exit_status() == v1::SUCCESS ? 1 : 0;
    state.counters["client_rate_min_per_s"] = min_rate;
    state.counters["client_rate_max_per_s"] = max_rate;
    state.counters["samples_in_gaps_all_clients"] = lost_to_clients;
    state.counters["latency_p50_ms"] = percentile(all_latency, 0.50);
    state.counters["latency_p99_ms"] = percentile(all_latency, 0.99);
    state.counters["latency_max_ms"] = percentile(all_latency, 1.0);
    state.counters["blocks_per_client"] = static_cast<double>(observers[0].latency_ms.size());
  }
}
BENCHMARK(BM_PacedRun10kHz8Observers)->Iterations(1)->UseRealTime()->Unit(benchmark::kSecond);
#endif

}  // namespace

BENCHMARK_MAIN();
