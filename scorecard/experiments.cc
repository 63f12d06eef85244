#include "scorecard/experiments.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <stdexcept>

#include "daemon/controller.h"
#include "hal/sim_transducer.h"
#include "sim/instrument_params.h"

namespace tribo::scorecard {

namespace {

constexpr double kStartM = 2e-6;
constexpr double kLoadAtS = 1.5, kLoadRampS = 0.5;

double tan_tilt(const v1::DaemonConfig& c) {
  const auto& t = c.sim().tip().tilt_offset();
  return t.enabled() ? std::tan(t.angle_deg() * std::numbers::pi / 180) : 0.0;
}

// The instrument and its controller in lock-step.
class LockStep {
 public:
  LockStep(const v1::DaemonConfig& config, std::uint64_t seed)
      : transducer_(sim::instrument_params_from_config(config.sim()), seed, config.controller().loop_rate_hz(),
                    false),
        controller_(daemon::controller_params_from_config(config.controller())) {}

  double dt_s() const { return transducer_.period_s(); }

  void step(double normal_force_n, double lateral_position_m) {
    daemon::Setpoints s;
    s.normal_force_n = normal_force_n;
    s.lateral_position_m = lateral_position_m;
    hal::SensorFrame frame;
    transducer_.read(frame);
    transducer_.write(controller_.step(s, frame).drive);
    transducer_.wait_next_tick();
  }

  const sim::Measurement& measured() const { return transducer_.instrument().measurement(); }
  const sim::InstrumentTruth& truth() const { return transducer_.instrument().truth(); }

