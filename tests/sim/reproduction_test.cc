// The dissertation's observations (§3.3.1, §4.4, §5.3) reproduced by the
// simulated instrument with its default config -- sensor noise, tilt,
// electrostatic drive and all -- through the controller, as an experiment
// would see them. Each test states its tolerance and why. Where the physics
// does not reproduce an observation the test prints the numbers and asserts
// only what holds; docs/physics_and_sources.md lists those.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <numeric>
#include <vector>

#include "sim/lugre_friction.h"
#include "sim/normal_axis.h"
#include "tests/sim/sim_test_support.h"

namespace tribo::sim {
namespace {

using testing::default_config;
using testing::LoopSetpoints;

double tilt_tan(const v1::DaemonConfig& c) {
  return std::tan(c.sim().tip().tilt_offset().angle_deg() * std::numbers::pi / 180);
}

// One experiment as the instrument records it, every tick: time from motion
// onset, measured lateral force, position and normal force; true tip velocity.
struct Trace {
  std::vector<double> t, force, position, setpoint, normal, velocity;
};

// Approach 0 -> +2 um unloaded, settle (the I-PD loop's slow pole is ~5 1/s),
// load over 0.5 s, rest, then move by `travel` at `velocity` (and back when
// `back`), then hold. Time 0 of the trace is the motion onset.
struct Protocol {
  double load_n = 1e-3;
  double velocity_m_per_s = 1e-6;
  double travel_m = 4e-6;
  double rest_s = 1.5;
  bool back = false;
  double hold_s = 0;  // between the passes (and at the end)
};

Trace run(const v1::DaemonConfig& config, const Protocol& p, std::uint64_t seed = 1) {
  const double t_load = 1.5, t_go = t_load + 0.5 + p.rest_s, t_move = p.travel_m / p.velocity_m_per_s;
  const double t_back = t_move + p.hold_s;  // from motion onset
  const double duration = t_go + (p.back ? t_back + t_move : t_move) + p.hold_s;
  Trace tr;
  testing::run_closed_loop(
      config, seed, duration,
      [&](double t) {
        double x = 2e-6 * std::min(1.0, t / 0.3);
        const double s = t - t_go;
        if (s > 0) x += p.velocity_m_per_s * std::min(s, t_move);
        if (p.back && s > t_back) x -= p.velocity_m_per_s * std::min(s - t_back, t_move);
        return LoopSetpoints{std::clamp((t - t_load) / 0.5, 0.0, 1.0) * p.load_n, x};
      },
      [&](double t, const hal::SimTransducer& h) {
        if (t < t_go - 0.5) return;
        const Measurement& m = h.instrument().measurement();
        const double s = t - t_go;
        double x = 2e-6 + p.velocity_m_per_s * std::clamp(s, 0.0, t_move);
        if (p.back && s > t_back) x -= p.velocity_m_per_s * std::min(s - t_back, t_move);
        tr.t.push_back(s);
        tr.force.push_back(m.lateral_force_n);
        tr.position.push_back(m.lateral_position_m);
        tr.setpoint.push_back(x);
        tr.normal.push_back(m.normal_force_n);
        tr.velocity.push_back(h.instrument().truth().lateral.velocity_m_per_s);
      });
  return tr;
}

double mean_over(const Trace& tr, const std::vector<double>& v, double from_s, double to_s) {
  double sum = 0;
  int n = 0;
  for (std::size_t k = 0; k < tr.t.size(); ++k) {
    if (tr.t[k] >= from_s && tr.t[k] < to_s) {
      sum += v[k];
      ++n;
    }
  }
  return sum / n;
}

// µ = 0.0996 for the 50 µm diamond tip on mica at 13.5 µm/s, 500-9810 µN
// (§4.4). Friction from a forward and a backward pass, (F+ - F-) / 2, which
// cancels the tilt's -N tan(theta) as an experimenter would.
TEST(Reproduction, FrictionIsLinearInLoadWithTheMeasuredMu) {
  // The model's mu: without the spot-to-spot variation of the sample (on in
  // the default, one draw of 1.3 % RMS per seed; FiveSeedsSpreadLikeTheDissertationsRuns).
  v1::DaemonConfig config = default_config();
  config.mutable_sim()->mutable_sample()->mutable_heterogeneity()->set_enabled(false);
  // The I-PD loop lags (kp + k) v0 / ki = 2.8 um behind at 13.5 um/s and
  // settles with a 0.2 s time constant: 10 um passes (0.74 s) with a 1 s
  // hold between them, averaged over the last 30 % of each pass.
  Protocol p;
  p.velocity_m_per_s = 13.5e-6;
  p.travel_m = 10e-6;
  p.back = true;
  p.hold_s = 1.0;
  p.rest_s = 0.5;
  const double pass = p.travel_m / p.velocity_m_per_s, back = pass + p.hold_s;
  std::vector<double> loads, frictions;
  for (double load : {500e-6, 1000e-6, 3000e-6, 5000e-6, 9810e-6}) {
    p.load_n = load;
    const Trace tr = run(config, p);
    const double forward = mean_over(tr, tr.force, 0.7 * pass, pass);
    const double backward = mean_over(tr, tr.force, back + 0.7 * pass, back + pass);
    loads.push_back(0.5 * (mean_over(tr, tr.normal, 0.7 * pass, pass) + mean_over(tr, tr.normal, back + 0.7 * pass, back + pass)));
    frictions.push_back(0.5 * (forward - backward));
    std::printf("  N = %7.1f uN: friction %6.2f uN (forward %6.2f, backward %6.2f), mu %.4f\n", loads.back() * 1e6,
                frictions.back() * 1e6, forward * 1e6, backward * 1e6, frictions.back() / loads.back());
  }
  const double n = static_cast<double>(loads.size());
  const double mx = std::accumulate(loads.begin(), loads.end(), 0.0) / n;
  const double my = std::accumulate(frictions.begin(), frictions.end(), 0.0) / n;
  double sxx = 0, sxy = 0, syy = 0;
  for (std::size_t i = 0; i < loads.size(); ++i) {
    sxx += (loads[i] - mx) * (loads[i] - mx);
    sxy += (loads[i] - mx) * (frictions[i] - my);
    syy += (frictions[i] - my) * (frictions[i] - my);
  }
  const double slope = sxy / sxx, intercept = my - slope * mx, r2 = sxy * sxy / (sxx * syy);
  std::printf("  fit: mu = %.4f, intercept %.2f uN, R^2 %.6f\n", slope, intercept * 1e6, r2);
  // The model's steady mu at 13.5 um/s is 0.0996 (Fc/N + (a - b) ln(1 + v/V*)
  // of the rate-and-state contact, set so); the sensor noise averages out to
  // well under 1 %.
  EXPECT_NEAR(slope, 0.0996, 0.01 * 0.0996);
  EXPECT_NEAR(intercept, 0.0, 2e-6);
  EXPECT_GT(r2, 0.9999);
}

// Five runs at 3000 µN and 13.5 µm/s spread by 1.3 % in the dissertation.
// Seeds change only the noise in the simulated instrument, which spreads the
// means by < 0.1 % (0.066 % with the 3 nm position wander the tip follows); the
// rest comes from the sample, spot to spot (sample.heterogeneity, 1.3 % RMS,
// on in the default). The standard deviation of five draws lies within
// [0.35, 1.67] sigma with 95 % probability.
TEST(Reproduction, FiveSeedsSpreadLikeTheDissertationsRuns) {
  v1::DaemonConfig config = default_config();
  Protocol p;
  p.load_n = 3000e-6;
  p.velocity_m_per_s = 13.5e-6;
  p.travel_m = 10e-6;
  p.rest_s = 0.5;
  const double pass = p.travel_m / p.velocity_m_per_s;
  auto spread = [&](const v1::DaemonConfig& c, double* mean_out) {
    std::vector<double> means;
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
      const Trace tr = run(c, p, seed);
      means.push_back(mean_over(tr, tr.force, 0.5 * pass, pass) + tilt_tan(c) * mean_over(tr, tr.normal, 0.5 * pass, pass));
    }
    const double mean = std::accumulate(means.begin(), means.end(), 0.0) / 5;
    double ss = 0;
    for (double m : means) ss += (m - mean) * (m - mean);
    *mean_out = mean;
    return std::sqrt(ss / 4) / mean;
  };
  double mean_noise = 0, mean_sites = 0;
  config.mutable_sim()->mutable_sample()->mutable_heterogeneity()->set_enabled(false);
  const double noise_only = spread(config, &mean_noise);
  config.mutable_sim()->mutable_sample()->mutable_heterogeneity()->set_enabled(true);
  const double with_sites = spread(config, &mean_sites);
  std::printf("  five seeds at 3000 uN: %.2f uN mean, spread %.3f %% (noise only), %.2f uN, %.2f %% (with spot-to-spot variation)\n",
              mean_noise * 1e6, 100 * noise_only, mean_sites * 1e6, 100 * with_sites);
  EXPECT_LT(noise_only, 0.005);
  EXPECT_GT(with_sites, 0.35 * 0.013);
  EXPECT_LT(with_sites, 1.67 * 0.013);
}

// At motion onset the friction rises to its sliding value sooner at higher
// velocity (Fig. 4.21, 5.11); rise time: until the (tilt-corrected) lateral
// force first reaches 95 % of its steady value.
TEST(Reproduction, StictionRiseIsEarlierAtHigherVelocity) {
  const v1::DaemonConfig config = default_config();
  std::vector<double> rise, overshoot, spike;
  for (double v : {0.2e-6, 4e-6, 18e-6, 36.4e-6}) {
    Protocol p;
    p.load_n = 9810e-6;
    p.velocity_m_per_s = v;
    p.travel_m = v < 1e-6 ? 1.2e-6 : 8e-6;
    const double t_move = p.travel_m / v;
    const Trace tr = run(config, p);
    std::vector<double> friction(tr.force.size());
    for (std::size_t k = 0; k < friction.size(); ++k) friction[k] = tr.force[k] + tilt_tan(config) * tr.normal[k];
    const double steady = mean_over(tr, friction, 0.8 * t_move, t_move);
    double t_rise = -1, peak = 0, v_peak = 0;
    for (std::size_t k = 0; k < tr.t.size(); ++k) {
      if (tr.t[k] < 0 || tr.t[k] > t_move) continue;
      if (t_rise < 0 && friction[k] >= 0.95 * steady) t_rise = tr.t[k];
      peak = std::max(peak, friction[k]);
      v_peak = std::max(v_peak, tr.velocity[k]);
    }
    rise.push_back(t_rise);
    overshoot.push_back(v_peak / v);
    spike.push_back(peak / steady - 1);
    std::printf("  v0 = %5.1f um/s: rise %.3f s, steady %.1f uN, peak %.1f uN (+%.1f %%), tip velocity peak %.2f v0\n",
                v * 1e6, t_rise, steady * 1e6, peak * 1e6, 100 * spike.back(), overshoot.back());
  }
  for (std::size_t i = 1; i < rise.size(); ++i) EXPECT_LT(rise[i], rise[i - 1]) << "velocity index " << i;
  // The dissertation's spike grows with velocity (Table 5.1 at 9810 uN: +30,
  // +43, +56 % over the sliding friction at 4, 18, 36 um/s). The default
  // contact (rate-and-state, presliding, dwell) reproduces the trend: +22.7, +28.9, +32.6 % measured
  // (+6.5 % at 0.2 um/s). Plain LuGre (Appendix C's form) under Appendix C's
  // loop gave a few %, falling with velocity (Breakaway.PlainLugreHasNoSpikeAt9810uN).
  for (std::size_t i = 2; i < spike.size(); ++i) EXPECT_GT(spike[i], spike[i - 1]) << "velocity index " << i;
  for (std::size_t i = 1; i < spike.size(); ++i) EXPECT_GT(spike[i], 0.1) << "velocity index " << i;
}

// Fig. 4.22: a longer rest before motion gives a larger spike. Plain LuGre
// forgets the rest; with dwell_stiction (Armstrong's rising static friction)
// on at its configured 0.3 gain and 100 s time constant the spike grows.
// Quiet sensors: with them the held tip follows the 3 nm position wander,
// which leaves the bristle +-3 nm (+-10 uN) anywhere when motion starts
// and blurs a 60 s dwell's few %.
// On the fitted contact, whose rate-and-state state forgets a rest within
// 0.09 s, so that the dwell term alone makes the difference (the default's
// state ages by b ln t at rest and would add its own).
TEST(Reproduction, LongerRestGivesALargerSpikeWithDwellStiction) {
  v1::DaemonConfig config = testing::fitted_contact_config();
  testing::silence_sensors(config);
  config.mutable_sim()->mutable_friction()->mutable_dwell_stiction()->set_enabled(true);
  auto peak_after = [&](double rest) {
    Protocol p;
    p.load_n = 3000e-6;
    p.velocity_m_per_s = 0.5e-6;  // slow enough that the static level shows (exp(-v/vs) = 0.66)
    p.travel_m = 1e-6;
    p.rest_s = rest;
    const Trace tr = run(config, p);
    double peak = 0;
    for (std::size_t k = 0; k < tr.t.size(); ++k) {
      if (tr.t[k] > 0) peak = std::max(peak, tr.force[k] + tilt_tan(config) * tr.normal[k]);
    }
    return peak;
  };
  // 5 s and 60 s: after 5 s the loop's integrator has taken the tilt's push
  // off the bristle (time constant ~0.7 s in stick), so only the dwell differs.
  // Fs grows by 1 + 0.3 theta / (theta + 100 s): 9.6 % between the two.
  const double short_rest = peak_after(5), long_rest = peak_after(60);
  std::printf("  peak after 5 s rest %.1f uN, after 60 s %.1f uN (+%.1f %%)\n", short_rest * 1e6, long_rest * 1e6,
              100 * (long_rest / short_rest - 1));
  EXPECT_GT(long_rest, 1.02 * short_rest);
  EXPECT_LT(long_rest, 1.096 * short_rest);
}

// §5.4.1, eq. 32: in steady sliding the I-PD loop lags by dl = k v0 / ki,
// where k is everything proportional to position: kp plus the transducer
// spring (the dissertation's plant has none). Quiet sensors: the 3 nm
// position wander would blur the 0.1 um lag at 0.5 um/s by a few %.
TEST(Reproduction, SteadyLagIsStiffnessTimesVelocityOverKi) {
  v1::DaemonConfig config = default_config();
  testing::silence_sensors(config);
  const auto& g = config.controller().lateral_displacement();
  const double k = g.kp() + config.sim().lateral().spring_stiffness_n_per_m();
  // 6 s of sliding (at most 10 um): at 9810 uN the stick phase alone lasts
  // ~1.5 s at 0.5 um/s, and the lag settles with a 0.2 s time constant after it.
  for (auto [load, v] : {std::pair{1e-3, 0.5e-6}, std::pair{1e-3, 2e-6}, std::pair{9810e-6, 0.5e-6},
                         std::pair{9810e-6, 1.5e-6}}) {
    Protocol p;
    p.load_n = load;
    p.velocity_m_per_s = v;
    p.travel_m = v * 6.0;
    const double t_move = p.travel_m / v;
    const Trace tr = run(config, p);
    std::vector<double> lag(tr.t.size());
    for (std::size_t k2 = 0; k2 < lag.size(); ++k2) lag[k2] = tr.setpoint[k2] - tr.position[k2];
    const double measured = mean_over(tr, lag, t_move - 0.5, t_move);
    std::printf("  %4.0f uN, v0 = %.1f um/s: lag %.4f um, (kp + k) v0 / ki = %.4f um\n", load * 1e6, v * 1e6,
                measured * 1e6, k * v / g.ki() * 1e6);
    EXPECT_NEAR(measured, k * v / g.ki(), 0.02 * k * v / g.ki());
  }
}

// Fig. 5.14-5.15, Table 5.1: stretch time ts (motion onset to the end of the
// stick phase, here: the friction reaching 95 % of its sliding value) and
// stretch distance ds (the tip's travel meanwhile); and the Table 5.1
// identification (eqs. 26, 28, 33) applied to the simulated runs.
TEST(Reproduction, StretchTimeAndDistanceAndTheTable51Formulas) {
  const v1::DaemonConfig config = default_config();
  const auto& g = config.controller().lateral_displacement();
  struct Row {
    double load, v, ts, ds, fs, dl;
  };
  std::vector<Row> rows;
  for (double load : {5000e-6, 9810e-6}) {
    for (double v : {1e-6, 4e-6}) {
      Protocol p;
      p.load_n = load;
      p.velocity_m_per_s = v;
      p.travel_m = v * 2.5;
      const double t_move = p.travel_m / v;
      const Trace tr = run(config, p);
      std::vector<double> friction(tr.force.size()), lag(tr.force.size());
      for (std::size_t k = 0; k < friction.size(); ++k) {
        friction[k] = tr.force[k] + tilt_tan(config) * tr.normal[k];
        lag[k] = tr.setpoint[k] - tr.position[k];
      }
      const double steady = mean_over(tr, friction, t_move - 0.5, t_move);
      const double x0 = mean_over(tr, tr.position, -0.05, 0.0);
      Row r{load, v, -1, 0, 0, mean_over(tr, lag, t_move - 0.5, t_move)};
      for (std::size_t k = 0; k < tr.t.size() && r.ts < 0; ++k) {
        if (tr.t[k] > 0 && friction[k] >= 0.95 * steady) {
          r.ts = tr.t[k];
          r.ds = tr.position[k] - x0;
          r.fs = friction[k];
        }
      }
      rows.push_back(r);
      const double mki = 2 * r.fs / (v * r.ts * r.ts), mk = mki * r.dl / v;
      std::printf("  %4.0f uN, %.0f um/s: ts %.3f s, ds %.3f um, Fs %.0f uN, dl %.3f um -> eq.26 sigma %.0f N/m, "
                  "eq.28 mki %.0f, eq.33 mk %.0f (with the true ki: %.0f)\n",
                  load * 1e6, v * 1e6, r.ts, r.ds * 1e6, r.fs * 1e6, r.dl * 1e6, r.fs / r.ds, mki, mk, g.ki() * r.dl / v);
    }
  }
  // rows: (5000, 1), (5000, 4), (9810, 1), (9810, 4)
  EXPECT_GT(rows[2].ts, rows[0].ts) << "stretch time grows with load";
  EXPECT_GT(rows[3].ts, rows[1].ts);
  EXPECT_GT(rows[2].ds, rows[0].ds) << "stretch distance grows with load";
  EXPECT_GT(rows[3].ds, rows[1].ds);
  EXPECT_LT(rows[1].ts, rows[0].ts) << "stretch time shrinks with velocity";
  EXPECT_LT(rows[3].ts, rows[2].ts);
  // Eq. 33 recovers the loop's position stiffness from the lag: with the
  // simulated ki, ki dl / v0 = kp + k_spring (536 N/m with the default's
  // gains from Table 5.1; measured 536-552). Eq. 28 does not recover ki with
  // the 95 %-of-steady stretch time used here: it assumes the tip stays put
  // while the integrator ramps, but the P term and the spring take part of the
  // ramp (61-77 % of ki with the default contact, ~40 % with plain LuGre,
  // which creeps).
  const double k_spring = config.sim().lateral().spring_stiffness_n_per_m();
  for (const Row& r : rows) EXPECT_NEAR(g.ki() * r.dl / r.v, g.kp() + k_spring, 0.05 * (g.kp() + k_spring));
}

// §5.2: during loading with no motion the tilted tip makes the transducer
// read -N tan(theta): the lateral force at rest against the load is a line
// of slope -tan(theta). Quiet sensors: at rest the stuck tip follows the
// 3 nm position wander, which moves the lateral force by sigma0 * 3 nm
// ~ 10 uN RMS (README) and would blur the line at 1 mN. On top of the line
// sits what the bristle kept from loading: at light load the tilt's push
// makes the contact creep (LuGre has no true stiction), and the loop's
// integrator, pulling the tip back, does not undo all of it -- measured
// +8 uN at 1 mN, -7 uN at 10 mN.
TEST(Reproduction, TiltGivesALateralForceDuringLoading) {
  v1::DaemonConfig config = default_config();
  testing::silence_sensors(config);
  std::vector<double> loads, forces;
  for (double load : {1e-3, 2.5e-3, 5e-3, 7.5e-3, 10e-3}) {
    Protocol p;
    p.load_n = load;
    p.travel_m = 0;
    p.velocity_m_per_s = 1e-6;
    p.rest_s = 3;
    const Trace tr = run(config, p);
    loads.push_back(mean_over(tr, tr.normal, -0.5, 0.0));
    forces.push_back(mean_over(tr, tr.force, -0.5, 0.0));
    std::printf("  N = %.0f uN: lateral force %.2f uN, -N tan(1.5 deg) = %.2f uN\n", loads.back() * 1e6,
                forces.back() * 1e6, -loads.back() * tilt_tan(config) * 1e6);
  }
  const double n = static_cast<double>(loads.size());
  const double mx = std::accumulate(loads.begin(), loads.end(), 0.0) / n;
  const double my = std::accumulate(forces.begin(), forces.end(), 0.0) / n;
  double sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < loads.size(); ++i) {
    sxx += (loads[i] - mx) * (loads[i] - mx);
    sxy += (loads[i] - mx) * (forces[i] - my);
  }
  std::printf("  slope %.5f, -tan(1.5 deg) = %.5f\n", sxy / sxx, -tilt_tan(config));
  EXPECT_NEAR(sxy / sxx, -tilt_tan(config), 0.1 * tilt_tan(config));
  for (std::size_t i = 0; i < loads.size(); ++i) EXPECT_NEAR(forces[i], -loads[i] * tilt_tan(config), 10e-6);
}

