#include "tests/analysis/synthetic_run.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

namespace tribo::testing {

namespace {

// Friction of the "true" contact: LuGre (exponential Stribeck), Amontons in N.
constexpr double kMuCoulomb = 0.10;
constexpr double kMuStatic = 0.143;
constexpr double kStribeckVelocity = 1.2e-6;
constexpr double kSigma0 = 3414.6;   // N/m
constexpr double kSigma1 = 5.5;      // N s/m
constexpr double kViscous = 0.5;     // N s/m (16 µN at 32 µm/s)
constexpr double kRamp_s = 0.05;     // velocity changes take 50 ms (raised cosine)
constexpr int kSubsteps = 8;

struct Segment {
  double duration_s;
  double speed_m_per_s;  // signed; 0: hold
  double normal_end_n;
};

std::vector<Segment> protocol(bool three_loads, int extra_loads) {
  std::vector<Segment> segs;
  const double speeds[] = {0.5e-6, 2e-6, 8e-6, 32e-6};
  // Dwell times alternate long and short within each direction, so that
  // dwell is not confounded with direction or speed.
  const double dwells[] = {0.25, 4.0, 8.0, 0.3, 1.0, 6.0, 2.0, 0.5};
  const double travel = 6e-6;
  std::vector<double> loads = three_loads ? std::vector<double>{1e-3, 0.5e-3, 2e-3} : std::vector<double>{1e-3};
  const double more[] = {1.5e-3, 0.75e-3, 1.25e-3, 1.75e-3};
  for (int k = 0; k < extra_loads; ++k) loads.push_back(more[k % 4]);
  segs.push_back({1.0, 0.0, 0.0});  // unloaded at rest
  int k = 0;
  for (double load : loads) {
    segs.push_back({2.0, 0.0, load});  // loading ramp at rest
    for (int cycle = 0; cycle < 4; ++cycle) {
      for (int dir : {+1, -1}) {
        segs.push_back({dwells[k++ % 8], 0.0, load});
        const double v = speeds[cycle];
        segs.push_back({travel / v, dir * v, load});
      }
    }
  }
  segs.push_back({1.0, 0.0, 0.0});  // unloading ramp at rest
  return segs;
}

// Velocity profile with smooth 50 ms transitions between segment speeds, as a
// closed loop would move the tip.
struct Motion {
  std::vector<double> start_s, speed, normal_start, normal_end, duration;
  double velocity(double t) const {
    const std::size_t k = segment(t);
    const double v = speed[k];
    const double prev = k > 0 ? speed[k - 1] : 0.0;
    const double into = t - start_s[k];
    if (into >= kRamp_s) return v;
    return prev + (v - prev) * 0.5 * (1 - std::cos(std::numbers::pi * into / kRamp_s));
  }
  double normal(double t) const {
    const std::size_t k = segment(t);
    const double f = std::clamp((t - start_s[k]) / duration[k], 0.0, 1.0);
    return normal_start[k] + (normal_end[k] - normal_start[k]) * f;
  }
  std::size_t segment(double t) const {
    auto it = std::upper_bound(start_s.begin(), start_s.end(), t);
    return static_cast<std::size_t>(std::max<std::ptrdiff_t>(0, it - start_s.begin() - 1));
  }
  double end_s() const { return start_s.back() + duration.back(); }
};

Motion build_motion(const std::vector<Segment>& segs) {
  Motion m;
  double t = 0, n = 0;
  for (const Segment& s : segs) {
    m.start_s.push_back(t);
    m.speed.push_back(s.speed_m_per_s);
    m.normal_start.push_back(n);
    m.normal_end.push_back(s.normal_end_n);
    m.duration.push_back(s.duration_s);
    t += s.duration_s;
    n = s.normal_end_n;
  }
  return m;
}

struct State {
  double x = 2e-6;       // actuator (tip) position
  double z = 0;          // bristle
  double v_lagged = 0;   // velocity seen by the Stribeck curve
  double play = 2e-6;    // backlash: centre of the gap
  bool engaged = true;
  double age_s = 1.0;    // contact age (dwell stiction)
};

class Truth {
 public:
  Truth(const SyntheticEffects& e, const Motion& m) : e_(e), m_(m) {}

  // age_s: the contact age (Dieterich ageing, State::age_s).
  double friction_level(double speed_for_stribeck, double normal, double x, double sign, double age_s) const {
    if (normal <= 0) return 0.0;
    double mu_s = kMuStatic;
    if (e_.dwell_gain > 0) mu_s *= 1 + e_.dwell_gain * age_s / (age_s + e_.dwell_time_s);
    double mu = kMuCoulomb + (mu_s - kMuCoulomb) * std::exp(-speed_for_stribeck / kStribeckVelocity);
    if (e_.log_velocity != 0) mu *= 1 + e_.log_velocity * std::log(std::max(speed_for_stribeck, 1e-9) / 1e-6);
    if (e_.periodic_amplitude != 0) mu *= 1 + e_.periodic_amplitude * std::sin(2 * std::numbers::pi * x / e_.periodic_length_m);
    if (e_.asymmetry != 0) mu *= 1 + e_.asymmetry * sign;
    const double effective_normal = e_.load_exponent != 0 ? normal * std::pow(normal / 1e-3, e_.load_exponent) : normal;
    return mu * effective_normal;
  }

  static double alpha(double r, double v, double z, double g) {
    if (r <= 0) return 1.0;
    if ((z > 0) != (v > 0) || z == 0) return 0.0;
    const double a = std::fabs(z);
    if (a <= r * g) return 0.0;
    if (a >= g) return 1.0;
    return 0.5 + 0.5 * std::sin(std::numbers::pi * (a - 0.5 * (1 + r) * g) / ((1 - r) * g));
  }

