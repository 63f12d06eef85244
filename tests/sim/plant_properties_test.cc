// Properties of the simulated plant that hold whatever the parameters:
// stored energy never grows without drive; the same inputs and seed give
// bit-identical output at every loop rate; no loop rate 1-50 kHz blows up.
#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <cstdio>
#include <vector>

#include "sim/instrument.h"
#include "sim/noise_source.h"
#include "sim/step_size.h"
#include "tests/sim/sim_test_support.h"

namespace tribo::sim {
namespace {

// The plant under test is declared: plain LuGre (tests/sim/sim_test_support.h),
// not the default instrument.
using testing::plain_lugre_config;

struct EnergyCase {
  const char* name;
  double load_n;
  void (*adjust)(InstrumentParams&);
  bool biased;  // the drive plates at their DC bias (no drive command)
};

void plain(InstrumentParams&) {}
void elasto_plastic(InstrumentParams& p) { p.friction.lugre.breakaway_ratio = 0.8; }
void maxwell_slip(InstrumentParams& p) { p.friction.presliding_hysteresis.enabled = true; }
void backlash(InstrumentParams& p) { p.lateral.backlash.enabled = true; }
void dwell(InstrumentParams& p) { p.friction.dwell_stiction.enabled = true; }
void strengthening(InstrumentParams& p) { p.friction.velocity_strengthening.enabled = true; }
void asymmetry(InstrumentParams& p) { p.friction.direction_asymmetry.enabled = true; }
// Rate-and-state with elasto-plastic presliding, as in
// config/instruments/dissertation_fit.textproto.
void rate_state(InstrumentParams& p) {
  p.friction.lugre.breakaway_ratio = 0.9;
  p.friction.rate_state = {true, 0.023, 0.02, 1e-6, 0.66e-6, 0.49, StateLaw::kSlip};
}
void rate_state_ageing(InstrumentParams& p) {
  rate_state(p);
  p.friction.rate_state.law = StateLaw::kAgeing;
}
// The held-contact scheme (sim/held_contact.h), with the default's tolerance
// for holding S at a sub-step's start.
void held(InstrumentParams& p) {
  p.integrator.held_contact = true;
  p.integrator.contact_law_tolerance_n = 1e-8;
}
void held_elasto_plastic(InstrumentParams& p) {
  elasto_plastic(p);
  held(p);
}
void held_dwell(InstrumentParams& p) {
  dwell(p);
  held(p);
}
void held_rate_state(InstrumentParams& p) {
  rate_state(p);
  held(p);
}
void held_rate_state_ageing(InstrumentParams& p) {
  rate_state_ageing(p);
  held(p);
}
void effects(InstrumentParams& p) {
  dwell(p);
  strengthening(p);
  asymmetry(p);
  maxwell_slip(p);
  backlash(p);
}

class EnergyWithoutDrive : public ::testing::TestWithParam<EnergyCase> {};

// From random states (|z| <= g(v), speeds up to 50 um/s) the plant is left
// alone for 0.1 s: at every tick the stored energy (kinetic, springs,
// bristles, and the potentials of the tilt force and the bias field) must
// not exceed the previous tick's, beyond rounding.
//
// LuGre dissipates while |z| <= g: dE/dt = -(c + sigma2) v^2 - sigma0 |v| z^2 / g
// - sigma1 v^2 (1 - sgn(v) z / g). Where g moves independently of v -- the
// frictional lag (g follows a lagged velocity) and position-periodic friction
// (g follows x) -- the bristle can sit beyond g, and then the sigma1 term
// returns energy (measured: up to 0.9 % and 1.8 % of the stored energy in one
// tick from such random states). That is the published model's known lack
// of passivity (Barabanov and Ortega 2000); tribo keeps the model as
// published, so those two effects are not in this list (README). The same
// holds for rate-and-state under the slip law from states far from steady
// (|ln(|v| phi / D_c)| large, phi and so g change fast): at 1 mN, measured up
// to 1.8e-5 of the stored energy in one tick; at 10 mN and under the ageing
// law it stays within rounding, and those cases are below.
TEST_P(EnergyWithoutDrive, NeverGrows) {
  const EnergyCase& c = GetParam();
  InstrumentParams params = instrument_params_from_config(plain_lugre_config().sim());
  c.adjust(params);
  const LateralPlant plant{params.lateral, params.friction};
  LateralInputs in;
  in.drive = c.biased ? electrostatic_drive_field(params.lateral_drive,
                                                  {params.lateral_drive.bias_voltage_v, params.lateral_drive.bias_voltage_v})
                      : ideal_drive_field(0.0);
  in.levels = contact_levels(params.friction, c.load_n, 0.0, 1.0);
  in.tip_force_n = c.load_n * std::tan(params.tilt.angle_rad);
  NoiseSource random(derive_seed(42, 7));
  const double dt = 1e-4;
  int violations = 0, checked = 0;
  double worst = 0;
  for (int trial = 0; trial < 40; ++trial) {
    LateralState s;
    s.position_m = (2 * random.uniform() - 1) * 10e-6;
    s.velocity_m_per_s = (2 * random.uniform() - 1) * 50e-6;
    s.tip_position_m = s.position_m + (2 * random.uniform() - 1) * 20e-9;
    s.tip_velocity_m_per_s = s.velocity_m_per_s;
    s.contact_age_s = 10 * random.uniform();
    s.rate_state_s = 0.05 + 0.1 * s.contact_age_s;  // no extra draw: the other cases keep their states
    s.lag_velocity_m_per_s = s.velocity_m_per_s;
    const double g = lateral_derivative(plant, in, s).deflection_scale_m;
    s.bristle_m = (2 * random.uniform() - 1) * g;
    for (double& z : s.slip_m) z = (2 * random.uniform() - 1) * g * (1 - params.friction.presliding_hysteresis.spread);
    double energy = stored_energy_j(plant, in, s);
    HeldContactMemory memory;
    for (int k = 0; k < 1000; ++k) {
      advance_lateral(plant, in, params.integrator, dt, s, nullptr, &memory);
      const double next = stored_energy_j(plant, in, s);
      const double growth = (next - energy) / std::max(std::fabs(energy), 1e-18);
      worst = std::max(worst, growth);
      if (growth > 1e-9) ++violations;
      ++checked;
      energy = next;
    }
  }
  std::printf("  %-15s %d ticks, largest relative growth per tick %.2e\n", c.name, checked, worst);
  EXPECT_EQ(violations, 0) << "largest relative growth per tick " << worst;
}

INSTANTIATE_TEST_SUITE_P(
    Plants, EnergyWithoutDrive,
    ::testing::Values(EnergyCase{"lugre_1mN", 1e-3, plain, false}, EnergyCase{"lugre_10mN", 10e-3, plain, false},
                      EnergyCase{"light_load", 2e-6, plain, false}, EnergyCase{"biased_plates", 1e-3, plain, true},
                      EnergyCase{"elasto_plastic", 1e-3, elasto_plastic, false},
                      EnergyCase{"maxwell_slip", 1e-3, maxwell_slip, false},
                      EnergyCase{"backlash", 1e-3, backlash, false}, EnergyCase{"dwell", 1e-3, dwell, false},
                      EnergyCase{"strengthening", 1e-3, strengthening, false},
                      EnergyCase{"asymmetry", 1e-3, asymmetry, false}, EnergyCase{"effects", 1e-3, effects, false},
                      EnergyCase{"rate_state_10mN", 10e-3, rate_state, false},
                      EnergyCase{"rate_state_ageing", 1e-3, rate_state_ageing, false},
                      EnergyCase{"no_contact", 0.0, plain, true},
                      EnergyCase{"held_lugre_1mN", 1e-3, held, false},
                      EnergyCase{"held_light_load", 2e-6, held, false},
                      EnergyCase{"held_biased_plates", 1e-3, held, true},
                      EnergyCase{"held_elasto_plastic", 1e-3, held_elasto_plastic, false},
                      EnergyCase{"held_dwell", 1e-3, held_dwell, false},
                      EnergyCase{"held_rate_state_10mN", 10e-3, held_rate_state, false},
                      EnergyCase{"held_rate_state_ageing", 1e-3, held_rate_state_ageing, false}),
    [](const ::testing::TestParamInfo<EnergyCase>& info) { return std::string(info.param.name); });

// The loop gains for a loop rate: the default I-PD at 10 kHz and above; a
// gentler one below, where kd dt / m = 5 at 1 kHz would be unstable.
v1::DaemonConfig config_at(double loop_rate_hz) {
  v1::DaemonConfig config = plain_lugre_config();
  config.mutable_controller()->set_loop_rate_hz(loop_rate_hz);
  if (loop_rate_hz < 1e4) {
    auto* g = config.mutable_controller()->mutable_lateral_displacement();
    g->set_kp(150);
    g->set_ki(500);
    g->set_kd(0.2 * loop_rate_hz / 1e3);
    g->set_derivative_filter_hz(100);
  }
  return config;
}

struct Sample {
  double lateral_force_n, lateral_position_m, normal_force_n, normal_displacement_m, friction_n, load_n;
  bool operator==(const Sample&) const = default;
};

// A short scratch with every sensor's noise: load 2 mN, 4 um at 4 um/s.
std::vector<Sample> scratch(double loop_rate_hz, std::uint64_t seed, bool* sane = nullptr) {
  std::vector<Sample> out;
  bool ok = true;
  testing::run_closed_loop(
      config_at(loop_rate_hz), seed, 1.6,
      [](double t) {
        return testing::LoopSetpoints{std::clamp((t - 0.1) / 0.3, 0.0, 1.0) * 2e-3,
                                      2e-6 * std::min(1.0, t / 0.1) + 4e-6 * std::clamp(t - 0.5, 0.0, 1.0)};
      },
      [&](double, const hal::SimTransducer& tr) {
        const Measurement& m = tr.instrument().measurement();
        out.push_back(Sample{m.lateral_force_n, m.lateral_position_m, m.normal_force_n, m.normal_displacement_m,
                             tr.instrument().truth().friction_n, tr.instrument().truth().normal.contact_load_n});
        ok &= std::isfinite(m.lateral_position_m) && std::isfinite(tr.instrument().truth().friction_n) &&
              !tr.instrument().truth().snapped;
      });
  if (sane) *sane = ok;
  return out;
}

class LoopRates : public ::testing::TestWithParam<double> {};

TEST_P(LoopRates, SameSeedIsBitIdenticalAndAnotherSeedDiffers) {
  const double rate = GetParam();
  const auto a = scratch(rate, 11), b = scratch(rate, 11), c = scratch(rate, 12);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) ASSERT_TRUE(a[k] == b[k]) << "tick " << k;
  std::size_t differing = 0;
  for (std::size_t k = 0; k < a.size(); ++k) differing += !(a[k] == c[k]);
  EXPECT_GT(differing, a.size() / 2);
}

TEST_P(LoopRates, FullInstrumentStaysFiniteAndSlidesAtTheModelsFriction) {
  const double rate = GetParam();
  bool sane = false;
  const auto run = scratch(rate, 3, &sane);
  EXPECT_TRUE(sane) << "NaN, infinity or snap-down at " << rate << " Hz";
  // Last 0.3 s of the 4 um/s slide: the friction is the Stribeck function's.
  const InstrumentParams p = instrument_params_from_config(config_at(rate).sim());
  double friction = 0, load = 0;
  const std::size_t n = static_cast<std::size_t>(0.3 * rate), end = run.size() - static_cast<std::size_t>(0.1 * rate);
  for (std::size_t k = end - n; k < end; ++k) {
    friction += run[k].friction_n;
    load += run[k].load_n;
  }
  const double expected = steady_state_friction_n(p.friction.lugre, load / static_cast<double>(n), 4e-6);
  // Within 1 %: the sensor noise dithers the contact a little (sim/capacitive_sensor.h).
  EXPECT_NEAR(friction / static_cast<double>(n), expected, 0.01 * expected) << rate << " Hz";
}

INSTANTIATE_TEST_SUITE_P(OneToFiftyKilohertz, LoopRates, ::testing::Values(1e3, 2e3, 5e3, 1e4, 2e4, 5e4),
                         [](const ::testing::TestParamInfo<double>& info) {
                           return std::to_string(static_cast<int>(info.param)) + "Hz";
                         });

}  // namespace
}  // namespace tribo::sim