// §7: the 50 µm tip's depth follows Hertz, delta = (3 N / (4 E* sqrt(R)))^(2/3),
// as the normal displacement sensor reports it (level sample, so the plate
// displacement is the depth).
TEST(Reproduction, DepthFollowsHertzForTheFiftyMicronTip) {
  const v1::DaemonConfig config = default_config();
  const auto& n = config.sim().normal();
  for (double load : {1e-3, 5e-3, 10e-3}) {
    Protocol p;
    p.load_n = load;
    p.travel_m = 0;
    p.rest_s = 0.5;
    double depth = 0, normal = 0;
    int count = 0;
    testing::run_closed_loop(config, 1, 2.5,
                             [&](double t) { return LoopSetpoints{std::clamp((t - 1.5) / 0.5, 0.0, 1.0) * load, 2e-6}; },
                             [&](double t, const hal::SimTransducer& h) {
                               if (t < 2.0) return;
                               depth += h.instrument().measurement().normal_displacement_m;
                               normal += h.instrument().measurement().normal_force_n;
                               ++count;
                             });
    depth /= count;
    normal /= count;
    const double hertz = std::pow(3 * normal / (4 * n.reduced_modulus_pa() * std::sqrt(n.tip_radius_m())), 2.0 / 3.0);
    std::printf("  N = %.0f uN: depth %.2f nm, Hertz %.2f nm\n", normal * 1e6, depth * 1e9, hertz * 1e9);
    EXPECT_NEAR(depth, hertz, 0.005 * hertz + 0.1e-9);
  }
}

