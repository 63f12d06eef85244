// The run documents as clients see them: order, descriptor, decimation, gap
// notices and resume for slow clients, many observers, late subscribers,
// and what happens when the controlling client goes away.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <thread>

#include "proto/run_files.h"
#include "tests/e2e/e2e_support.h"

namespace tribo::testing {
namespace {

std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

v1::ClientMessage subscribe(std::uint32_t decimation = 1) {
  v1::ClientMessage m;
  m.mutable_subscribe()->set_decimation(decimation);
  return m;
}

v1::ClientMessage load(const v1::Protocol& p) {
  v1::ClientMessage m;
  *m.mutable_load_protocol()->mutable_protocol() = p;
  return m;
}

v1::ClientMessage start_run() {
  v1::ClientMessage m;
  m.mutable_start_run();
  return m;
}

v1::ClientMessage get_status() {
  v1::ClientMessage m;
  m.mutable_get_status();
  return m;
}

TEST(ApiStreaming, RunDocumentsArriveInOrderWithDescriptorEventsAndConsecutiveSequences) {
  TempDir data, cfg;
  v1::DaemonConfig config = default_config();
  config.mutable_server()->set_control_token("s3cret-token");
  DaemonProcess daemon(data.path(), write_config(cfg, config));
  RawClient observer(daemon.port());
  ASSERT_TRUE(observer.request(hello_message()).has_hello());
  ASSERT_TRUE(observer.request(subscribe()).has_subscribe());

  client::TriboClient controller({"127.0.0.1", daemon.port()}, controller_session("s3cret-token"));
  const auto run = client::run_protocol(controller, standard_protocol(), 3);
  const StreamLog log = read_until_stop(observer);

  ASSERT_TRUE(log.stop);
  ASSERT_GE(log.documents.size(), 4u);
  EXPECT_TRUE(log.documents[0].has_run_start());
  EXPECT_TRUE(log.documents[1].has_run_descriptor());
  EXPECT_TRUE(log.documents.back().has_run_stop());
  EXPECT_EQ(log.stop->exit_status(), v1::SUCCESS);
  EXPECT_EQ(log.stop->sample_count(), 32000u);
  EXPECT_TRUE(log.gaps.empty());
  EXPECT_EQ(check_coverage(log, 32000, 1), "");

  // The descriptor names every channel with its unit, as the CSV does.
  const v1::RunDescriptor& d = *log.descriptor;
  ASSERT_EQ(d.channels_size(), static_cast<int>(kSampleChannels.size()));
  for (int i = 0; i < d.channels_size(); ++i) {
    EXPECT_EQ(d.channels(i).name(), kSampleChannels[i].name);
    EXPECT_EQ(d.channels(i).unit(), kSampleChannels[i].unit);
    EXPECT_EQ(d.channels(i).block_field(), kSampleChannels[i].block_field);
  }
  EXPECT_EQ(d.expected_samples(), 32000u);
  EXPECT_EQ(d.segment_names_size(), 5);

  // One SEGMENT_BEGIN per segment, at the first sample of that segment, after
  // every sample before it and before any sample from it.
  ASSERT_EQ(log.events.size(), 5u);
  const v1::SampleBlock& all = run.samples;
  std::uint64_t delivered = 0;  // samples delivered before each event
  std::size_t next_event = 0;
  for (const auto& doc : log.documents) {
    if (doc.has_samples()) delivered += static_cast<std::uint64_t>(sample_count(doc.samples()));
    if (!doc.has_segment_event()) continue;
    const auto& e = doc.segment_event();
    EXPECT_EQ(e.kind(), v1::SEGMENT_BEGIN);
    EXPECT_EQ(e.segment_index(), next_event);
    EXPECT_EQ(e.segment_name(), standard_protocol().segments(static_cast<int>(next_event)).name());
    EXPECT_EQ(e.sequence(), delivered) << "event " << next_event;
    EXPECT_EQ(all.segment_index(static_cast<int>(e.sequence())), e.segment_index());
    if (e.sequence() > 0) {
      EXPECT_NE(all.segment_index(static_cast<int>(e.sequence()) - 1), e.segment_index());
    }
    ++next_event;
  }

  // The control token never leaves the daemon: not in the run start, not on disk.
  EXPECT_TRUE(log.start->config().server().control_token().empty());
  EXPECT_EQ(slurp(data.path() / log.start->run_id() / wire::kMetadataFile).find("s3cret-token"), std::string::npos);
  // The recording keeps the descriptor and the events.
  std::string error;
  const auto metadata = wire::read_run_metadata(data.path() / log.start->run_id(), error);
  ASSERT_TRUE(metadata) << error;
  EXPECT_EQ(metadata->run_descriptor().channels_size(), d.channels_size());
  EXPECT_EQ(metadata->segment_events_size(), 5);
}

TEST(ApiStreaming, EachClientGetsItsOwnDecimation) {
  TempDir data;
  DaemonProcess daemon(data.path());
  const std::uint32_t decimations[] = {1, 7, 10, 1000};
  std::vector<std::unique_ptr<RawClient>> observers;
  for (auto n : decimations) {
    observers.push_back(std::make_unique<RawClient>(daemon.port()));
    observers.back()->request(hello_message());
    observers.back()->request(subscribe(n));
  }
  client::TriboClient controller({"127.0.0.1", daemon.port()}, controller_session());
  const auto run = client::run_protocol(controller, standard_protocol(), std::nullopt);
  for (std::size_t k = 0; k < observers.size(); ++k) {
    const std::uint32_t n = decimations[k];
    const StreamLog log = read_until_stop(*observers[k]);
    ASSERT_TRUE(log.stop) << n;
    EXPECT_EQ(check_coverage(log, 32000, n), "") << n;
    EXPECT_TRUE(log.gaps.empty()) << n;
    std::uint64_t count = 0;
    for (const auto& b : log.blocks) {
      for (int i = 0; i < sample_count(b); ++i) {
        const std::uint64_t seq = b.first_sequence() + static_cast<std::uint64_t>(i) * n;
        ASSERT_EQ(seq % n, 0u);
        ASSERT_EQ(sample_at(b, i), sample_at(run.samples, static_cast<int>(seq))) << n << " " << seq;
        ++count;
      }
    }
    EXPECT_EQ(count, (32000 + n - 1) / n) << n;
  }
}

// A client with a tiny TCP window that stops reading: the run and the
// recorder go on at full speed, the client's queue stays within its budget,
// and once it reads again it finds gap notices that, with the samples it got,
// cover the run exactly; the missed ranges fetched back equal the recording.
TEST(ApiStreaming, SlowClientGetsGapNoticesAndFetchesWhatItMissed) {
  TempDir data, cfg;
  v1::DaemonConfig config = default_config();
  config.mutable_server()->set_client_queue_bytes(64 * 1024);
  DaemonProcess daemon(data.path(), write_config(cfg, config));
  v1::Protocol protocol = standard_protocol();
  protocol.set_acquisition_rate_hz(10000);  // 320000 samples, ~20 MB of frames
  const std::uint64_t n = 320000;

  RawClient slow(daemon.port(), 4096);
  slow.request(hello_message());
  slow.request(subscribe());
  client::TriboClient controller({"127.0.0.1", daemon.port()}, controller_session());
  const auto run = client::run_protocol(controller, protocol, std::nullopt);
  ASSERT_EQ(run.stop.exit_status(), v1::SUCCESS);
  EXPECT_EQ(run.stop.sample_count(), n);
  EXPECT_EQ(run.stop.reason(), "") << "nothing dropped before the recorder";

  const StreamLog log = read_until_stop(slow);
  ASSERT_TRUE(log.stop);
  ASSERT_FALSE(log.gaps.empty()) << "a 4 KiB window and a 64 KiB budget cannot hold 20 MB";
  EXPECT_EQ(check_coverage(log, n, 1), "");
  std::uint64_t missed = 0;
  client::TriboClient fetcher({"127.0.0.1", daemon.port()}, observer_session());
  std::string error;
  const auto recorded = wire::read_run_directory(data.path() / run.start.run_id(), error);
  ASSERT_TRUE(recorded) << error;
  ASSERT_EQ(static_cast<std::uint64_t>(sample_count(recorded->samples)), n);
  for (const auto& gap : log.gaps) {
    EXPECT_EQ(gap.run_id(), run.start.run_id());
    const v1::SampleBlock fetched = client::fetch_samples(fetcher, gap.run_id(), gap.first_sequence(), gap.end_sequence());
    ASSERT_EQ(static_cast<std::uint64_t>(sample_count(fetched)), gap.end_sequence() - gap.first_sequence());
    for (int i = 0; i < sample_count(fetched); ++i) {
      ASSERT_EQ(sample_at(fetched, i), sample_at(recorded->samples, static_cast<int>(gap.first_sequence()) + i));
    }
    missed += gap.end_sequence() - gap.first_sequence();
  }
  EXPECT_GT(missed, n / 2);
  // The controller's own stream is complete (it read as fast as it could, or
  // fetched the rest) and equals the recording.
  EXPECT_EQ(run.missing_samples, 0u);
  ASSERT_EQ(sample_count(run.samples), sample_count(recorded->samples));
  for (int i = 0; i < sample_count(run.samples); i += 101) {
    ASSERT_EQ(sample_at(run.samples, i), sample_at(recorded->samples, i));
  }
  EXPECT_GT(fetcher.request(get_status()).status().gap_notices(), 0u);
}

// Connections that never read (one never even says hello) do not hold up the
// run, the recorder, other clients or the shutdown.
TEST(ApiStreaming, ClientsThatNeverReadStallNothing) {
  TempDir data;
  DaemonProcess daemon(data.path());
  RawClient silent(daemon.port());  // connects, says nothing
  RawClient deaf(daemon.port(), 4096);
  deaf.send(hello_message());
  v1::ClientMessage sub = subscribe();
  sub.set_request_id(2);
  deaf.send(sub);  // and never reads a byte
  v1::Protocol protocol = standard_protocol();
  protocol.set_acquisition_rate_hz(10000);
  client::TriboClient controller({"127.0.0.1", daemon.port()}, controller_session());
  for (int i = 0; i < 2; ++i) {
    const auto run = client::run_protocol(controller, protocol, std::nullopt);
    EXPECT_EQ(run.stop.exit_status(), v1::SUCCESS);
    EXPECT_EQ(run.stop.sample_count(), 320000u);
    EXPECT_EQ(run.missing_samples, 0u);
    EXPECT_EQ(wire::count_recorded_samples(data.path() / run.start.run_id()), 320000u);
  }
  const int status = daemon.terminate();  // within the 2 s close deadline
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
}

TEST(ApiStreaming, FiftyConcurrentObserversEachGetTheWholeRun) {
  TempDir data;
  DaemonProcess daemon(data.path());
  constexpr int kObservers = 50;
  std::vector<std::unique_ptr<RawClient>> observers;
  for (int i = 0; i < kObservers; ++i) {
    observers.push_back(std::make_unique<RawClient>(daemon.port()));
    ASSERT_TRUE(observers.back()->request(hello_message()).has_hello()) << i;
    observers.back()->request(subscribe(static_cast<std::uint32_t>(1 + i % 4)));
  }
  std::vector<StreamLog> logs(kObservers);
  std::vector<std::thread> readers;
  for (int i = 0; i < kObservers; ++i) {
    readers.emplace_back([&, i] { logs[static_cast<std::size_t>(i)] = read_until_stop(*observers[static_cast<std::size_t>(i)]); });
  }
  {
    client::TriboClient status({"127.0.0.1", daemon.port()}, observer_session());
    EXPECT_EQ(status.request(get_status()).status().observers(), static_cast<std::uint32_t>(kObservers + 1));
  }
  client::TriboClient controller({"127.0.0.1", daemon.port()}, controller_session());
  const auto run = client::run_protocol(controller, standard_protocol(), std::nullopt);
  for (auto& t : readers) t.join();
  for (int i = 0; i < kObservers; ++i) {
    const auto& log = logs[static_cast<std::size_t>(i)];
    ASSERT_TRUE(log.stop) << i;
    EXPECT_EQ(log.stop->exit_status(), v1::SUCCESS) << i;
    EXPECT_EQ(log.start->run_id(), run.start.run_id()) << i;
    EXPECT_EQ(check_coverage(log, 32000, static_cast<std::uint32_t>(1 + i % 4)), "") << i;
  }
}

TEST(ApiStreaming, LateSubscriberGetsStartDescriptorAndAGapForWhatCameBefore) {
  TempDir data, cfg;
  DaemonProcess daemon(data.path(), write_config(cfg, paced_config()));
  client::TriboClient controller({"127.0.0.1", daemon.port()}, controller_session());
  controller.request(load(short_protocol()));
  const std::string run_id = controller.request(start_run()).start_run().run_id();
  // Wait (on the run's own clock) until samples have gone out.
  RawClient status(daemon.port());
  status.request(hello_message());
  while (status.request(get_status()).status().samples_recorded() == 0) std::this_thread::yield();

  RawClient late(daemon.port());
  late.request(hello_message());
  late.request(subscribe());
  const StreamLog log = read_until_stop(late);
  ASSERT_TRUE(log.start);
  EXPECT_EQ(log.start->run_id(), run_id);
  ASSERT_TRUE(log.descriptor);
  ASSERT_TRUE(log.stop);
  ASSERT_FALSE(log.gaps.empty());
  EXPECT_EQ(log.gaps[0].first_sequence(), 0u);
  EXPECT_EQ(check_coverage(log, log.stop->sample_count(), 1), "");
}

// The controlling client disconnects mid-run; server.on_controller_loss says
// what happens. Paced runs, so that the run is still going when it does.
v1::RunStop run_and_drop_the_controller(v1::ControllerLossPolicy policy, std::uint32_t drop_in_segment,
                                        StreamLog& log, bool& controller_gone_while_running) {
  TempDir data, cfg;
  v1::DaemonConfig config = paced_config();
  config.mutable_server()->set_on_controller_loss(policy);
  DaemonProcess daemon(data.path(), write_config(cfg, config));
  RawClient observer(daemon.port());
  observer.request(hello_message());
  observer.request(subscribe());
  {
    RawClient controller(daemon.port());
    EXPECT_EQ(controller.request(hello_message(v1::CONTROLLER)).hello().role(), v1::CONTROLLER);
    controller.request(load(short_protocol()));
    controller.request(start_run());
    // Wait until the run is in the given segment, then vanish.
    for (;;) {
      auto d = observer.read();
      if (!d) break;
      log.add(*d);
      if (d->has_samples() && d->samples().segment_index(sample_count(d->samples()) - 1) >= drop_in_segment) break;
    }
  }
  // The observer asks while the run goes on (continue) or unloads (abort).
  RawClient asker(daemon.port());
  asker.request(hello_message());
  for (;;) {
    const auto s = asker.request(get_status()).status();
    if (!s.controller_connected()) {
      controller_gone_while_running = s.state() == v1::RUNNING;
      break;
    }
    std::this_thread::yield();
  }
  const StreamLog rest = read_until_stop(observer);
  for (const auto& d : rest.documents) log.add(d);
  return log.stop.value_or(v1::RunStop());
}

TEST(ApiStreaming, ControllerLossWithAbortPolicyUnloadsSafely) {
  StreamLog log;
  bool gone_while_running = false;  // the unload may be over before anyone asks
  const v1::RunStop stop = run_and_drop_the_controller(v1::ABORT_RUN, 2, log, gone_while_running);
  EXPECT_EQ(stop.exit_status(), v1::ABORT);
  EXPECT_EQ(stop.reason(), "the controlling client disconnected");
  ASSERT_FALSE(log.blocks.empty());
  // It was scratching under load, and unloaded to zero.
  double loaded_n = 0;
  for (const auto& b : log.blocks) {
    for (int i = 0; i < sample_count(b); ++i) loaded_n = std::max(loaded_n, b.normal_setpoint_n(i));
  }
  EXPECT_GT(loaded_n, 900e-6);
  const auto& last = log.blocks.back();
  EXPECT_EQ(last.normal_setpoint_n(sample_count(last) - 1), 0.0);
  EXPECT_TRUE(last.status_flags(sample_count(last) - 1) & v1::SAFE_UNLOAD);
  ASSERT_FALSE(log.events.empty());
  EXPECT_EQ(log.events.back().kind(), v1::UNLOAD_BEGIN);
  EXPECT_LT(stop.sample_count(), 3000u) << "stopped before the protocol's end";
}

TEST(ApiStreaming, ControllerLossWithContinuePolicyFinishesTheRun) {
  StreamLog log;
  bool gone_while_running = false;
  const v1::RunStop stop = run_and_drop_the_controller(v1::CONTINUE_RUN, 0, log, gone_while_running);
  EXPECT_TRUE(gone_while_running);
  EXPECT_EQ(stop.exit_status(), v1::SUCCESS) << stop.reason();
  EXPECT_EQ(stop.sample_count(), 3000u);
  EXPECT_EQ(check_coverage(log, 3000, 1), "");
}

}  // namespace
}  // namespace tribo::testing

