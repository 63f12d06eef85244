// End to end: the real tribod binary on an ephemeral loopback port, driven
// through the socket by the client library and by the tribo CLI.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <numbers>
#include <fstream>
#include <sstream>

#include "client/tribo_client.h"
#include "proto/run_files.h"
#include "proto/sample_record.h"
#include "proto/text_format_file.h"
#include "tests/sim/sim_test_support.h"
#include "tests/support/daemon_process.h"

namespace tribo {
namespace {

using testing::DaemonProcess;

client::SessionOptions controller_options() {
  client::SessionOptions s;
  s.role = v1::CONTROLLER;
  return s;
}
const client::SessionOptions controller = controller_options();
using testing::TempDir;

const std::string kStandard =
    std::string(TRIBO_SOURCE_DIR) + "/config/protocols/standard_scratch.textproto";

v1::Protocol standard_protocol() {
  v1::Protocol p;
  if (auto e = wire::load_text_proto_file(kStandard, p)) throw std::runtime_error(*e);
  return p;
}

client::RunResult run_standard(const DaemonProcess& daemon, std::optional<std::uint64_t> seed) {
  client::TriboClient client({"127.0.0.1", daemon.port()}, controller);
  return client::run_protocol(client, standard_protocol(), seed);
}

std::string file_contents(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(TribodEndToEnd, StandardScratchGivesTheModelsSteadyFriction) {
  TempDir data;
  DaemonProcess daemon(data.path());
  const client::RunResult run = run_standard(daemon, std::nullopt);

  EXPECT_EQ(run.stop.exit_status(), v1::SUCCESS) << run.stop.reason();
  EXPECT_EQ(run.missing_samples, 0u);
  ASSERT_EQ(sample_count(run.samples), 32000);  // 32 s at 1 kHz
  EXPECT_EQ(run.stop.sample_count(), 32000u);
  EXPECT_EQ(run.stop.cycle_count(), 320000u);  // 32 s at 10 kHz

  // Segment timing: 5, 3, 16, 3, 5 s; each recorded sample averages 10 ticks
  // and is stamped with their mean time (0.45 ms after the sample period starts).
  const double starts[] = {0, 5, 8, 24, 27, 32};
  const auto& b = run.samples;
  for (int i = 0; i < sample_count(b); ++i) {
    const double t = b.time_s(i);
    ASSERT_NEAR(t, i * 1e-3 + 0.45e-3, 1e-9) << i;
    const std::uint32_t seg = b.segment_index(i);
    ASSERT_GE(t, starts[seg]) << i;
    ASSERT_LT(t, starts[seg + 1]) << i;
  }

  // Steady part of the scratch (second half, 16..24 s): mean friction against
  // F_ss = Fc + (Fs - Fc) exp(-v/vs) + s2 v at the measured normal load
  // (dissertation §2, eqs. 9-13), plus the transducer damping c v that the lateral force
  // channel also carries, minus the tip tilt's N tan(theta) (§5.2: it pushes
  // the tip towards +x, the direction of this scratch).
  const v1::DaemonConfig config = testing::default_config();
  const auto& f = config.sim().friction();
  double sum = 0, sum_sq = 0, normal = 0;
  int n = 0;
  for (int i = 0; i < sample_count(b); ++i) {
    if (b.segment_index(i) != 2 || b.time_s(i) < 16.0) continue;
    sum += b.lateral_force_n(i);
    sum_sq += b.lateral_force_n(i) * b.lateral_force_n(i);
    normal += b.normal_force_n(i);
    ++n;
  }
  ASSERT_EQ(n, 8000);
  const double mean = sum / n, load = normal / n, v = 0.5e-6;
  const double sd = std::sqrt(sum_sq / n - mean * mean);
  double expected = f.coulomb_coeff() * load +
                          (f.static_coeff() - f.coulomb_coeff()) * load *
                              std::exp(-v / f.stribeck_velocity_m_per_s()) +
                          f.viscous_n_s_per_m() * v + config.sim().lateral().damping_n_s_per_m() * v;
  const auto& tilt = config.sim().tip().tilt_offset();
  const double tilt_n = tilt.enabled() ? load * std::tan(tilt.angle_deg() * std::numbers::pi / 180) : 0.0;
  // Within the noise: five standard errors of the mean (0.18 µN here), or the
  // 0.5 % of the friction that residual sensor-noise dither of the contact
  // may cost (measured -0.1 ... -0.2 % with this config), whichever is larger.
  const double tolerance = std::max(5 * sd / std::sqrt(n), 5e-3 * expected);
  expected -= tilt_n;
  EXPECT_NEAR(mean, expected, tolerance) << "sd " << sd << " load " << load;
  EXPECT_NEAR(load, 1000e-6, 5e-6) << "open loop: springs absorb ~0.3 %";
}

TEST(TribodEndToEnd, SameSeedGivesIdenticalSampleFilesAndAnotherSeedDoesNot) {
  TempDir data;
  DaemonProcess daemon(data.path());
  const auto a = run_standard(daemon, 7);
  const auto b = run_standard(daemon, 7);
  const auto c = run_standard(daemon, 8);
  const auto file = [&](const client::RunResult& r) {
    return file_contents(data.path() / r.start.run_id() / wire::kSamplesFile);
  };
  ASSERT_NE(a.start.run_id(), b.start.run_id());
  const std::string fa = file(a), fb = file(b), fc = file(c);
  ASSERT_GT(fa.size(), 1000000u);
  EXPECT_TRUE(fa == fb) << "same seed, different samples";
  EXPECT_FALSE(fa == fc) << "different seed, same noise";
  // The streamed samples are the recorded ones.
  std::string error;
  const auto recorded = wire::read_run_directory(data.path() / a.start.run_id(), error);
  ASSERT_TRUE(recorded) << error;
  ASSERT_EQ(sample_count(recorded->samples), sample_count(a.samples));
  for (int i = 0; i < sample_count(a.samples); i += 997) {
    EXPECT_EQ(sample_at(recorded->samples, i), sample_at(a.samples, i));
  }
  EXPECT_EQ(recorded->metadata.start().seed(), 7u);
  EXPECT_EQ(recorded->metadata.stop().exit_status(), v1::SUCCESS);
}

TEST(TribodEndToEnd, OutOfLimitProtocolIsRejectedBeforeAnythingMoves) {
  TempDir data;
  DaemonProcess daemon(data.path());
  client::TriboClient client({"127.0.0.1", daemon.port()}, controller);
  v1::Protocol p = standard_protocol();
  p.mutable_segments(1)->mutable_normal()->set_end_un(20000);  // 20 mN
  p.mutable_segments(2)->mutable_normal()->set_end_un(20000);
  v1::ClientMessage load;
  *load.mutable_load_protocol()->mutable_protocol() = p;
  try {
    client.request(load);
    FAIL() << "a 20 mN protocol was accepted";
  } catch (const client::ClientError& e) {
    EXPECT_EQ(e.error().code(), v1::INVALID_ARGUMENT);
    EXPECT_EQ(e.error().field(), "segments[1].normal.end_uN");
    EXPECT_NE(e.error().message().find("20000"), std::string::npos) << e.what();
  }
  v1::ClientMessage status;
  status.mutable_get_status();
  EXPECT_EQ(client.request(status).status().state(), v1::IDLE);
  EXPECT_TRUE(std::filesystem::is_empty(data.path())) << "no run was started";
}

TEST(TribodEndToEnd, CliRunsTheProtocolAndPrintsAndSavesTheSummary) {
  TempDir data, out;
  DaemonProcess daemon(data.path());
  const std::string address = "127.0.0.1:" + std::to_string(daemon.port());
  const auto text = testing::run_command(
      {DaemonProcess::tribo_cli_path(), "run", kStandard, "--address", address, "--out",
       (out.path() / "run").string()});
  EXPECT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("mean friction"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("mu = F/N"), std::string::npos) << text.out;
  std::string error;
  const auto saved = wire::read_run_directory(out.path() / "run", error);
  ASSERT_TRUE(saved) << error;
  EXPECT_EQ(sample_count(saved->samples), 32000);

  const auto json = testing::run_command(
      {DaemonProcess::tribo_cli_path(), "run", kStandard, "--address", address, "--json"});
  EXPECT_EQ(json.exit_code, 0) << json.err;
  for (const char* field : {"\"mean_friction_uN\"", "\"mu\"", "\"stiction_peak_uN\"",
                            "\"steady_lag_um\"", "\"exit_status\": \"SUCCESS\""}) {
    EXPECT_NE(json.out.find(field), std::string::npos) << field << " missing in\n" << json.out;
  }
}

TEST(TribodEndToEnd, CliNamesTheFieldOfAMalformedProtocolFile) {
  TempDir dir;
  const auto path = dir.path() / "bad.textproto";
  std::ofstream(path) << "name: \"bad\"\nsegments {\n  duration_s: 5\n  lateral { end_umm: 2 }\n}\n";
  const auto result = testing::run_command(
      {DaemonProcess::tribo_cli_path(), "run", path.string(), "--address", "127.0.0.1:1"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("end_umm"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("bad.textproto:4:"), std::string::npos) << result.err;
}

TEST(TribodEndToEnd, CliReportsAnUnreachableDaemon) {
  TempDir dir;
  // Port 1 on loopback: nothing listens there.
  const auto result = testing::run_command(
      {DaemonProcess::tribo_cli_path(), "run", kStandard, "--address", "127.0.0.1:1"});
  EXPECT_EQ(result.exit_code, 3);
  EXPECT_NE(result.err.find("cannot connect"), std::string::npos) << result.err;
}

}  // namespace
}  // namespace tribo

namespace tribo {
namespace {

TEST(TribodEndToEnd, SigtermMidRunUnloadsSafelyAndFinalizesTheRecording) {
  TempDir data;
  DaemonProcess daemon(data.path());
  client::TriboClient client({"127.0.0.1", daemon.port()}, controller);
  v1::Protocol p = standard_protocol();
  // A 50 min loaded dwell at +2 µm: still running when the signal comes.
  p.mutable_segments(2)->set_duration_s(3000);
  p.mutable_segments(2)->mutable_lateral()->set_end_um(2);
  p.mutable_segments(3)->mutable_lateral()->set_end_um(2);
  p.mutable_segments(4)->set_duration_s(1);
  v1::ClientMessage load, subscribe, start;
  *load.mutable_load_protocol()->mutable_protocol() = p;
  client.request(load);
  subscribe.mutable_subscribe();
  client.request(subscribe);
  start.mutable_start_run();
  const std::string run_id = client.request(start).start_run().run_id();
  // Wait until the scratch is under way (simulated time 10 s), then terminate.
  for (;;) {
    const v1::ServerMessage event = client.next_event();
    ASSERT_FALSE(event.has_run_stop()) << "the run ended before the signal";
    if (event.has_samples() && event.samples().time_s(event.samples().time_s_size() - 1) > 10) break;
  }
  const int status = daemon.terminate();
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;

  std::string error;
  const auto run = wire::read_run_directory(data.path() / run_id, error);
  ASSERT_TRUE(run) << error;
  EXPECT_EQ(run->metadata.stop().exit_status(), v1::ABORT);
  EXPECT_EQ(run->metadata.stop().reason(), "daemon received a termination signal");
  EXPECT_EQ(run->metadata.stop().sample_count(),
            static_cast<std::uint64_t>(sample_count(run->samples)));
  const auto& b = run->samples;
  ASSERT_GT(sample_count(b), 10000);
  EXPECT_EQ(b.normal_setpoint_n(sample_count(b) - 1), 0.0) << "unloaded before exiting";
  EXPECT_TRUE(b.status_flags(sample_count(b) - 1) & v1::SAFE_UNLOAD);
  // The finalized metadata keeps the descriptor and where the unload began.
  EXPECT_EQ(run->metadata.run_descriptor().channels_size(), 9);
  ASSERT_GT(run->metadata.segment_events_size(), 0);
  const auto& unload = run->metadata.segment_events(run->metadata.segment_events_size() - 1);
  EXPECT_EQ(unload.kind(), v1::UNLOAD_BEGIN);
  EXPECT_TRUE(b.status_flags(static_cast<int>(unload.sequence())) & v1::SAFE_UNLOAD);
  EXPECT_FALSE(b.status_flags(static_cast<int>(unload.sequence()) - 1) & v1::SAFE_UNLOAD);
}

}  // namespace
}  // namespace tribo