// §1, §4.4.1: with the dissertation's 10 Hz displacement feedback, scratches
// below ~0.1 um/s oscillate; the default 10 kHz loop does not. The 10 Hz
// loop is integral action only (ki = 500 N/(m s): ki dt / k = 0.4 in
// sliding; P or D at 10 Hz against this 54 Hz plant is unstable).
// Oscillation: the standard deviation of the (tilt-corrected) friction over
// the second half of a 20 s scratch, relative to the model's F_ss; and the
// tip's largest advance per 0.1 s relative to the commanded one (a slip).
//
// On plain LuGre (testing::plain_lugre_config): its Stribeck drop (mu 0.143 ->
// 0.0996 over 1.2 um/s) is what sticks and slips under the slow loop. The
// default contact's steady friction does not weaken with velocity (a - b > 0,
// flat as §4.4.3 measured) and it slides stably under the 10 Hz loop: the
// scorecard's stick_slip rows, docs/simulated_instrument.md.
TEST(Reproduction, SlowFeedbackOscillatesAtLowVelocityAndTheDefaultLoopDoesNot) {
  auto wobble = [](double loop_rate_hz, double v, double* slip) {
    v1::DaemonConfig config = testing::plain_lugre_config();
    config.mutable_controller()->set_loop_rate_hz(loop_rate_hz);
    if (loop_rate_hz < 100) {
      auto* g = config.mutable_controller()->mutable_lateral_displacement();
      g->set_kp(0);
      g->set_ki(500);
      g->set_kd(0);
      g->set_derivative_filter_hz(0);
    }
    Protocol p;
    p.load_n = 1e-3;
    p.velocity_m_per_s = v;
    p.travel_m = v * 20;
    const Trace tr = run(config, p);
    std::vector<double> friction(tr.force.size());
    for (std::size_t k = 0; k < friction.size(); ++k) friction[k] = tr.force[k] + tilt_tan(config) * tr.normal[k];
    const double mean = mean_over(tr, friction, 10, 20);
    std::vector<double> sq(friction.size());
    for (std::size_t k = 0; k < sq.size(); ++k) sq[k] = (friction[k] - mean) * (friction[k] - mean);
    const std::size_t per_100ms = static_cast<std::size_t>(std::lround(0.1 * loop_rate_hz));
    double advance = 0;
    for (std::size_t k = per_100ms; k < tr.t.size(); ++k) {
      if (tr.t[k] > 10) advance = std::max(advance, tr.position[k] - tr.position[k - per_100ms]);
    }
    *slip = advance / (0.1 * v);
    const double f_ss = steady_state_friction_n(instrument_params_from_config(config.sim()).friction.lugre,
                                                mean_over(tr, tr.normal, 10, 20), v);
    return std::sqrt(mean_over(tr, sq, 10, 20)) / f_ss;
  };
  double slow_low_slip = 0, slow_high_slip = 0, fast_low_slip = 0;
  const double slow_low = wobble(10, 0.05e-6, &slow_low_slip), slow_high = wobble(10, 0.5e-6, &slow_high_slip);
  const double fast_low = wobble(1e4, 0.05e-6, &fast_low_slip);
  std::printf("  10 Hz loop: friction wobble %.1f %% of F_ss at 0.05 um/s (largest advance %.1f x commanded per 0.1 s), "
              "%.1f %% at 0.5 um/s (%.1f x); 10 kHz loop: %.1f %% at 0.05 um/s (%.1f x)\n",
              100 * slow_low, slow_low_slip, 100 * slow_high, slow_high_slip, 100 * fast_low, fast_low_slip);
  // Measured: 27 % and 38x (stick-slip) against 7-8 % and 1.1-2.8x. The
  // default loop's 7 % at 0.05 um/s is no stick-slip (the tip never runs
  // ahead by more than 1.1x the commanded advance).
  EXPECT_GT(slow_low, 0.25) << "stick-slip under the slow loop";
  EXPECT_GT(slow_low_slip, 10.0);
  EXPECT_LT(slow_high, 0.15) << "above ~0.1 um/s the slow loop scratches";
  EXPECT_LT(slow_high_slip, 5.0);
  EXPECT_LT(fast_low, 0.15) << "the default loop holds 0.05 um/s";
  EXPECT_LT(fast_low_slip, 3.0);
}

}  // namespace
}  // namespace tribo::sim