 private:
  hal::SimTransducer transducer_;
  daemon::Controller controller_;
};

// Approach, settle, load to load_n, rest until rest_end_s (all unrecorded).
void prepare(LockStep& loop, double load_n, double rest_end_s) {
  const auto ticks = std::lround(rest_end_s / loop.dt_s());
  for (long k = 0; k < ticks; ++k) {
    const double t = static_cast<double>(k) * loop.dt_s();
    loop.step(std::clamp((t - kLoadAtS) / kLoadRampS, 0.0, 1.0) * load_n, kStartM * std::min(1.0, t / 0.3));
  }
}

double mean(const std::vector<double>& v, std::size_t from, std::size_t to) {
  return std::accumulate(v.begin() + static_cast<long>(from), v.begin() + static_cast<long>(to), 0.0) /
         static_cast<double>(to - from);
}

// RMS about the mean of each block of `block` samples.
double block_rms(const std::vector<double>& v, std::size_t block) {
  double ss = 0;
  std::size_t n = 0;
  for (std::size_t b = 0; b + block <= v.size(); b += block) {
    const double m = mean(v, b, b + block);
    for (std::size_t k = b; k < b + block; ++k) ss += (v[k] - m) * (v[k] - m);
    n += block;
  }
  return n > 0 ? std::sqrt(ss / static_cast<double>(n)) : 0.0;
}

}  // namespace

Breakaway run_breakaway(const v1::DaemonConfig& config, const BreakawayProtocol& p, std::uint64_t seed) {
  if (p.earlier_passes % 2 != 0) throw std::invalid_argument("run_breakaway: earlier_passes must be even");
  LockStep loop(config, seed);
  const double dt = loop.dt_s(), tilt = tan_tilt(config);
  const double move_s = std::min(p.travel_m / p.velocity_m_per_s, p.max_motion_s);
  const auto move_ticks = static_cast<std::size_t>(std::lround(move_s / dt));
  const auto before_ticks = std::lround(0.05 / dt);
  // The last rest ends with the 50 ms read before the onset.
  prepare(loop, p.load_n, kLoadAtS + kLoadRampS + p.rest_s - (p.earlier_passes > 0 ? 0.0 : 0.05));
  for (int pass = 0; pass < p.earlier_passes; ++pass) {
    const double from = pass % 2 == 0 ? kStartM : kStartM + p.velocity_m_per_s * move_s;
    const double direction = pass % 2 == 0 ? 1.0 : -1.0;
    for (std::size_t k = 0; k < move_ticks; ++k) {
      loop.step(p.load_n, from + direction * p.velocity_m_per_s * static_cast<double>(k + 1) * dt);
    }
    const bool last = pass + 1 == p.earlier_passes;
    const auto rest_ticks = std::lround(p.rest_s / dt) - (last ? before_ticks : 0);
    for (long k = 0; k < rest_ticks; ++k) loop.step(p.load_n, kStartM + (pass % 2 == 0 ? p.velocity_m_per_s * move_s : 0));
  }
  TransitionRecord r;
  r.dt_s = dt;
  r.velocity_m_per_s = p.velocity_m_per_s;
  r.force_noise_n = config.sim().sensors().lateral_force_noise_n();
  // 50 ms before the onset give the force and the position the motion starts from.
  for (long k = 0; k < before_ticks; ++k) {
    loop.step(p.load_n, kStartM);
    const sim::Measurement& m = loop.measured();
    r.force_before_n += m.lateral_force_n + m.normal_force_n * tilt;
    r.position_before_m += m.recorded_lateral_position_m();
    r.tip_position_before_m += loop.truth().lateral.position_m;
  }
  r.force_before_n /= static_cast<double>(before_ticks);
  r.position_before_m /= static_cast<double>(before_ticks);
  r.tip_position_before_m /= static_cast<double>(before_ticks);
  r.force_n.resize(move_ticks);
  r.position_m.resize(move_ticks);
  r.setpoint_m.resize(move_ticks);
  r.tip_position_m.resize(move_ticks);
  for (std::size_t k = 0; k < move_ticks; ++k) {
    const double setpoint = kStartM + p.velocity_m_per_s * static_cast<double>(k + 1) * dt;
    loop.step(p.load_n, setpoint);
    const sim::Measurement& m = loop.measured();
    r.force_n[k] = m.lateral_force_n + m.normal_force_n * tilt;
    // The position as the instrument records it (with its readout noise).
    r.position_m[k] = m.recorded_lateral_position_m();
    r.setpoint_m[k] = setpoint;
    r.tip_position_m[k] = loop.truth().lateral.position_m;
  }
  return measure_transition(r);
}

Passes run_passes(const v1::DaemonConfig& config, double load_n, double velocity, std::uint64_t seed) {
  // 10 um passes with a 1 s hold between them, averaged over the last 30 %
  // of each pass (the I-PD loop settles within ~0.2 s).
  LockStep loop(config, seed);
  const double go_s = kLoadAtS + kLoadRampS + 0.5, travel = 10e-6, pass_s = travel / velocity, hold_s = 1.0;
  prepare(loop, load_n, go_s);
  const double dt = loop.dt_s();
  double fwd = 0, bwd = 0, load = 0;
  long nf = 0, nb = 0;
  const auto ticks = std::lround((2 * pass_s + hold_s) / dt);
  for (long k = 0; k < ticks; ++k) {
    const double s = static_cast<double>(k + 1) * dt;
    double x = kStartM + velocity * std::min(s, pass_s);
    if (s > pass_s + hold_s) x -= velocity * std::min(s - pass_s - hold_s, pass_s);
    loop.step(load_n, x);
    const sim::Measurement& m = loop.measured();
    if (s > 0.7 * pass_s && s <= pass_s) {
      fwd += m.lateral_force_n;
      load += m.normal_force_n;
      ++nf;
    } else if (s > pass_s + hold_s + 0.7 * pass_s) {
      bwd += m.lateral_force_n;
      load += m.normal_force_n;
      ++nb;
    }
  }
  fwd /= static_cast<double>(nf);
  bwd /= static_cast<double>(nb);
  return Passes{load / static_cast<double>(nf + nb), 0.5 * (fwd - bwd), 0.5 * (fwd + bwd),
                loop.truth().normal.depth_m};
}

double held_force_drift_n(const v1::DaemonConfig& config, double load_n, double hold_s, std::uint64_t seed) {
  LockStep loop(config, seed);
  prepare(loop, load_n, kLoadAtS + kLoadRampS + 20.0);
  const auto per_second = std::lround(1.0 / loop.dt_s());
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (long s = 0; s < std::lround(hold_s); ++s) {
    double sum = 0;
    for (long k = 0; k < per_second; ++k) {
      loop.step(load_n, kStartM);
      sum += loop.measured().lateral_force_n;
    }
    lo = std::min(lo, sum / static_cast<double>(per_second));
    hi = std::max(hi, sum / static_cast<double>(per_second));
  }
  return hi - lo;
}

NoiseFloors noise_at_rest(const v1::DaemonConfig& config, double load_n, double hold_s, std::uint64_t seed) {
  LockStep loop(config, seed);
  prepare(loop, load_n, kLoadAtS + kLoadRampS + 2.0);
  std::vector<double> x, f, n, z;
  for (long k = 0; k < std::lround(hold_s / loop.dt_s()); ++k) {
    loop.step(load_n, kStartM);
    const sim::Measurement& m = loop.measured();
    x.push_back(m.recorded_lateral_position_m());
    f.push_back(m.lateral_force_n);
    n.push_back(m.normal_force_n);
    z.push_back(m.normal_displacement_m);
  }
  const auto block = static_cast<std::size_t>(std::max<long>(1, std::lround(0.1 / loop.dt_s())));
  return NoiseFloors{block_rms(x, block), block_rms(f, block), block_rms(n, block), block_rms(z, block)};
}

v1::DaemonConfig stick_slip_config(const v1::DaemonConfig& config, double loop_rate_hz) {
  v1::DaemonConfig c = config;
  c.mutable_controller()->set_loop_rate_hz(loop_rate_hz);
  if (loop_rate_hz < 100) {
    auto* g = c.mutable_controller()->mutable_lateral_displacement();
    g->set_kp(0);
    g->set_ki(500);
    g->set_kd(0);
    g->set_derivative_filter_hz(0);
  }
  return c;
}

double stick_slip_advance_ratio(const std::vector<double>& x, double velocity, double dt) {
  const auto ticks = static_cast<long>(x.size()), per_100ms = std::max<long>(1, std::lround(0.1 / dt));
  double advance = 0;
  for (long k = std::max(ticks / 2, per_100ms); k < ticks; ++k) advance = std::max(advance, x[k] - x[k - per_100ms]);
  return advance / (velocity * static_cast<double>(per_100ms) * dt);
}

double stick_slip_ratio(const v1::DaemonConfig& config, double loop_rate_hz, double velocity, std::uint64_t seed) {
  constexpr double kLoadN = 1e-3, kScratchS = 20.0;
  LockStep loop(stick_slip_config(config, loop_rate_hz), seed);
  const double go_s = kLoadAtS + kLoadRampS + 2.0, dt = loop.dt_s();
  prepare(loop, kLoadN, go_s);
  const auto ticks = std::lround(kScratchS / dt);
  std::vector<double> x;
  for (long k = 0; k < ticks; ++k) {
    loop.step(kLoadN, kStartM + velocity * static_cast<double>(k + 1) * dt);
    x.push_back(loop.truth().lateral.position_m);
  }
  return stick_slip_advance_ratio(x, velocity, dt);
}

double steady_friction_n(const v1::DaemonConfig& config, double load_n, double velocity, std::uint64_t seed) {
  BreakawayProtocol p;
  p.load_n = load_n;
  p.velocity_m_per_s = velocity;
  p.travel_m = 10e-6;
  p.max_motion_s = 8.0;
  return run_breakaway(config, p, seed).steady_n;
}

}  // namespace tribo::scorecard
