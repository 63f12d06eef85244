// Numerical accuracy of the simulated instrument. A closed-loop run
// (noise-free sensors, so that two runs differ only by their integration) is
// repeated at a sub-step 100x finer than the accurate setting, as reference,
// across loop rates 1-50 kHz and stress cases (stiff bristles, light
// damping, fast pulls, light loads, every optional effect at once). Against
// it, for the friction force, the bristle state and the transducer's lateral
// force:
//
// - local error: every tick of the reference is re-integrated from the
//   reference state with the setting under test and compared with the
//   reference's next state -- the error the integrator makes per tick;
// - global error: a whole run at the setting under test, compared tick by
//   tick -- only where the closed loop is not itself sensitive to tiny
//   differences (stick-slip in the stress cases amplifies any perturbation,
//   a property of the physics, not of the integrator).
//
// Both must be under 1 % of Fs at the accurate setting and shrink with the
// step.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "sim/instrument.h"
#include "sim/step_size.h"
#include "tests/sim/sim_test_support.h"

namespace tribo::sim {
namespace {

// The plant under test is declared: plain LuGre (tests/sim/sim_test_support.h),
// not the default instrument.
using testing::plain_lugre_config;

struct Case {
  const char* name;
  double loop_rate_hz;
  double load_n;
  double velocity_m_per_s;
  void (*adjust)(v1::DaemonConfig&);
  bool global;  // compare whole runs too
  double duration_s = 0.8;
};

// The reference's ticks: state before and after, and what was held.
struct Tick {
  LateralState before, after;
  LateralInputs inputs;
  double dead_time_s;
};

struct Record {
  std::vector<Tick> ticks;
  std::vector<double> lateral_force_n;
  bool finite = true;
};

// Approach 0 -> 2 um unloaded (0.1 s), load ramp to load_n (0.2 s), a pull
// at velocity from 0.35 s for up to 4 um, 50 ms rest, back, rest.
daemon::Setpoints setpoints(const Case& c, double t) {
  const double travel = std::min(4e-6, c.velocity_m_per_s * 0.3);
  const double t_go = 0.35, t_move = travel / c.velocity_m_per_s, t_back = t_go + t_move + 0.05;
  double x = 2e-6 * std::min(1.0, t / 0.1);
  if (t > t_go) x += c.velocity_m_per_s * std::min(t - t_go, t_move);
  if (t > t_back) x -= c.velocity_m_per_s * std::min(t - t_back, t_move);
  daemon::Setpoints sp;
  sp.normal_force_n = std::clamp((t - 0.1) / 0.2, 0.0, 1.0) * c.load_n;
  sp.lateral_position_m = x;
  return sp;
}

v1::DaemonConfig config_for(const Case& c) {
  v1::DaemonConfig config = plain_lugre_config();
  testing::silence_sensors(config);
  config.mutable_controller()->set_loop_rate_hz(c.loop_rate_hz);
  config.mutable_sim()->mutable_integrator()->set_max_substeps(100000);
  c.adjust(config);
  return config;
}

// The reference evaluates the contact law at every RK4 stage, whatever the
// case's method.
Record record(const Case& c, double max_h_lambda, double duration_s, bool reference = false) {
  v1::DaemonConfig config = config_for(c);
  config.mutable_sim()->mutable_integrator()->set_max_h_lambda(max_h_lambda);
  if (reference) config.mutable_sim()->mutable_integrator()->set_method(v1::INTEGRATION_RK4);
  hal::SimTransducer transducer(instrument_params_from_config(config.sim()), 1, c.loop_rate_hz, false);
  daemon::Controller controller(daemon::controller_params_from_config(config.controller()));
  const SimInstrument& sim = transducer.instrument();
  const double dt = transducer.period_s();
  Record r;
  for (long k = 0; k < std::lround(duration_s / dt); ++k) {
    hal::SensorFrame frame;
    transducer.read(frame);
    transducer.write(controller.step(setpoints(c, static_cast<double>(k) * dt), frame).drive);
    Tick tick;
    tick.before = sim.truth().lateral;
    transducer.wait_next_tick();
    tick.after = sim.truth().lateral;
    tick.inputs = sim.last_inputs();
    tick.dead_time_s = sim.truth().dead_time_s;
    r.ticks.push_back(tick);
    r.lateral_force_n.push_back(sim.measurement().lateral_force_n);
    r.finite &= std::isfinite(sim.truth().friction_n) && std::isfinite(sim.truth().lateral.position_m);
  }
  return r;
}

struct Errors {
  double friction = 0, bristle = 0, lateral_force = 0;  // relative to Fs (z: to Fs / sigma0)
};

double friction_at(const LateralPlant& plant, const LateralInputs& in, const LateralState& s) {
  return lateral_derivative(plant, in, s).friction_n;
}

// The bristle state: LuGre's z, or the Maxwell-slip elements'.
double bristle_difference(const LateralState& a, const LateralState& b) {
  double d = std::fabs(a.bristle_m - b.bristle_m);
  for (int i = 0; i < kMaxSlipElements; ++i) d = std::max(d, std::fabs(a.slip_m[i] - b.slip_m[i]));
  return d;
}

Errors local_errors(const Record& ref, const LateralPlant& plant, const IntegratorSettings& method,
                    double max_h_lambda, double dt, double fs, double sigma0) {
  Errors e;
  for (const Tick& t : ref.ticks) {
    if (t.dead_time_s > 0 || !t.inputs.levels.in_contact()) continue;
    LateralState s = t.before;
    // As the instrument does before integrating a tick: with rate-and-state
    // the state's fall after break-away lowers g faster than the bristle
    // relaxes, and this limit (not the integrator) takes the bristle back.
    limit_to_static_friction(plant, t.inputs, s);
    IntegratorSettings settings = method;
    settings.max_h_lambda = max_h_lambda;
    settings.max_substeps = 100000;
    advance_lateral(plant, t.inputs, settings, dt, s);
    e.friction = std::max(e.friction, std::fabs(friction_at(plant, t.inputs, s) -
                                                friction_at(plant, t.inputs, t.after)) / fs);
    e.bristle = std::max(e.bristle, bristle_difference(s, t.after) * sigma0 / fs);
  }
  return e;
}

// From the start of loading on: during the unloaded approach from the
// neutral point the drive's plate handovers (discrete events) may fall one
// tick apart in two runs.
Errors global_errors(const Record& run, const Record& ref, const LateralPlant& plant, double dt,
                     double fs, double sigma0) {
  Errors e;
  for (std::size_t k = static_cast<std::size_t>(std::lround(0.1 / dt)); k < ref.ticks.size(); ++k) {
    const Tick& a = run.ticks[k];
    const Tick& b = ref.ticks[k];
    e.friction = std::max(e.friction, std::fabs(friction_at(plant, a.inputs, a.after) -
                                                friction_at(plant, b.inputs, b.after)) / fs);
    e.bristle = std::max(e.bristle, bristle_difference(a.after, b.after) * sigma0 / fs);
    e.lateral_force = std::max(e.lateral_force, std::fabs(run.lateral_force_n[k] - ref.lateral_force_n[k]) / fs);
  }
  return e;
}

class IntegratorAccuracy : public ::testing::TestWithParam<Case> {};

TEST_P(IntegratorAccuracy, MatchesAHundredTimesFinerReferenceAndConvergesWithTheStep) {
  const Case& c = GetParam();
  const v1::DaemonConfig config = config_for(c);
  const InstrumentParams params = instrument_params_from_config(config.sim());
  const LateralPlant plant{params.lateral, params.friction};
  const double accurate = config.sim().integrator().max_h_lambda();
  const double dt = 1.0 / c.loop_rate_hz, duration = c.duration_s;
  const double fs = params.friction.lugre.static_coeff * c.load_n;
  const double sigma0 = params.friction.lugre.sigma0_n_per_m;

  const Record ref = record(c, accurate / 100, duration, true);
  ASSERT_TRUE(ref.finite);
  std::vector<Errors> local, global;
  const std::vector<double> steps = {2.0, 1.0, 0.5, 0.25};
  for (double step : steps) {
    local.push_back(local_errors(ref, plant, params.integrator, step * accurate, dt, fs, sigma0));
    std::printf("  %-15s h*lambda %.2f: local  friction %.1e Fs, bristle %.1e Fs/sigma0\n", c.name,
                step * accurate, local.back().friction, local.back().bristle);
    if (!c.global) continue;
    const Record r = record(c, step * accurate, duration);
    ASSERT_TRUE(r.finite) << "h lambda " << step;
    global.push_back(global_errors(r, ref, plant, dt, fs, sigma0));
    std::printf("  %-15s h*lambda %.2f: global friction %.1e Fs, bristle %.1e Fs/sigma0, lateral force %.1e Fs\n",
                c.name, step * accurate, global.back().friction, global.back().bristle, global.back().lateral_force);
  }
  // At the accurate setting (index 1), under 1 % of Fs.
  EXPECT_LT(local[1].friction, 0.01);
  EXPECT_LT(local[1].bristle, 0.01);
  // Shrinking with the step: a quarter of the accurate step is at least 4x
  // better (RK4 is 4th order; the split scheme 2nd), down to a floor of
  // 1e-9 Fs where rounding takes over.
  EXPECT_LT(local[3].friction, std::max(0.25 * local[1].friction, 1e-9));
  EXPECT_LT(local[3].bristle, std::max(0.25 * local[1].bristle, 1e-9));
  EXPECT_LE(local[2].friction, local[0].friction);
  if (!c.global) return;
  // Whole runs: the transducer's lateral force carries the controller's
  // reaction, and at the onset of contact the D term turns a 1e-7 m/s
  // difference into ~0.5 uN, so its floor is ~0.5 % of Fs at light loads.
  EXPECT_LT(global[1].friction, 0.01);
  EXPECT_LT(global[1].bristle, 0.01);
  EXPECT_LT(global[1].lateral_force, 0.01);
  EXPECT_LT(global[3].friction, global[0].friction);
  EXPECT_LT(global[3].bristle, global[0].bristle);
}

void no_change(v1::DaemonConfig&) {}

// Coarse mode: the explicit midpoint rule at h lambda <= 1.2 (2 evaluations
// per sub-step instead of RK4's 4), against the same 100x finer RK4 reference.
// (At 1.8 the error reaches 1.1 % and 2.5 % of Fs at 1 mN and 50 uN.)
TEST(IntegratorAccuracy, CoarseModeStaysWithinOnePercentOfFs) {
  for (const auto& [load, v] : {std::pair{9.81e-3, 18e-6}, std::pair{1e-3, 0.5e-6}, std::pair{50e-6, 4e-6}}) {
    const Case c{"coarse", 1e4, load, v, no_change, true};
    const v1::DaemonConfig config = config_for(c);
    const InstrumentParams params = instrument_params_from_config(config.sim());
    const LateralPlant plant{params.lateral, params.friction};
    const double fs = params.friction.lugre.static_coeff * load, sigma0 = params.friction.lugre.sigma0_n_per_m;
    const Record ref = record(c, config.sim().integrator().max_h_lambda() / 100, 0.8, true);
    Case coarse = c;
    coarse.adjust = [](v1::DaemonConfig& cfg) { cfg.mutable_sim()->mutable_integrator()->set_method(v1::INTEGRATION_MIDPOINT); };
    const Record r = record(coarse, 1.2, 0.8);
    ASSERT_TRUE(r.finite);
    const Errors e = global_errors(r, ref, plant, 1e-4, fs, sigma0);
    std::printf("  coarse, %5.0f uN, %4.1f um/s: global friction %.1e Fs, bristle %.1e Fs/sigma0, lateral force %.1e Fs\n",
                load * 1e6, v * 1e6, e.friction, e.bristle, e.lateral_force);
    EXPECT_LT(e.friction, 0.01);
    EXPECT_LT(e.bristle, 0.01);
    EXPECT_LT(e.lateral_force, 0.01);
  }
}

// At 1 kHz the default loop (kd dt / m = 5) is unstable, and kp = 300 is
// so close to it that the loop amplifies any difference: a gentler one.
void slow_loop(v1::DaemonConfig& c) {
  auto* g = c.mutable_controller()->mutable_lateral_displacement();
  g->set_kp(150);
  g->set_ki(500);
  g->set_kd(0.2);
  g->set_derivative_filter_hz(100);
}

// Stiff bristles: sigma0 x 100 (sigma1 = 3 sqrt(m sigma0) x 10).
void stiff_bristles(v1::DaemonConfig& c) {
  auto* f = c.mutable_sim()->mutable_friction();
  f->set_contact_stiffness_n_per_m(100 * f->contact_stiffness_n_per_m());
  f->set_bristle_damping_n_s_per_m(10 * f->bristle_damping_n_s_per_m());
}

// Light damping: no transducer damping, bristle damping / 20.
void light_damping(v1::DaemonConfig& c) {
  c.mutable_sim()->mutable_lateral()->set_damping_n_s_per_m(0);
  auto* f = c.mutable_sim()->mutable_friction();
  f->set_bristle_damping_n_s_per_m(f->bristle_damping_n_s_per_m() / 20);
}

// Every optional friction effect on at once.
void all_effects(v1::DaemonConfig& c) {
  auto* f = c.mutable_sim()->mutable_friction();
  f->mutable_dwell_stiction()->set_enabled(true);
  f->mutable_frictional_lag()->set_enabled(true);
  f->mutable_velocity_strengthening()->set_enabled(true);
  f->mutable_load_dependence()->set_enabled(true);
  f->mutable_position_periodic()->set_enabled(true);
  f->mutable_orientation_anisotropy()->set_enabled(true);
  f->mutable_direction_asymmetry()->set_enabled(true);
  f->mutable_presliding_hysteresis()->set_enabled(true);
}

// Rate-and-state with elasto-plastic presliding (config/instruments/dissertation_fit.textproto).
// At 9.81 mN, 36 um/s it converges as required (local friction error 1.3e-3
// Fs at h lambda = 1, 1.0e-5 Fs at 0.25). At 50 uN, 4 um/s (split scheme) the
// error is small (1.4e-4 Fs at h lambda = 1) but the bristle converges only
// at first order (8.8e-6 -> 3.8e-6 Fs/sigma0 from h lambda 1 to 0.25):
// not listed, as the 4x-per-4x-step requirement below does not hold.
void rate_state(v1::DaemonConfig& c) {
  auto* f = c.mutable_sim()->mutable_friction();
  f->set_breakaway_ratio(0.9);
  f->set_coulomb_coeff(0.09);
  f->set_static_coeff(0.09);
  auto* r = f->mutable_rate_state();
  r->set_enabled(true);
  r->set_direct_coeff(0.023);
  r->set_state_coeff(0.02);
  r->set_reference_velocity_m_per_s(1e-6);
  r->set_memory_length_m(0.66e-6);
  r->set_initial_state_s(0.49);
}

// The same with the held-contact scheme (sim/held_contact.h; S evaluated at
// each sub-step's start and midpoint), against the same reference (the law
// at every stage, 100x finer).
void rate_state_held(v1::DaemonConfig& c) {
  rate_state(c);
  c.mutable_sim()->mutable_integrator()->set_method(v1::INTEGRATION_RK4_HELD_CONTACT);
}

// Backlash: the tip (0.3 g) on its own coupling behind a 20 nm dead zone.
void backlash(v1::DaemonConfig& c) { c.mutable_sim()->mutable_tip()->mutable_backlash()->set_enabled(true); }

INSTANTIATE_TEST_SUITE_P(
    LoopRatesAndStressCases, IntegratorAccuracy,
    ::testing::Values(Case{"r10kHz_18um_s", 1e4, 9.81e-3, 18e-6, no_change, true},
                      Case{"r10kHz_0p5um_s", 1e4, 1e-3, 0.5e-6, no_change, true},
                      Case{"r1kHz_18um_s", 1e3, 9.81e-3, 18e-6, slow_loop, true},
                      Case{"r50kHz_18um_s", 5e4, 9.81e-3, 18e-6, no_change, true},
                      Case{"light_load", 1e4, 50e-6, 4e-6, no_change, true},
                      Case{"fast_pull", 1e4, 5e-3, 100e-6, no_change, true},
                      Case{"stiff_bristles", 1e4, 5e-3, 18e-6, stiff_bristles, false},
                      Case{"light_damping", 1e4, 5e-3, 18e-6, light_damping, false},
                      Case{"all_effects", 1e4, 5e-3, 4e-6, all_effects, false},
                      Case{"rate_state", 1e4, 9.81e-3, 36e-6, rate_state, false},
                      Case{"rate_state_held", 1e4, 9.81e-3, 36e-6, rate_state_held, false},
                      Case{"backlash", 1e4, 5e-3, 4e-6, backlash, false, 0.6}),
    [](const ::testing::TestParamInfo<Case>& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace tribo::sim
