// The friction compensation in the loop (docs/friction_compensation.md): the
// protocol's field and its validation, the controller's bumpless switching,
// the supervisor's watch on the compensation, the start document's record of
// the model, and what it does on the simulated instrument: on the default
// (config/tribod.textproto, the slip-rate law) with the model identified on it
// (tests/data/friction_reports/default_identification.json), and on the fitted
// contact (config/instruments/fitted_contact.textproto), on which the other
// reports in tests/data/friction_reports were identified and the rest of the
// figures of docs/friction_compensation.md measured.
#include <gtest/gtest.h>

#include <cmath>
#include <utility>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/controller.h"
#include "daemon/protocol_validator.h"
#include "daemon/safety_supervisor.h"
#include "hal/backend_factory.h"
#include "proto/text_format_file.h"
#include "tests/daemon/protocol_check_support.h"
#include "tests/daemon/service_test_support.h"
#include "tests/support/compensation_runs.h"

namespace tribo::daemon {
namespace {

using tribo::testing::breakaway_figures;
using tribo::testing::run_in_process;
using tribo::testing::segments_named;
using tribo::testing::shipped_protocol;
using tribo::testing::with_friction_model;

std::string identification_report() {
  auto text = wire::read_file(std::string(TRIBO_SOURCE_DIR) + "/tests/data/friction_reports/identification.json");
  if (!text) throw std::runtime_error("fixture missing");
  return *text;
}

using tribo::testing::all;
using tribo::testing::find;

TEST(FrictionCompensationProtocol, CompilesTheProtocolsModelIntoItsDisplacementSegments) {
  const v1::Protocol p = with_friction_model(shipped_protocol("breakaway.textproto"), identification_report());
  const ProtocolCheck c = validate_protocol(p, tribo::testing::fitted_contact_config());
  ASSERT_TRUE(c.ok()) << all(c);
  ASSERT_EQ(c.load_function.friction_models().size(), 1u);
  for (const SegmentPlan& plan : c.load_function.segments()) {
    // The force ramp regulates the force: nothing to compensate there.
    EXPECT_EQ(plan.friction_model, plan.lateral_mode == LateralMode::kForce ? -1 : 0) << plan.name;
  }
}

TEST(FrictionCompensationProtocol, ASegmentSwitchesItOffOrNamesItsOwn) {
  v1::Protocol p = with_friction_model(shipped_protocol("standard_scratch.textproto"), identification_report());
  p.mutable_segments(0)->mutable_friction_compensation()->set_off(true);
  v1::FrictionCompensation& own = *p.mutable_segments(2)->mutable_friction_compensation();
  own.set_report_file("other.json");
  own.set_report_json(tribo::testing::scaled_report(identification_report(), 0.7, 1));
  const ProtocolCheck c = validate_protocol(p, tribo::testing::fitted_contact_config());
  ASSERT_TRUE(c.ok()) << all(c);
  ASSERT_EQ(c.load_function.friction_models().size(), 2u);
  EXPECT_EQ(c.load_function.segments()[0].friction_model, -1);
  EXPECT_EQ(c.load_function.segments()[1].friction_model, 0);
  EXPECT_EQ(c.load_function.segments()[2].friction_model, 1);
  EXPECT_EQ(c.load_function.friction_models()[1].report_file, "other.json");
}

TEST(FrictionCompensationProtocol, RefusalsNameTheFieldAndTheReason) {
  const v1::DaemonConfig config = tribo::testing::fitted_contact_config();
  // A model the compensation cannot evaluate.
  std::string text = identification_report();
  text.replace(text.find("\"tilt_offset\"", text.find("\"final_model\"")), 13, "\"backlash\"");
  ProtocolCheck c = validate_protocol(with_friction_model(shipped_protocol("standard_scratch.textproto"), text, "id.json"),
                                      config);
  const ValidationIssue* e = find(c, "friction_compensation.report_json");
  ASSERT_NE(e, nullptr) << all(c);
  EXPECT_NE(e->message.find("id.json: final_model.effects has backlash"), std::string::npos) << e->message;

  // A force segment asked to compensate.
  v1::Protocol p = shipped_protocol("breakaway.textproto");
  p.mutable_segments(3)->mutable_friction_compensation()->set_report_json(identification_report());
  c = validate_protocol(p, config);
  e = find(c, "segments[3].friction_compensation");
  ASSERT_NE(e, nullptr) << all(c);
  EXPECT_NE(e->message.find("LATERAL_DISPLACEMENT segments only"), std::string::npos);

  // off and a report at once; a file the client did not read.
  p = shipped_protocol("standard_scratch.textproto");
  p.mutable_segments(2)->mutable_friction_compensation()->set_off(true);
  p.mutable_segments(2)->mutable_friction_compensation()->set_report_json(identification_report());
  EXPECT_NE(find(validate_protocol(p, config), "segments[2].friction_compensation.off"), nullptr);
  p = shipped_protocol("standard_scratch.textproto");
  p.mutable_friction_compensation()->set_report_file("model.json");
  c = validate_protocol(p, config);
  e = find(c, "friction_compensation.report_json");
  ASSERT_NE(e, nullptr) << all(c);
  EXPECT_NE(e->message.find("report_file model.json was not read"), std::string::npos);
}

TEST(FrictionCompensationProtocol, RefusesAModelThatWouldAskMoreOfTheDriveThanTheSupervisorAllows) {
  v1::DaemonConfig config = tribo::testing::fitted_contact_config();
  // The standard scratch at 1000 µN: mu_s N + |tilt| N + (Fv + sigma1) v is about 124 µN.
  config.mutable_supervisor()->set_max_friction_compensation_n(100e-6);
  const ProtocolCheck c =
      validate_protocol(with_friction_model(shipped_protocol("standard_scratch.textproto"), identification_report(),
                                            "id.json"),
                        config);
  const ValidationIssue* e = find(c, "friction_compensation");
  ASSERT_NE(e, nullptr) << all(c);
  EXPECT_NE(e->message.find("beyond supervisor.max_friction_compensation_n = 100 µN"), std::string::npos) << e->message;
  config.mutable_supervisor()->set_max_friction_compensation_n(200e-6);
  EXPECT_TRUE(validate_protocol(with_friction_model(shipped_protocol("standard_scratch.textproto"),
                                                    identification_report()),
                                config)
                  .ok());
}

// A contact that heals at rest (rate-and-state, the ageing law) asks more
// of the drive the longer the run: the validator bounds its state by the
// time from the run's start to each segment's end (identified_friction_bound).
TEST(FrictionCompensationProtocol, BoundsARateAndStateModelByTheRunsDuration) {
  v1::DaemonConfig config = tribo::testing::fitted_contact_config();
  config.mutable_supervisor()->set_max_friction_compensation_n(250e-6);
  nlohmann::json j = nlohmann::json::parse(identification_report());
  j["final_model"]["effects"].push_back("rate_state");
  j["final_model"]["rate_state_law"] = "ageing (Dieterich)";
  for (const auto& [name, value] : {std::pair{"rs_a", 0.002}, {"rs_b", 0.02}, {"rs_dc", 2e-7}}) {
    j["final_model"]["parameters"].push_back({{"name", name}, {"value", value}, {"unit", "1"}});
  }
  j["final_model"]["reference_speed_m_per_s"] = 2e-6;
  j["final_model"]["reference_load"] = 2e-3;
  // At 1000 µN the healed state adds b N ln(v_ref t / D_c) = 20 µN ln(10 t/s)
  // to the 124 µN of the model without it (the test above): about 110 µN by
  // the scratch's end at 24 s, 175 µN when the load is held 10 minutes first.
  v1::Protocol p = with_friction_model(shipped_protocol("standard_scratch.textproto"), j.dump(), "rs.json");
  ProtocolCheck c = validate_protocol(p, config);
  EXPECT_TRUE(c.ok()) << all(c);
  p.mutable_segments(1)->set_duration_s(600);
  c = validate_protocol(p, config);
  const ValidationIssue* e = find(c, "friction_compensation");
  ASSERT_NE(e, nullptr) << all(c);
  EXPECT_NE(e->message.find("friction compensation (rs.json) may reach"), std::string::npos) << e->message;
  EXPECT_NE(e->message.find("s of the run's start, beyond supervisor.max_friction_compensation_n = 250 µN"),
            std::string::npos)
      << e->message;
}

IdentifiedFriction fixture_model() {
  return std::get<FrictionReport>(read_friction_report(identification_report())).model;
}

// The controller alone on a fixed reading: switching the compensation on or
// off does not step the drive, although the compensation's share does.
TEST(FrictionCompensationController, SwitchingOnAndOffIsBumpless) {
  const IdentifiedFriction model = fixture_model();
  Controller controller(controller_params_from_config(tribo::testing::fitted_contact_config()));
  hal::SensorFrame frame;
  frame.lateral_position_m = 2e-6;
  frame.normal_force_n = 5e-3;
  TickSetpoints sp;
  sp.normal = 5e-3;
  sp.lateral = 2e-6;
  double last = 0;
  for (int k = 0; k < 100; ++k) last = controller.step(sp, frame).drive.lateral_force_n;
  sp.friction_model = &model;
  const ControlOutput on = controller.step(sp, frame);
  EXPECT_TRUE(on.flags & v1::FRICTION_COMPENSATED);
  EXPECT_NEAR(on.friction_compensation_n, model.tilt_tan * 5e-3, 1e-9) << "at rest: the tilt's push";
  EXPECT_GT(std::fabs(on.friction_compensation_n), 1e-4);
  EXPECT_NEAR(on.drive.lateral_force_n, last, 1e-9);
  for (int k = 0; k < 100; ++k) last = controller.step(sp, frame).drive.lateral_force_n;
  sp.friction_model = nullptr;
  const ControlOutput off = controller.step(sp, frame);
  EXPECT_FALSE(off.flags & v1::FRICTION_COMPENSATED);
  EXPECT_EQ(off.friction_compensation_n, 0.0);
  EXPECT_NEAR(off.drive.lateral_force_n, last, 1e-9);
}

// A moving command, its rate different at every tick, on a fixed reading.
TickSetpoints moving_setpoints(int tick, const IdentifiedFriction* model) {
  TickSetpoints sp;
  sp.normal = 5e-3;
  sp.lateral = 2e-6;
  sp.lateral_rate = 1e-6 * std::sin(0.05 * tick) + 2e-8 * tick;
  sp.friction_model = model;
  return sp;
}

hal::SensorFrame fixed_frame() {
  hal::SensorFrame frame;
  frame.lateral_position_m = 2.1e-6;
  frame.normal_force_n = 5e-3;
  return frame;
}

// The observer driven by the commanded velocities `rates` along the
// controller's inputs, as the controller computes it: its compensation per tick.
std::vector<double> observer_along(const IdentifiedFriction& model, const ObserverSettings& settings,
                                   const std::vector<double>& rates, double period_s) {
  ObserverState state = observer_at_rest(model);
  std::vector<double> forces;
  for (std::size_t k = 0; k < rates.size(); ++k) {
    const TickSetpoints sp = moving_setpoints(static_cast<int>(k), &model);
    ObserverInput in;
    in.position_m = fixed_frame().lateral_position_m;
    in.position_error_m = fixed_frame().lateral_position_m - sp.lateral;
    in.normal_force_n = fixed_frame().normal_force_n;
    in.commanded_velocity_m_per_s = rates[k];
    in.period_s = period_s;
    forces.push_back(observer_step(model, settings, in, state).force_n);
  }
  return forces;
}

// velocity_delay_s: the observer's driving velocity is the commanded velocity
// of N ticks ago (0 before the compensation had run N ticks: a command at
// rest), and nothing else of its input changes.
TEST(FrictionCompensationController, TheObserverIsDrivenByTheCommandedVelocityOfNTicksAgo) {
  const IdentifiedFriction model = fixture_model();
  v1::DaemonConfig config = tribo::testing::fitted_contact_config();
  constexpr int kDelay = 25;  // 2.5 ms at 10 kHz
  config.mutable_controller()->mutable_friction_compensation()->set_velocity_delay_s(
      kDelay / config.controller().loop_rate_hz());
  const ControllerParams params = controller_params_from_config(config);
  ASSERT_EQ(params.friction_velocity_delay_ticks, static_cast<std::size_t>(kDelay));
  Controller controller(params);
  std::vector<double> commanded, delayed, compensation;
  for (int k = 0; k < 200; ++k) {
    const TickSetpoints sp = moving_setpoints(k, &model);
    compensation.push_back(controller.step(sp, fixed_frame()).friction_compensation_n);
    commanded.push_back(sp.lateral_rate);
    delayed.push_back(k >= kDelay ? commanded[k - kDelay] : 0.0);
    ASSERT_EQ(controller.friction_observer().driving_velocity_m_per_s, delayed.back()) << "tick " << k;
  }
  EXPECT_EQ(compensation, observer_along(model, params.friction_observer, delayed, params.period_s));
  // Switched off and on again: the observer starts at rest, the delay with it.
  TickSetpoints off = moving_setpoints(200, nullptr);
  controller.step(off, fixed_frame());
  for (int k = 201; k < 201 + kDelay; ++k) {
    controller.step(moving_setpoints(k, &model), fixed_frame());
    ASSERT_EQ(controller.friction_observer().driving_velocity_m_per_s, 0.0) << "tick " << k;
  }
  controller.step(moving_setpoints(201 + kDelay, &model), fixed_frame());
  EXPECT_EQ(controller.friction_observer().driving_velocity_m_per_s, moving_setpoints(201, &model).lateral_rate);
}

// velocity_lag_s: after a step of the commanded velocity the observer's
// driving velocity rises as 1 - exp(-t / tau), and the delay comes before it.
TEST(FrictionCompensationController, TheObserverIsDrivenByTheCommandedVelocityThroughAFirstOrderLag) {
  const IdentifiedFriction model = fixture_model();
  v1::DaemonConfig config = tribo::testing::fitted_contact_config();
  auto& fc = *config.mutable_controller()->mutable_friction_compensation();
  constexpr double kTau = 0.0753;
  constexpr int kDelay = 100;  // 10 ms at 10 kHz
  fc.set_velocity_lag_s(kTau);
  fc.set_velocity_delay_s(kDelay / config.controller().loop_rate_hz());
  const ControllerParams params = controller_params_from_config(config);
  const double h = params.period_s;
  Controller controller(params);
  std::vector<double> driving;
  TickSetpoints sp = moving_setpoints(0, &model);
  sp.lateral_rate = 0;
  for (int k = 0; k < 10; ++k) controller.step(sp, fixed_frame());
  sp.lateral_rate = 4e-6;  // a ramp starts
  for (int k = 0; k < 5000; ++k) {
    controller.step(sp, fixed_frame());
    driving.push_back(controller.friction_observer().driving_velocity_m_per_s);
  }
  for (int k = 0; k < kDelay; ++k) ASSERT_EQ(driving[k], 0.0) << "tick " << k << " of the delay";
  for (const double t : {0.5 * kTau, kTau, 2 * kTau, 4 * kTau}) {
    const int k = kDelay + static_cast<int>(std::lround(t / h)) - 1;
    EXPECT_NEAR(driving[k], 4e-6 * (1 - std::exp(-t / kTau)), 4e-6 * 0.01) << t << " s after the delay";
  }
  EXPECT_GT(driving[kDelay], 0.0);
  EXPECT_LT(driving[kDelay + 10], 4e-6 * 11 * h / kTau) << "11 ticks after the delay";
}

// velocity_delay_s and velocity_lag_s 0 (the default): the present commanded velocity drives the
// observer, bit for bit the compensation of the observer on the command.
TEST(FrictionCompensationController, NoDelayDrivesTheObserverWithThePresentCommandedVelocity) {
  const IdentifiedFriction model = fixture_model();
  const ControllerParams params = controller_params_from_config(tribo::testing::fitted_contact_config());
  ASSERT_EQ(params.friction_velocity_delay_ticks, 0u);
  Controller controller(params);
  std::vector<double> commanded, compensation;
  for (int k = 0; k < 200; ++k) {
    const TickSetpoints sp = moving_setpoints(k, &model);
    compensation.push_back(controller.step(sp, fixed_frame()).friction_compensation_n);
    commanded.push_back(sp.lateral_rate);
    ASSERT_EQ(controller.friction_observer().driving_velocity_m_per_s, sp.lateral_rate) << "tick " << k;
  }
  EXPECT_EQ(compensation, observer_along(model, params.friction_observer, commanded, params.period_s));
}

TEST(FrictionCompensationSupervisor, NonFiniteOrExcessiveCompensationTrips) {
  SafetySupervisor s(supervisor_params_from_config(tribo::testing::fitted_contact_config()));
  EXPECT_TRUE(s.compensation_allowed(1.5e-3, 1));
  EXPECT_FALSE(s.compensation_allowed(2.5e-3, 2)) << "beyond limits.max_lateral_force_n, the default limit";
  EXPECT_EQ(s.trip().reason, TripReason::kFrictionCompensation);
  EXPECT_EQ(s.trip().tick, 2u);
  SafetySupervisor t(supervisor_params_from_config(tribo::testing::fitted_contact_config()));
  EXPECT_FALSE(t.compensation_allowed(std::nan(""), 3));
  EXPECT_EQ(t.trip().reason, TripReason::kFrictionCompensation);
}

// Defence in depth: a model the validator never saw (here a sigma0 of NaN)
// yields a compensation that is not finite; the run trips before the
// command reaches the backend and unloads safely.
TEST(FrictionCompensationSupervisor, ANonFiniteCompensationNeverReachesTheBackend) {
  const v1::DaemonConfig config = tribo::testing::fitted_contact_config();
  const ProtocolCheck check = validate_protocol(shipped_protocol("standard_scratch.textproto"), config);
  ASSERT_TRUE(check.ok());
  std::vector<SegmentPlan> plans = check.load_function.segments();
  for (SegmentPlan& plan : plans) plan.friction_model = plan.name == "scratch" ? 0 : -1;
  FrictionReport broken;
  broken.model = fixture_model();
  broken.model.sigma0_n_per_m = std::nan("");
  const LoadFunction load_function(plans, check.load_function.loop_rate_hz(), {broken});
  auto transducer = hal::make_transducer(config, 1);
  SpscQueue<Sample> queue(1 << 16);
  RunControl control;
  RunTelemetry telemetry;
  RunLoop loop(*transducer, load_function, run_loop_config_from(config), queue, control, telemetry);
  Sample sample;
  while (loop.tick()) {
    ASSERT_TRUE(std::isfinite(loop.controller().last_drive().lateral_force_n) ||
                loop.supervisor().tripped());
    while (queue.try_pop(sample)) {
    }
  }
  ASSERT_EQ(loop.outcome().end, RunEnd::kTripped);
  EXPECT_EQ(loop.outcome().trip.reason, TripReason::kFrictionCompensation);
  EXPECT_NEAR(loop.outcome().trip_time_s, 8.0, 1e-3) << "at the scratch's first tick";
}

// The rest run on the default simulated instrument, through the daemon's loop.

TEST(FrictionCompensationRun, TheStartDocumentRecordsTheReportsHashAndParameters) {
  const auto run = run_in_process(tribo::testing::fitted_contact_config(),
                                  with_friction_model(shipped_protocol("standard_scratch.textproto"),
                                                      identification_report(), "identification.json"),
                                  1);
  ASSERT_EQ(run.start.friction_models_size(), 1);
  const v1::FrictionModelUse& use = run.start.friction_models(0);
  EXPECT_EQ(use.report_file(), "identification.json");
  EXPECT_EQ(use.report_sha256(), "8e97474e04076d74d1d9601fbd005e21276ec9f28ec6427ff41f64d99bba46bf");
  EXPECT_EQ(use.contact(), "lugre + tilt_offset");
  ASSERT_EQ(use.parameters_size(), 8);
  EXPECT_EQ(use.parameters(0).name(), "mu_c");
  EXPECT_EQ(use.parameters(0).value(), fixture_model().coulomb);
  EXPECT_EQ(use.segments_size(), 5) << "every segment of the standard scratch is a displacement segment";
  // Every sample says the drive carried the compensation.
  for (const Sample& s : run.samples) ASSERT_TRUE(s.status_flags & v1::FRICTION_COMPENSATED) << s.time_s;
}

// The break-away protocol without and with a friction model, seed 1, both
// run to the end, and its three slides.
struct WithoutAndWith {
  tribo::testing::InProcessRun before, after;
  std::vector<std::uint32_t> slides;
};

WithoutAndWith breakaway_without_and_with(const v1::DaemonConfig& config, const std::string& report) {
  const v1::Protocol protocol = shipped_protocol("breakaway_velocities.textproto");
  WithoutAndWith r{run_in_process(config, protocol, 1), run_in_process(config, with_friction_model(protocol, report), 1), {}};
  EXPECT_EQ(r.before.outcome.end, RunEnd::kCompleted);
  EXPECT_EQ(r.after.outcome.end, RunEnd::kCompleted);
  r.slides = segments_named(r.before, "slide");
  EXPECT_EQ(r.slides.size(), 3u);
  return r;
}

// §5.3.1: the tip overshoots the commanded velocity after break-away. Fed
// forward, the identified friction lowers it at every speed, and the
// reversals follow the setpoint more closely.
TEST(FrictionCompensationRun, LowersTheOvershootAfterBreakAwayAndTheErrorAtReversals) {
  const auto [before, after, slides] = breakaway_without_and_with(tribo::testing::fitted_contact_config(), identification_report());
  ASSERT_FALSE(HasFailure());
  for (std::uint32_t segment : slides) {
    const auto b = breakaway_figures(before, segment);
    const auto a = breakaway_figures(after, segment);
    EXPECT_GT(b.overshoot, 1.8) << b.commanded_m_per_s;
    EXPECT_LT(a.overshoot, 0.8 * b.overshoot) << b.commanded_m_per_s;
    EXPECT_LT(a.time_to_speed_s, b.time_to_speed_s) << b.commanded_m_per_s;
    // The 10 ms filter of the record reads the tip's true motion.
    EXPECT_NEAR(a.overshoot, a.true_overshoot, 0.1 * a.true_overshoot);
    // The stiction peak read is the contact's, with and without (the
    // contact's own peak differs: it breaks away sooner).
    EXPECT_NEAR(b.stiction_peak_n, b.true_stiction_peak_n, 5e-6);
    EXPECT_NEAR(a.stiction_peak_n, a.true_stiction_peak_n, 5e-6);
  }
  const auto tb = tribo::testing::tracking_figures(before, "stroke");
  const auto ta = tribo::testing::tracking_figures(after, "stroke");
  EXPECT_LT(ta.reversal_rms_m, 0.6 * tb.reversal_rms_m);
  EXPECT_NEAR(ta.steady_rms_m, tb.steady_rms_m, 0.01e-6) << "the I-PD loop's ramp lag stays";
}

// The same on the default instrument (config/tribod.textproto: the slip-rate
// law) with the model tribo-fit identifies from its identification run
// (tests/data/friction_reports/default_identification.json: LuGre with
// rate-and-state, presliding and a direction asymmetry). Seed 1 without and
// with: overshoot 3.21 / 1.94 / 1.52 and 2.17 / 1.36 / 1.13 at 4 / 18 /
// 36 µm/s, reversal RMS 0.829 and 0.366 µm (docs/friction_compensation.md).
TEST(FrictionCompensationRun, OnTheDefaultInstrumentLowersTheOvershootAndTheErrorAtReversals) {
  auto report =
      wire::read_file(std::string(TRIBO_SOURCE_DIR) + "/tests/data/friction_reports/default_identification.json");
  ASSERT_TRUE(report);
  const auto [before, after, slides] = breakaway_without_and_with(tribo::testing::default_config(), *report);
  ASSERT_FALSE(HasFailure());
  for (std::uint32_t segment : slides) {
    const auto b = breakaway_figures(before, segment);
    const auto a = breakaway_figures(after, segment);
    EXPECT_GT(b.overshoot, 1.4) << b.commanded_m_per_s;
    EXPECT_LT(a.overshoot, 0.8 * b.overshoot) << b.commanded_m_per_s;
    EXPECT_LT(a.true_overshoot, 0.8 * b.true_overshoot) << b.commanded_m_per_s;
  }
  const auto tb = tribo::testing::tracking_figures(before, "stroke");
  const auto ta = tribo::testing::tracking_figures(after, "stroke");
  EXPECT_LT(ta.reversal_rms_m, 0.6 * tb.reversal_rms_m);
  EXPECT_NEAR(ta.steady_rms_m, tb.steady_rms_m, 0.01e-6) << "the I-PD loop's ramp lag stays";
}

// A rate-and-state model peaks at break-away, but only where the contact's
// peak is: its state must last while the lagging tip has not yet slid. With
// the observer's velocity lagged by the loop's ramp lag and its contact state
// following the measured speed, tribo-fit's rate-and-state model of a
// break-away record (tests/data/friction_reports/breakaway.json) keeps the
// tip within 1.3x of the commanded velocity at 4, 18 and 36 µm/s; with the
// commanded speed driving the state (the rest the same) it does not at 4 µm/s.
TEST(FrictionCompensationRun, ARateAndStateModelWhoseStateFollowsTheTipMeetsTheOvershootGoal) {
  v1::DaemonConfig config = tribo::testing::fitted_contact_config();
  config.mutable_supervisor()->set_max_friction_compensation_n(0.004);  // the model's bound: 2.75 mN
  auto& fc = *config.mutable_controller()->mutable_friction_compensation();
  fc.set_velocity_lag_s(0.0753);
  fc.set_velocity_filter_hz(50);
  auto report = wire::read_file(std::string(TRIBO_SOURCE_DIR) + "/tests/data/friction_reports/breakaway.json");
  ASSERT_TRUE(report);
  const v1::Protocol protocol = with_friction_model(shipped_protocol("breakaway_velocities.textproto"), *report);
  const auto commanded_state = run_in_process(config, protocol, 1);
  fc.set_contact_state_from_measured_velocity(true);
  const auto measured_state = run_in_process(config, protocol, 1);
  ASSERT_EQ(commanded_state.outcome.end, RunEnd::kCompleted);
  ASSERT_EQ(measured_state.outcome.end, RunEnd::kCompleted);
  const auto slides = segments_named(measured_state, "slide");
  ASSERT_EQ(slides.size(), 3u);
  for (std::uint32_t segment : slides) {
    const auto a = breakaway_figures(measured_state, segment);
    EXPECT_LT(a.overshoot, 1.3) << a.commanded_m_per_s;
    EXPECT_LT(a.true_overshoot, 1.3) << a.commanded_m_per_s;
  }
  EXPECT_GT(breakaway_figures(commanded_state, slides[0]).overshoot, 1.5);
}

// The transducer reads the drive less the spring: with the compensation in
// the drive, the friction the summary reports is still the contact's.
TEST(FrictionCompensationRun, TheReportedFrictionIsTheContactsWithinItsNoise) {
  const v1::DaemonConfig config = tribo::testing::fitted_contact_config();
  const v1::Protocol protocol = shipped_protocol("standard_scratch.textproto");
  for (std::uint64_t seed : {1, 2}) {
    const auto without = run_in_process(config, protocol, seed);
    const auto with = run_in_process(config, with_friction_model(protocol, identification_report()), seed);
    // The summary's steady window: the second half of the scratch (t = 16..24 s).
    const double a = testing::mean_between(without.samples, 16, 24, &Sample::lateral_force_n);
    const double b = testing::mean_between(with.samples, 16, 24, &Sample::lateral_force_n);
    // Standard error of that mean: 3.2 µN of scatter over 8000 samples, 0.036 µN.
    EXPECT_NEAR(b, a, 0.036e-6) << seed;
    // And it is the contact's: the transducer reads the contact's true
    // friction less the tilt's push, over the same ticks, as closely with
    // the compensation as without (the instrument's own offset between the
    // two, +0.017 and -0.213 µN on seeds 1 and 2, is the same).
    double share = 0, contact_with = 0, contact_without = 0;
    for (std::size_t k = 160000; k < 240000; ++k) {
      share += with.compensation_n[k];
      contact_with += with.true_friction_n[k] - with.true_tilt_n[k];
      contact_without += without.true_friction_n[k] - without.true_tilt_n[k];
    }
    EXPECT_NEAR(b - contact_with / 80000, a - contact_without / 80000, 0.036e-6) << seed;
    // The compensation did carry the friction: the loop's own share is small.
    EXPECT_NEAR(share / 80000, a, 0.05 * a) << seed;
  }
}

}  // namespace
}  // namespace tribo::daemon