namespace tribo::testing {
namespace {

TEST(ApiStreaming, ASafetyTripSendsAFaultBeforeTheStop) {
  TempDir data, cfg;
  v1::DaemonConfig config = default_config();
  // The scratch reads ~68 µN (friction ~94 µN less N tan 1.5° = 26 µN for the tilted tip).
  config.mutable_limits()->set_max_lateral_force_n(50e-6);
  config.mutable_autotune()->set_relay_amplitude_n(40e-6);  // a relay within the limit, or tribod refuses the config
  DaemonProcess daemon(data.path(), write_config(cfg, config));
  RawClient observer(daemon.port());
  observer.request(hello_message());
  v1::ClientMessage sub;
  sub.mutable_subscribe();
  observer.request(sub);
  client::TriboClient controller({"127.0.0.1", daemon.port()}, controller_session());
  const auto run = client::run_protocol(controller, standard_protocol(), std::nullopt);
  const StreamLog log = read_until_stop(observer);
  ASSERT_TRUE(log.stop);
  EXPECT_EQ(log.stop->exit_status(), v1::FAULT);
  ASSERT_EQ(log.faults.size(), 1u);
  const v1::Fault& fault = log.faults[0];
  // The reason, then the supervisor's detail (value and limit).
  EXPECT_EQ(fault.reason().rfind("lateral force beyond the limit: ", 0), 0u) << fault.reason();
  EXPECT_TRUE(log.documents[log.documents.size() - 2].has_fault()) << "the fault comes right before the stop";
  ASSERT_FALSE(log.events.empty());
  EXPECT_EQ(log.events.back().kind(), v1::UNLOAD_BEGIN);
  EXPECT_EQ(log.events.back().sequence(), fault.sequence());
  EXPECT_TRUE(run.samples.status_flags(static_cast<int>(fault.sequence())) & v1::SAFE_UNLOAD);
  EXPECT_DOUBLE_EQ(run.samples.time_s(static_cast<int>(fault.sequence())), fault.time_s());
  EXPECT_EQ(check_coverage(log, log.stop->sample_count(), 1), "");

  std::string error;
  const auto metadata = wire::read_run_metadata(data.path() / run.start.run_id(), error);
  ASSERT_TRUE(metadata) << error;
  ASSERT_EQ(metadata->faults_size(), 1);
  EXPECT_EQ(metadata->faults(0).sequence(), fault.sequence());
  v1::ClientMessage status;
  status.mutable_get_status();
  EXPECT_EQ(controller.request(status).status().state(), v1::FAULTED);
}

}  // namespace
}  // namespace tribo::testing