  // Bristle rate and friction at drive velocity v.
  void rates(const State& s, double t, double v, double& dz, double& dvl, double& force) const {
    const double normal = m_.normal(t);
    const double stribeck_speed = e_.lag_time_s > 0 ? std::fabs(s.v_lagged) : std::fabs(v);
    dvl = e_.lag_time_s > 0 ? (v - s.v_lagged) / e_.lag_time_s : 0.0;
    const double level = friction_level(stribeck_speed, normal, s.x, v >= 0 ? 1.0 : -1.0, s.age_s);
    if (level <= 0) {
      dz = -s.z / 1e-3;
      force = 0;
      return;
    }
    const double g = level / kSigma0;
    dz = v - alpha(e_.breakaway_ratio, v, s.z, g) * std::fabs(v) * s.z / g;
    force = kSigma0 * s.z + kSigma1 * dz + (kViscous + e_.extra_viscous_n_s_per_m) * v;
  }

  // Advances the state over [t, t + h] in RK4 substeps; returns the friction at the end.
  double step(State& s, double t, double h) const {
    const double dt = h / kSubsteps;
    double force = 0;
    for (int k = 0; k < kSubsteps; ++k) {
      const double t0 = t + k * dt;
      const double v0 = m_.velocity(t0), vh = m_.velocity(t0 + 0.5 * dt), v1 = m_.velocity(t0 + dt);
      // Contact age, d age/dt = 1 - |v| age / D_c, exactly at the mid-step
      // speed and held over the substep.
      const double speed = std::fabs(vh);
      if (speed < 1e-12) {
        s.age_s += dt;
      } else {
        const double steady = e_.dwell_memory_m / speed;
        s.age_s = steady + (s.age_s - steady) * std::exp(-speed * dt / e_.dwell_memory_m);
      }
      const double x_next = s.x + dt * (v0 + 4 * vh + v1) / 6;
      double vp0 = v0, vph = vh, vp1 = v1;
      if (e_.backlash_gap_m > 0) {
        // Play operator: the element moves only when the gap is closed.
        const double half = 0.5 * e_.backlash_gap_m;
        const double play_next = std::clamp(s.play, x_next - half, x_next + half);
        const double vp = (play_next - s.play) / dt;
        s.engaged = play_next != s.play || std::fabs(std::fabs(x_next - play_next) - half) < 1e-15;
        s.play = play_next;
        vp0 = vph = vp1 = vp;
        if (!s.engaged) {
          s.z *= std::exp(-dt / 1e-3);  // unloaded element relaxes
          s.x = x_next;
          force = 0;
          continue;
        }
      }
      auto f = [&](const State& st, double tt, double v, double& dz, double& dvl) {
        double fo = 0;
        rates(st, tt, v, dz, dvl, fo);
        return fo;
      };
      double k1z, k1l, k2z, k2l, k3z, k3l, k4z, k4l;
      f(s, t0, vp0, k1z, k1l);
      State s2 = s;
      s2.z += 0.5 * dt * k1z;
      s2.v_lagged += 0.5 * dt * k1l;
      f(s2, t0 + 0.5 * dt, vph, k2z, k2l);
      State s3 = s;
      s3.z += 0.5 * dt * k2z;
      s3.v_lagged += 0.5 * dt * k2l;
      f(s3, t0 + 0.5 * dt, vph, k3z, k3l);
      State s4 = s;
      s4.z += dt * k3z;
      s4.v_lagged += dt * k3l;
      f(s4, t0 + dt, vp1, k4z, k4l);
      s.z += dt * (k1z + 2 * k2z + 2 * k3z + k4z) / 6;
      s.v_lagged += dt * (k1l + 2 * k2l + 2 * k3l + k4l) / 6;
      s.x = x_next;
      double dz, dvl;
      force = f(s, t0 + dt, vp1, dz, dvl);
    }
    return force;
  }

 private:
  const SyntheticEffects& e_;
  const Motion& m_;
};

}  // namespace

analysis::MeasuredSeries synthetic_run(const SyntheticEffects& effects, std::uint64_t seed, const SyntheticOptions& options) {
  const Motion motion = build_motion(protocol(options.three_loads, options.extra_loads));
  const Truth truth(effects, motion);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);

  analysis::MeasuredSeries s;
  s.source = "synthetic";
  const double h = 1.0 / options.rate_hz;
  const auto n = static_cast<std::size_t>(motion.end_s() / h);
  State state;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * h;
    const double friction = k == 0 ? 0.0 : truth.step(state, t - h, h);
    const double normal = motion.normal(t);
    double lateral = friction + effects.tilt_tan * normal;
    if (effects.drift_n_per_s != 0) {
      lateral += effects.drift_n_per_s * (t + 20.0 * std::sin(2 * std::numbers::pi * t / 60.0));
    }
    s.time_s.push_back(t);
    s.position_m.push_back(state.x + options.position_noise_m * unit(rng));
    s.force_n.push_back(lateral + options.force_noise_n * unit(rng));
    s.normal_force_n.push_back(normal + 0.1e-6 * unit(rng));
  }
  return s;
}

analysis::MeasuredSeries single_load_run(std::uint64_t seed) {
  SyntheticOptions options;
  options.three_loads = false;
  analysis::MeasuredSeries s = synthetic_run({}, seed, options);
  analysis::derive_motion(s, 0);
  return s;
}

}  // namespace tribo::testing
