#include "analysis/models/friction_model.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "analysis/models/autodiff.h"

namespace tribo::analysis {

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

double sign_of(double v) { return v >= 0 ? 1.0 : -1.0; }

// The parameter value for theta; a log-parameter's theta is capped at +-40 so
// that a wild trial step cannot overflow (the derivative is kept).
template <class T>
T transform(const ParamSpec& spec, const T& theta) {
  using std::exp;
  switch (spec.transform) {
    case Transform::kLog: {
      T t = theta;
      const double v = value_of(t);
      if (v > 40) t = t - (v - 40);
      if (v < -40) t = t - (v + 40);
      return spec.scale * exp(t);
    }
    case Transform::kLinear: return spec.scale * theta;
    case Transform::kLogit: return 1.0 / (1.0 + exp(-theta));
  }
  return theta;
}

std::string force_unit_of(const ModelData& d) { return d.series.force_unit; }

// Unit of a friction level: force units, or none for coefficients of N.
std::string level_unit(const ModelData& d, const ModelStructure& st) {
  return st.load_scaled ? "1" : force_unit_of(d);
}

double level_scale(const ModelData& d, const ModelStructure& st) {
  return st.load_scaled ? d.mu_scale : d.force_scale;
}

struct Index {
  int fc = -1, fs = -1, vs = -1, sigma0 = -1, sigma1 = -1, fv = -1, offset = -1, mass = -1;
  int dwell_dfs = -1, dwell_time = -1, dwell_memory = -1, lag = -1, logv = -1, load_exponent = -1;
  int per_cos = -1, per_sin = -1, per_length = -1, asym_levels = -1, asym_viscous = -1;
  int tilt = -1, breakaway = -1, gap = -1;
  int rs_a = -1, rs_b = -1, rs_dc = -1, slip_trend = -1, dither = -1;
  std::vector<int> drift;
};

Index index_of(const ModelParams& p) {
  Index k;
  const bool mu = p.structure.load_scaled;
  k.fc = p.index(mu ? "mu_c" : "Fc");
  k.fs = p.index(mu ? "mu_s" : "Fs");
  k.vs = p.index("vs");
  k.sigma0 = p.index("sigma0");
  k.sigma1 = p.index("sigma1");
  k.fv = p.index("Fv");
  k.offset = p.index("offset");
  k.mass = p.index("mass");
  k.dwell_dfs = p.index("dwell_dFs");
  k.dwell_time = p.index("dwell_time");
  k.dwell_memory = p.index("dwell_memory");
  k.lag = p.index("lag_time");
  k.logv = p.index("log_velocity_coeff");
  k.load_exponent = p.index("load_exponent");
  k.per_cos = p.index("periodic_cos");
  k.per_sin = p.index("periodic_sin");
  k.per_length = p.index("periodic_length");
  k.asym_levels = p.index("asym_levels");
  k.asym_viscous = p.index("asym_viscous");
  k.tilt = p.index("tilt_tan");
  for (int j = 1; p.index("drift_" + std::to_string(j)) >= 0; ++j) k.drift.push_back(p.index("drift_" + std::to_string(j)));
  k.breakaway = p.index("breakaway_ratio");
  k.gap = p.index("backlash_gap");
  k.rs_a = p.index("rs_a");
  k.rs_b = p.index("rs_b");
  k.rs_dc = p.index("rs_dc");
  k.slip_trend = p.index("slip_trend");
  k.dither = p.index("dither_speed");
  if (k.fc < 0 || k.fs < 0 || k.vs < 0 || k.sigma0 < 0 || k.sigma1 < 0 || k.fv < 0 || k.offset < 0) {
    throw std::logic_error("friction model: base parameters missing");
  }
  return k;
}

// Elasto-plastic alpha(z, v) (Dupont et al. 2002; as in sim/lugre_friction.h).
template <class T>
T plasticity(const T& r, double v, const T& z, const T& g) {
  using std::sin;
  const double zv = value_of(z);
  if ((zv > 0) != (v > 0) || zv == 0) return T(0.0);
  const T zabs = zv > 0 ? z : T(-z);
  if (value_of(zabs) <= value_of(r * g)) return T(0.0);
  if (value_of(zabs) >= value_of(g)) return T(1.0);
  return 0.5 + 0.5 * sin(std::numbers::pi * (zabs - 0.5 * (1.0 + r) * g) / ((1.0 - r) * g));
}

// z after h at constant v: dz/dt = v - a z with a = alpha |v| / g, exactly.
// H: double for a fixed interval, T for one that depends on the parameters
// (backlash); a double skips the derivatives of a constant, whose terms are
// zero (the values and the non-zero derivatives are the same, bit for bit).
template <class T, class H>
T bristle_step(const T& z, double v, const H& h, const T& alpha_over_g) {
  using std::exp;
  const T a = std::fabs(v) * alpha_over_g;
  const T u = a * h;
  if (value_of(u) < 1e-9) return z + v * h;
  const T e = exp(-u);
  return z * e + v * (1.0 - e) / a;
}

// z after h at constant v when the bristle relaxes at a speed other than
// |v| (the unresolved dither's E|v + d|): dz/dt = v - a z, a = speed alpha / g.
template <class T>
T bristle_step_at_speed(const T& z, double v, double h, const T& speed, const T& alpha_over_g) {
  using std::exp;
  const T a = speed * alpha_over_g;
  const T u = a * h;
  if (value_of(u) < 1e-9) return z + v * h;
  const T e = exp(-u);
  return z * e + v * (1.0 - e) / a;
}

template <class T>
T erf_of(const T& x) {
  if constexpr (std::is_same_v<T, double>) {
    return std::erf(x);
  } else {
    const double xv = x.value();
    return T(std::erf(xv), typename T::DerType(x.derivatives() * (2.0 / std::sqrt(std::numbers::pi) * std::exp(-xv * xv))));
  }
}

// E|v + d| for d ~ N(0, rms^2): rms sqrt(2/pi) exp(-v^2 / 2 rms^2) + v erf(v / (rms sqrt 2)).
template <class T>
T dithered_speed(double v, const T& rms) {
  using std::exp;
  const T r = v / (std::numbers::sqrt2 * rms);
  return std::sqrt(2.0 / std::numbers::pi) * rms * exp(-(r * r)) + v * erf_of(r);
}

}  // namespace

double param_value(const ParamSpec& spec, double theta) { return transform(spec, theta); }

namespace {

// b[0, intervals + 3): the uniform cubic B-splines at u (zero but four,
// from the index returned).
int cubic_bspline_basis_into(double u, int intervals, double* b) {
  std::fill(b, b + intervals + 3, 0.0);
  const double x = std::clamp(u, 0.0, 1.0) * intervals;
  const int k = std::min(static_cast<int>(x), intervals - 1);
  const double t = x - k;
  // The four non-zero uniform cubic B-splines on interval k.
  b[k] = (1 - t) * (1 - t) * (1 - t) / 6;
  b[k + 1] = (3 * t * t * t - 6 * t * t + 4) / 6;
  b[k + 2] = (-3 * t * t * t + 3 * t * t + 3 * t + 1) / 6;
  b[k + 3] = t * t * t / 6;
  return k;
}

// The drift spline's knots: at quantiles of the fitted samples' times (the
// sliding samples that are not held out), so that each knot interval holds
// the same share of the data the fit sees, as regression splines place
// their knots. Uniform knots in time left an interval with a quarter of a
// second of fitted sliding (the fast passes between long holds and
// held-out slow passes), whose coefficients then swung by a millinewton
// across the holds (an independent generator's drift files). Uniform knots
// are kept when the fit set has fewer than 4 samples per interval.
std::vector<double> drift_knots(const MeasuredSeries& s, const MotionSegmentation& m,
                                const std::vector<char>& at_rest, int intervals) {
  std::vector<double> fitted;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (!at_rest[i] && !m.heldout[i] && m.direction[i] != 0) fitted.push_back(s.time_s[i]);
  }
  const double t0 = s.time_s.front(), t1 = std::max(s.time_s.back(), t0 + 1e-30);
  const bool quantiles = fitted.size() >= 4 * static_cast<std::size_t>(intervals);
  std::vector<double> knots{t0};
  for (int k = 1; k < intervals; ++k) {
    knots.push_back(quantiles ? fitted[fitted.size() * static_cast<std::size_t>(k) / static_cast<std::size_t>(intervals)]
                              : t0 + (t1 - t0) * k / intervals);
  }
  knots.push_back(t1);
  return knots;
}

// Drift functions: at most 12 knot intervals (ModelData).
constexpr int kMaxDriftFunctions = 15;

}  // namespace

std::vector<double> cubic_bspline_basis(double u, int intervals) {
  std::vector<double> b(static_cast<std::size_t>(intervals + 3), 0.0);
  cubic_bspline_basis_into(u, intervals, b.data());
  return b;
}

int ModelData::drift_basis_at(std::size_t i, double* out) const {
  return cubic_bspline_basis_into(drift_spline_coordinate(series.time_s[i]), drift_functions - 3, out);
}

double ModelData::drift_spline_coordinate(double time_s) const {
  const auto& k = drift_knot_time_s;
  const auto it = std::upper_bound(k.begin() + 1, k.end() - 1, time_s);
  const auto j = static_cast<std::size_t>(it - k.begin()) - 1;
  const double u = (time_s - k[j]) / std::max(k[j + 1] - k[j], 1e-300);
  return (static_cast<double>(j) + std::clamp(u, 0.0, 1.0)) / static_cast<double>(k.size() - 1);
}

void ModelData::set_drift_intervals(int intervals) {
  const int n = std::clamp(intervals, 3, kMaxDriftFunctions - 3);
  drift_functions = n + 3;
  drift_knot_time_s = drift_knots(series, motion, at_rest, n);
}

double param_theta(const ParamSpec& spec, double value) {
  switch (spec.transform) {
    case Transform::kLog: return std::log(value / spec.scale);
    case Transform::kLinear: return value / spec.scale;
    case Transform::kLogit: return std::log(value / (1.0 - value));
  }
  return value;
}

bool ModelStructure::has(Effect e) const { return std::find(effects.begin(), effects.end(), e) != effects.end(); }

int ModelParams::index(std::string_view name) const {
  for (std::size_t i = 0; i < specs.size(); ++i) {
    if (specs[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

double ModelParams::value(std::string_view name) const {
  const int k = index(name);
  if (k < 0) throw std::logic_error("no model parameter " + std::string(name));
  return param_value(specs[static_cast<std::size_t>(k)], theta[static_cast<std::size_t>(k)]);
}

void ModelParams::set_value(std::string_view name, double value) {
  const int k = index(name);
  if (k < 0) throw std::logic_error("no model parameter " + std::string(name));
  ParamSpec& spec = specs[static_cast<std::size_t>(k)];
  // Keep theta of order one: a log parameter's scale becomes the value (theta
  // 0), a signed one's scale grows to the value's magnitude.
  if (spec.transform == Transform::kLog) spec.scale = value;
  if (spec.transform == Transform::kLinear && std::fabs(value) > spec.scale) spec.scale = std::fabs(value);
  theta[static_cast<std::size_t>(k)] = param_theta(spec, value);
}

std::size_t ModelParams::free_count() const {
  return static_cast<std::size_t>(std::count_if(specs.begin(), specs.end(), [](const ParamSpec& s) { return !s.fixed; }));
}

namespace {

std::shared_ptr<const DriveArrays> drive_arrays(const MeasuredSeries& s, const MotionSegmentation& m) {
  const std::size_t n = s.size();
  // At rest the measured velocity is sensor noise; fed to LuGre, its |v|
  // term would drain the bristle (the dither effect of docs/physics_and_sources.md "The simulated
  // instrument") although the contact does not move. The model is therefore
  // driven at zero velocity while the tip rests: inside each hold, from the
  // first to the last sample within four position-noise widths of the resting
  // position (the hold's edges, found on smoothed speed, can hold the end and
  // the start of motion). The width is the record's noise floor as well: a
  // smoothed position carries almost no white noise, and a band of its width
  // held nothing (the model's state then ran through every hold on the
  // smoother's velocity, 178 -> -8 µN over one hold of the independent
  // generator's rate_state seed-3 file).
  DriveArrays a;
  std::vector<double>& drive_velocity = a.drive_velocity;
  drive_velocity = s.velocity_m_per_s;
  const double band = 4 * std::max({m.position_noise_m, s.position_noise_m, 1e-300});
  std::vector<char>& at_rest = a.at_rest;
  at_rest.assign(n, 0);
  for (const Hold& h : m.holds) {
    for (std::size_t i = h.first; i <= h.last; ++i) at_rest[i] = 1;
  }
  for (const Hold& h : m.holds) {
    std::vector<double> xs(s.position_m.begin() + static_cast<std::ptrdiff_t>(h.first),
                           s.position_m.begin() + static_cast<std::ptrdiff_t>(h.last) + 1);
    const double rest = median(xs);
    std::size_t first = h.first, last = h.last;
    while (first < last && std::fabs(s.position_m[first] - rest) > band) ++first;
    while (last > first && std::fabs(s.position_m[last] - rest) > band) --last;
    for (std::size_t i = first; i <= last; ++i) drive_velocity[i] = 0.0;
  }
  // The mean velocity over each sample interval: the position increment when
  // the velocity was derived from the position (central differences smear a
  // motion onset half a sample early), else the mean of the measured ends.
  std::vector<double>& step_velocity = a.step_velocity;
  step_velocity.assign(n, 0.0);
  for (std::size_t i = 1; i < n; ++i) {
    if (drive_velocity[i - 1] == 0.0 && drive_velocity[i] == 0.0) continue;
    step_velocity[i] = s.velocity_measured ? 0.5 * (drive_velocity[i - 1] + drive_velocity[i])
                                           : (s.position_m[i] - s.position_m[i - 1]) / (s.time_s[i] - s.time_s[i - 1]);
  }
  // Only where a slip trend may be fitted (one way only): on other records it
  // would cost eight bytes a sample for nothing.
  if (slides_one_way(m)) {
    a.slip_m.assign(n, 0.0);
    for (std::size_t i = 1; i < n; ++i) {
      a.slip_m[i] = a.slip_m[i - 1] + std::fabs(step_velocity[i]) * (s.time_s[i] - s.time_s[i - 1]);
    }
  }
  return std::make_shared<const DriveArrays>(std::move(a));
}

}  // namespace

ModelData::ModelData(const MeasuredSeries& s, const MotionSegmentation& m)
    : series(s),
      motion(m),
      fitted_force(&s.force_n),
      arrays_(drive_arrays(s, m)),
      drive_velocity(arrays_->drive_velocity),
      at_rest(arrays_->at_rest),
      step_velocity(arrays_->step_velocity),
      slip_m(arrays_->slip_m) {
  const std::size_t n = s.size();
  time_start_s_ = s.time_s.front();
  time_span_s_ = std::max(s.time_s.back() - time_start_s_, 1e-30);
  std::vector<double> force, speed, accel, normal;
  for (std::size_t i = 0; i < n; ++i) {
    if (m.pass_of[i] < 0) continue;
    force.push_back(std::fabs(s.force_n[i]));
    speed.push_back(std::fabs(s.velocity_m_per_s[i]));
    accel.push_back(std::fabs(s.acceleration_m_per_s2.empty() ? 0.0 : s.acceleration_m_per_s2[i]));
  }
  if (force.empty()) {
    for (std::size_t i = 0; i < n; ++i) force.push_back(std::fabs(s.force_n[i]));
  }
  force_scale = std::max(median(force), 1e-30);
  speed_ref = std::max(median(speed), 1e-30);
  speed_floor = 0.01 * speed_ref;
  mass_scale = force_scale / std::max(median(accel), 1e-30);
  if (s.has_normal()) {
    const double nmax = *std::max_element(s.normal_force_n.begin(), s.normal_force_n.end());
    std::vector<double> mu;
    for (std::size_t i = 0; i < n; ++i) {
      if (s.normal_force_n[i] > 0.05 * nmax) {
        normal.push_back(s.normal_force_n[i]);
        if (m.pass_of[i] >= 0) mu.push_back(std::fabs(s.force_n[i]) / s.normal_force_n[i]);
      }
    }
    normal_ref = std::max(median(normal), 1e-30);
    mu_scale = std::max(median(mu), 1e-12);
  }
  set_drift_intervals(static_cast<int>(m.passes.size()) / 2);
}

ModelParams base_params(const ModelData& d, const ModelStructure& st) {
  ModelParams p;
  p.structure = st;
  const std::string lu = level_unit(d, st), fu = force_unit_of(d);
  const double level = level_scale(d, st);
  const double range = [&] {
    const auto [lo, hi] = std::minmax_element(d.series.position_m.begin(), d.series.position_m.end());
    return std::max(*hi - *lo, 1e-12);
  }();
  const double force_per_speed = d.force_scale / d.speed_ref;
  p.specs = {
      {st.load_scaled ? "mu_c" : "Fc", lu, Transform::kLog, level, false, {}},
      {st.load_scaled ? "mu_s" : "Fs", lu, Transform::kLog, 1.2 * level, false, {}},
      {"vs", "m/s", Transform::kLog, 0.2 * d.speed_ref, false, {}},
      {"sigma0", fu + "/m", Transform::kLog, d.force_scale / (1e-3 * range), false, {}},
      {"sigma1", fu + " s/m", Transform::kLog, force_per_speed, false, {}},
      {"Fv", fu + " s/m", Transform::kLinear, 0.1 * force_per_speed, false, {}},
      {"offset", fu, Transform::kLinear, 0.1 * d.force_scale, false, {}},
  };
  p.theta = {0, 0, 0, 0, std::log(0.01), 0, 0};
  if (st.unresolved_dither) {
    p.specs.push_back({"dither_speed", "m/s", Transform::kLog, 0.1 * d.speed_ref, false, {}});
    p.theta.push_back(0.0);
  }
  if (st.fit_mass) {
    p.specs.push_back({"mass", fu == "N" ? "kg" : fu + " s^2/m", Transform::kLinear, d.mass_scale, false, {}});
    p.theta.push_back(0.0);
  }
  return p;
}

std::vector<ParamSpec> effect_parameters(Effect e, const ModelData& d, const ModelStructure& st) {
  const std::string lu = level_unit(d, st), fu = force_unit_of(d);
  const double level = level_scale(d, st);
  switch (e) {
    case Effect::kDwellStiction:
      return {{"dwell_dFs", lu, Transform::kLinear, 0.2 * level, false, e},
              {"dwell_time", "s", Transform::kLog, 1.0, false, e},
              {"dwell_memory", "m", Transform::kLog, 1e-6, false, e}};
    case Effect::kFrictionalLag:
      return {{"lag_time", "s", Transform::kLog, 5e-3, false, e}};
    case Effect::kVelocityStrengthening:
      return {{"log_velocity_coeff", lu, Transform::kLinear, 0.02 * level, false, e}};
    case Effect::kLoadDependence:
      return {{"load_exponent", "1", Transform::kLinear, 0.1, false, e}};
    case Effect::kPositionPeriodic: {
      const std::string amp_unit = st.periodic_additive ? fu : "1";
      const double amp_scale = st.periodic_additive ? 0.05 * d.force_scale : 0.05;
      return {{"periodic_cos", amp_unit, Transform::kLinear, amp_scale, false, e},
              {"periodic_sin", amp_unit, Transform::kLinear, amp_scale, false, e},
              {"periodic_length", "m", Transform::kLog, 1e-6, false, e}};
    }
    case Effect::kDirectionAsymmetry:
      return {{"asym_levels", "1", Transform::kLinear, 0.1, false, e},
              {"asym_viscous", "1", Transform::kLinear, 0.1, false, e}};
    case Effect::kTiltOffset:
      return {{"tilt_tan", "1", Transform::kLinear, 0.01, false, e}};
    case Effect::kDrift:
    {
      std::vector<ParamSpec> specs;
      for (int j = 0; j < d.drift_functions; ++j) {
        specs.push_back({"drift_" + std::to_string(j + 1), fu, Transform::kLinear, 0.05 * d.force_scale, false, e});
      }
      return specs;
    }
    case Effect::kPreslidingHysteresis:
      return {{"breakaway_ratio", "1", Transform::kLogit, 1.0, false, e}};
    case Effect::kBacklash:
      return {{"backlash_gap", "m", Transform::kLog, 1e-6, false, e}};
    case Effect::kRateState:
      return {{"rs_a", lu, Transform::kLinear, 0.01 * level, false, e},
              {"rs_b", lu, Transform::kLinear, 0.01 * level, false, e},
              {"rs_dc", "m", Transform::kLog, 1e-5, false, e}};
  }
  return {};
}

ModelParams with_slip_trend(const ModelParams& params, const ModelData& d) {
  if (d.slip_m.empty()) throw std::logic_error("friction model: a slip trend on a record that does not slide one way only");
  ModelParams p = params;
  const double slid = std::max(d.slip_m.back(), 1e-12);
  p.specs.push_back({"slip_trend", level_unit(d, p.structure) + "/m", Transform::kLinear,
                     0.1 * level_scale(d, p.structure) / slid, false, {}});
  p.theta.push_back(0.0);
  return p;
}

ModelParams with_effect(const ModelParams& params, Effect e, const ModelData& d,
                        const std::vector<double>& initial_values) {
  ModelParams p = params;
  if (p.structure.has(e)) return p;
  p.structure.effects.push_back(e);
  if (e == Effect::kDrift) {
    // The spline carries the constant: the offset would be collinear with it.
    p.specs[static_cast<std::size_t>(p.index("offset"))].fixed = true;
  }
  auto specs = effect_parameters(e, d, p.structure);
  for (std::size_t k = 0; k < specs.size(); ++k) {
    ParamSpec spec = specs[k];
    double theta = 0.0;
    if (k < initial_values.size()) {
      if (spec.transform == Transform::kLog) spec.scale = initial_values[k];
      else theta = param_theta(spec, initial_values[k]);
    }
    p.specs.push_back(spec);
    p.theta.push_back(theta);
  }
  return p;
}

ModelParams without_effect(const ModelParams& params, Effect e, const ModelData& d) {
  ModelParams p;
  p.structure = params.structure;
  std::erase(p.structure.effects, e);
  for (std::size_t k = 0; k < params.specs.size(); ++k) {
    if (params.specs[k].effect == e) continue;
    p.specs.push_back(params.specs[k]);
    p.theta.push_back(params.theta[k]);
  }
  if (e == Effect::kDrift && params.structure.has(e) && !slides_one_way(d.motion)) {
    p.specs[static_cast<std::size_t>(p.index("offset"))].fixed = false;
  }
  return p;
}

// Dieterich's ageing law along the measured motion, d theta/dt = 1 - |v|
// theta / D_c, exactly over each sample interval at its mean velocity: theta
// is the time at rest in a hold and relaxes to D_c / |v| within a slip of a
// few D_c in sliding, so a pass after a short hold starts from the age the
// previous pass left (as on the instrument: sim/friction_effects.h), not
// from zero. The record's first sample: steady sliding if moving, else new.
// Advanced one sample at a time with the simulation (no per-sample array).
template <class T>
T contact_age_start(const ModelData& d, const T& memory_m) {
  const double v0 = std::fabs(d.drive_velocity[0]);
  return v0 > 0 ? T(memory_m / v0) : T(0.0 * memory_m);
}

// The age at sample i >= 1 from the age at i - 1.
template <class T>
T contact_age_step(const ModelData& d, const T& memory_m, const T& previous, std::size_t i) {
  using std::exp;
  const MeasuredSeries& s = d.series;
  const double h = s.time_s[i] - s.time_s[i - 1], speed = std::fabs(d.step_velocity[i]);
  if (speed == 0.0) return previous + h;
  const T steady = memory_m / speed;
  return steady + (previous - steady) * exp(-(speed * h) / memory_m);
}

// Ruina's slip law along the measured motion, d theta/dt = -(|v| theta / D_c)
// ln(|v| theta / D_c): phi = ln(|v| theta / D_c) decays as exp(-|v| t / D_c)
// at constant speed, so each interval is exact in phi; at rest theta holds
// (the slip law does not heal without slip). The speed used to carry theta
// over a speed change is the interval's. First sample: steady sliding if
// moving, else a state of D_c / v_ref.
template <class T>
T slip_law_start(const ModelData& d, const T& memory_m) {
  const double v0 = std::fabs(d.drive_velocity[0]);
  return memory_m / (v0 > 0 ? v0 : d.speed_ref);
}

template <class T>
T slip_law_step(const ModelData& d, const T& memory_m, const T& previous, std::size_t i) {
  using std::exp;
  using std::log;
  const MeasuredSeries& s = d.series;
  const double h = s.time_s[i] - s.time_s[i - 1], speed = std::fabs(d.step_velocity[i]);
  if (speed == 0.0) return previous;
  const T phi = log(speed * previous / memory_m);
  return memory_m / speed * exp(phi * exp(-(speed * h) / memory_m));
}

namespace {

// Whether a pass start from rest sets the bristle state afresh and all the
// model carries from one pass to the next besides is the contact age and the
// rate-and-state variable (each a function of the record's motion alone,
// advanced to a start by a pass of its own): not so with backlash, whose side
// in contact and gap carry over a hold.
bool starts_each_pass_afresh(const ModelParams& p) {
  return p.structure.state_from_rest && index_of(p).gap < 0;
}

bool is_pass_start_after_hold(const ModelData& d, std::size_t i) {
  return i > 0 && i < d.at_rest.size() && d.at_rest[i - 1] && !d.at_rest[i];
}

}  // namespace

std::size_t pass_start_near(const ModelData& d, const ModelParams& p, std::size_t near) {
  if (!starts_each_pass_afresh(p)) return 0;
  const std::size_t n = d.at_rest.size();
  near = std::min(near, n);
  for (std::size_t offset = 0; offset <= std::max(near, n - near); ++offset) {
    if (offset <= near && is_pass_start_after_hold(d, near - offset)) return near - offset;
    if (near + offset < n && is_pass_start_after_hold(d, near + offset)) return near + offset;
  }
  return 0;
}

template <class T>
void simulate_streamed(const ModelData& d, const ModelParams& p, const std::vector<T>& theta, SampleSink<T> sink,
                       const RestStateLane* rest, std::size_t begin, std::size_t end) {
  using std::cos;
  using std::exp;
  using std::log;
  using std::pow;
  using std::sin;
  const MeasuredSeries& s = d.series;
  const std::vector<double>& measured_force = *d.fitted_force;
  const std::size_t n = s.size();
  const ModelStructure& st = p.structure;
  const Index k = index_of(p);
  auto val = [&](int i) { return transform(p.specs[static_cast<std::size_t>(i)], theta[static_cast<std::size_t>(i)]); };

  const T fc = val(k.fc), fs = val(k.fs), vs = val(k.vs), sigma0 = val(k.sigma0), sigma1 = val(k.sigma1);
  const T fv = val(k.fv), offset = val(k.offset);
  const bool mass = k.mass >= 0, dwell = k.dwell_dfs >= 0, lag = k.lag >= 0, logv = k.logv >= 0;
  const bool load_dep = k.load_exponent >= 0 && s.has_normal(), periodic = k.per_length >= 0;
  const bool asym = k.asym_levels >= 0, tilt = k.tilt >= 0 && s.has_normal(), drift = !k.drift.empty();
  const bool ep = k.breakaway >= 0, backlash = k.gap >= 0, rate_state = k.rs_a >= 0;
  const bool load_scaled = st.load_scaled && s.has_normal();
  const T m = mass ? val(k.mass) : T(0.0);
  const T dwell_dfs = dwell ? val(k.dwell_dfs) : T(0.0), dwell_time = dwell ? val(k.dwell_time) : T(1.0);
  const T dwell_memory = dwell ? val(k.dwell_memory) : T(1.0);
  // The contact age and the rate-and-state variable at the sample being
  // simulated (stribeck() is only asked about that sample).
  T age = dwell ? contact_age_start(d, dwell_memory) : T(0.0);
  const T lag_time = lag ? val(k.lag) : T(0.0);
  const T log_coeff = logv ? val(k.logv) : T(0.0);
  const T load_exponent = load_dep ? val(k.load_exponent) : T(0.0);
  const T per_cos = periodic ? val(k.per_cos) : T(0.0), per_sin = periodic ? val(k.per_sin) : T(0.0);
  const T per_wavenumber = periodic ? T(2.0 * std::numbers::pi / val(k.per_length)) : T(0.0);
  const T asym_levels = asym ? val(k.asym_levels) : T(0.0), asym_viscous = asym ? val(k.asym_viscous) : T(0.0);
  const T tilt_tan = tilt ? val(k.tilt) : T(0.0);
  const T breakaway = ep ? val(k.breakaway) : T(0.0);
  const T gap = backlash ? val(k.gap) : T(0.0);
  const T rs_a = rate_state ? val(k.rs_a) : T(0.0), rs_b = rate_state ? val(k.rs_b) : T(0.0);
  const T rs_dc = rate_state ? val(k.rs_dc) : T(1.0);
  const bool slip_law = st.rate_state_slip_law;
  const bool trend = k.slip_trend >= 0;
  const T slip_trend = trend ? val(k.slip_trend) : T(0.0);
  const bool dither = k.dither >= 0;
  const T dither_rms = dither ? val(k.dither) : T(0.0);
  // The bristle's relaxation over a step at velocity vk: |vk| alpha / g, or
  // with the dither E|vk + d| alpha / g.
  auto relax = [&](const T& z, double vk, double h, const T& alpha_over_g) -> T {
    if (!dither) return bristle_step(z, vk, h, alpha_over_g);
    return bristle_step_at_speed(z, vk, h, dithered_speed(vk, dither_rms), alpha_over_g);
  };
  T rs_state = !rate_state ? T(0.0) : (slip_law ? slip_law_start(d, rs_dc) : contact_age_start(d, rs_dc));
  std::vector<T> drift_c;
  if (drift) {
    for (int index : k.drift) drift_c.push_back(val(index));
  }
  const double delta = st.stribeck_exponent;
  const double tiny = 1e-9 * d.force_scale;

  // S(speed) at sample i for a motion of the given sign.
  auto stribeck = [&](std::size_t i, const T& speed, double sign) -> T {
    T static_level = fs;
    if (dwell) static_level = static_level + dwell_dfs * (age / (age + dwell_time));
    const T ratio = speed / vs;
    const T shape = delta == 1.0 ? ratio : (delta == 2.0 ? T(ratio * ratio) : T(pow(ratio, delta)));
    T level = fc + (static_level - fc) * exp(-shape);
    if (logv) level = level + log_coeff * log((speed + d.speed_floor) / d.speed_ref);
    if (rate_state) {
      level = level + rs_a * log((speed + d.speed_floor) / d.speed_ref) + rs_b * log(d.speed_ref * rs_state / rs_dc);
    }
    if (trend) level = level + slip_trend * d.slip_m[i];
    if (load_scaled) {
      const double normal = std::max(s.normal_force_n[i], 0.0);
      if (normal <= 0) return T(0.0);
      level = level * normal;
      if (load_dep) level = level * exp(load_exponent * std::log(normal / d.normal_ref));
    }
    if (asym) level = level * (1.0 + asym_levels * sign);
    if (periodic && !st.periodic_additive) {
      const T phase = per_wavenumber * s.position_m[i];
      level = level * (1.0 + per_cos * cos(phase) + per_sin * sin(phase));
    }
    return level;
  };

  // Lagged velocity v(t_i - lag) by linear interpolation in the measured velocity.
  std::size_t lag_k = 0;
  auto lagged_velocity = [&](std::size_t i) -> T {
    const T target = s.time_s[i] - lag_time;
    const double tv = value_of(target);
    if (tv <= s.time_s.front()) return T(d.drive_velocity.front() + 0.0 * lag_time);
    while (lag_k + 1 < n && s.time_s[lag_k + 1] <= tv) ++lag_k;
    if (lag_k + 1 >= n) return T(d.drive_velocity.back() + 0.0 * lag_time);
    const double t0 = s.time_s[lag_k], t1 = s.time_s[lag_k + 1];
    const double v0 = d.drive_velocity[lag_k], v1 = d.drive_velocity[lag_k + 1];
    return v0 + (target - t0) * ((v1 - v0) / (t1 - t0));
  };

  auto additive = [&](std::size_t i) -> T {
    T f = offset;
    if (mass) f = f + m * s.acceleration_m_per_s2[i];
    if (tilt) f = f + tilt_tan * s.normal_force_n[i];
    if (drift) {
      std::array<double, kMaxDriftFunctions> basis{};
      // Only the four functions that are not zero here: each other term is
      // a coefficient times zero, which adds nothing to the force or its
      // derivatives (with up to 15 functions, most of the additive work).
      const auto first = static_cast<std::size_t>(d.drift_basis_at(i, basis.data()));
      for (std::size_t j = first; j < std::min(first + 4, drift_c.size()); ++j) f = f + drift_c[j] * basis[j];
    }
    if (periodic && st.periodic_additive) {
      const T phase = per_wavenumber * s.position_m[i];
      f = f + per_cos * cos(phase) + per_sin * sin(phase);
    }
    return f;
  };

  const auto& v = d.drive_velocity;
  const auto& x = s.position_m;

  auto absolute = [](const T& a) { return value_of(a) >= 0 ? a : T(-a); };

  // Bristle over the interval [t(i-1), t(i)], the velocity linear in between.
  // One exact exponential step at the mean velocity and mean level, unless the
  // velocity changes much while the bristle relaxes within a fraction of the
  // interval (onsets, reversals): then sub-steps, each with its own velocity
  // and level.
  auto advance = [&](T z, std::size_t i, const T& level_prev, const T& level_now, const T& vlag_prev, const T& vlag_now) {
    const double h = s.time_s[i] - s.time_s[i - 1];
    const double va = v[i - 1], vb = v[i], mean = d.step_velocity[i];
    const double g_min = std::min(value_of(level_prev), value_of(level_now)) / value_of(sigma0);
    const double relaxing_speed = std::max({std::fabs(va), std::fabs(vb), value_of(dither_rms)});
    const double rate = relaxing_speed / std::max(g_min, 1e-300);
    // A relaxed bristle follows a steady velocity exactly in one step; it is
    // a velocity that changes sign or by a quarter within the interval that
    // needs sub-steps.
    const bool steady = va * vb > 0 && std::fabs(vb - va) <= 0.25 * std::max(std::fabs(va), std::fabs(vb));
    const int m = steady ? 1 : std::clamp(static_cast<int>(std::ceil(rate * h / 0.5)), 1, 16);
    if (m == 1) {
      const double vm = mean;
      const T g = 0.5 * (level_prev + level_now) / sigma0;
      // Without plasticity alpha is one: 1 / g, not a quotient of a constant.
      if (!ep) return relax(z, vm, h, T(1.0 / g));
      const T alpha = plasticity(breakaway, vm, z, g);
      return relax(z, vm, h, T(alpha / g));
    }
    for (int k = 0; k < m; ++k) {
      const double u = (k + 0.5) / m;
      const double vk = mean + (vb - va) * (u - 0.5);
      const T speed = lag ? absolute(vlag_prev + (vlag_now - vlag_prev) * u) : T(std::fabs(vk));
      const T level_k = stribeck(i, speed, sign_of(vk));
      if (value_of(level_k) <= tiny) return T(0.0 * sigma0);
      const T g = level_k / sigma0;
      if (!ep) {
        z = relax(z, vk, h / m, T(1.0 / g));
        continue;
      }
      const T alpha = plasticity(breakaway, vk, z, g);
      z = relax(z, vk, h / m, T(alpha / g));
    }
    return z;
  };

  // The bristle at a hold's end from the force measured there: the mean of
  // (F - additive) over its last samples (up to 25 ms, at least one sample),
  // over sigma0, within the deflection limit level / sigma0.
  // Tells rest (when given) where and how z0 was set.
  auto state_at_rest = [&](std::size_t i, const T& limit_level) -> T {
    T sum = T(0.0 * sigma0);
    int count = 0;
    std::size_t first = i;
    for (std::size_t j = i; j-- > 0 && d.at_rest[j] && (count == 0 || s.time_s[i - 1] - s.time_s[j] <= 0.025);) {
      sum = sum + (measured_force[j] - additive(j));
      ++count;
      first = j;
    }
    const T z_rest = sum / (static_cast<double>(count) * sigma0);
    const T limit = limit_level / sigma0;
    const bool clamped = value_of(z_rest) > value_of(limit) || value_of(z_rest) < -value_of(limit);
    if (rest && rest->on_reset) rest->on_reset(i, first, static_cast<double>(count) * value_of(sigma0), clamped);
    if (value_of(z_rest) > value_of(limit)) return limit;
    if (value_of(z_rest) < -value_of(limit)) return T(-limit);
    return z_rest;
  };

  // Initial state: steady sliding if moving, else relaxed. Started at a
  // pass start after a hold, the level at the hold's last sample, as the full
  // simulation computes it there; the bristle state is set from rest at
  // begin (or zero where the level is nil there).
  if (begin > 0 && !(begin < n && starts_each_pass_afresh(p) && is_pass_start_after_hold(d, begin))) {
    throw std::invalid_argument("simulate_streamed: a simulation may start afresh only at a pass start after a hold");
  }
  const std::size_t i0 = begin > 0 ? begin - 1 : 0;
  // The contact age and the rate-and-state variable at i0, advanced as the
  // loop below advances them (the same operations: the same bits).
  for (std::size_t i = 1; i <= i0 && (dwell || rate_state); ++i) {
    if (dwell) age = contact_age_step(d, dwell_memory, age, i);
    if (rate_state) rs_state = slip_law ? slip_law_step(d, rs_dc, rs_state, i) : contact_age_step(d, rs_dc, rs_state, i);
  }
  T vlag = lag ? lagged_velocity(i0) : T(v[i0]);
  // At i0 > 0 as the loop computes the level there.
  T level = begin == 0 ? stribeck(0, absolute(vlag), sign_of(v[0]))
                       : stribeck(i0, lag ? absolute(vlag) : T(std::fabs(v[i0])), sign_of(v[i0]));
  T z = (begin == 0 && v[0] != 0 && value_of(level) > tiny) ? T(sign_of(v[0]) * level / sigma0) : T(0.0 * sigma0);
  int contact = v[0] >= 0 ? +1 : -1;  // backlash: side in contact
  bool in_gap = false;
  T x_open = T(x[0] + 0.0 * gap);

  // A pass that follows a hold starts from the force measured at rest
  // (state_at_rest): only the contact age and rate-and-state variable
  // (advanced at every sample), the level at the hold's last sample and the
  // lagged velocity there (computed from the record) reach past that start,
  // not the bristle state or the force before it. So the samples the sink
  // ignores up to the end of a hold that it also ignores are left out but
  // that last one: samples [i, skip_until).
  const bool skippable = st.state_from_rest && !backlash && sink.ignores_some();
  std::size_t next_taken = 0, hold_end = 0, skip_until = 0;
  for (std::size_t i = begin; i < std::min(n, end); ++i) {
    T friction = T(0.0 * sigma0);
    const T level_prev = level, vlag_prev = vlag;
    if (i > 0 && dwell) {
      const T next = contact_age_step(d, dwell_memory, age, i);
      age = next;
    }
    if (i > 0 && rate_state) {
      const T next = slip_law ? slip_law_step(d, rs_dc, rs_state, i) : contact_age_step(d, rs_dc, rs_state, i);
      rs_state = next;
    }
    if (skippable && i >= skip_until) {
      if (next_taken < i) {
        next_taken = i;
        while (next_taken < n && sink.ignores(next_taken)) ++next_taken;
      }
      if (hold_end < i) {
        hold_end = i;
        while (hold_end < n && !(d.at_rest[hold_end] && (hold_end + 1 == n || !d.at_rest[hold_end + 1]))) ++hold_end;
      }
      if (hold_end + 1 < n && hold_end > i && hold_end < next_taken) skip_until = hold_end;
    }
    if (i < skip_until) continue;
    if (i > 0) {
      if (lag) vlag = lagged_velocity(i);
      level = stribeck(i, lag ? absolute(vlag) : T(std::fabs(v[i])), sign_of(v[i]));
    }
    if (value_of(level) <= tiny) {
      z = T(0.0 * sigma0);
      sink(i, additive(i), T(0.0 * sigma0), false, 0.0);
      continue;
    }
    const T g = level / sigma0;
    if (st.state_from_rest && i > 0 && d.at_rest[i - 1] && !d.at_rest[i] && !(backlash && in_gap)) {
      z = state_at_rest(i, value_of(level_prev) > value_of(level) ? level_prev : level);
      if constexpr (!std::is_same_v<T, double>) {
        if (rest && rest->lane >= 0 && rest->lane < z.derivatives().size()) z.derivatives()[rest->lane] = 1.0;
      }
    }
    if (i > 0) {
      const double h = s.time_s[i] - s.time_s[i - 1];
      const double v_step = d.step_velocity[i];
      const T from = value_of(level_prev) > tiny ? level_prev : level;
      if (!backlash) {
        z = advance(z, i, from, level, vlag_prev, vlag);
      } else {
        if (!in_gap) {
          const T z_new = advance(z, i, from, level, vlag_prev, vlag);
          if (contact * value_of(z_new) < 0 && contact * value_of(z) >= 0 && sign_of(v_step) != contact) {
            // The force would change sign: contact opens where z crosses zero.
            const T f = z / (z - z_new);
            x_open = x[i - 1] + f * (x[i] - x[i - 1]);
            z = T(0.0 * sigma0);
            in_gap = true;
          } else {
            z = z_new;
          }
        }
        if (in_gap) {
          const double dx = std::fabs(x[i] - x[i - 1]);
          const T same_side = contact * (x[i] - x_open);
          const T other_side = contact * (x_open - x[i]) - gap;
          if (value_of(same_side) > 0 || value_of(other_side) > 0) {
            const T engaged = value_of(same_side) > 0 ? same_side : other_side;
            if (value_of(other_side) > 0) contact = -contact;
            in_gap = false;
            const T h_eff = dx > 0 ? T(h * engaged / dx) : T(0.0 * gap);
            z = bristle_step(T(0.0 * sigma0), v_step, h_eff, T(1.0 / g));
          }
        }
      }
    }
    double rate = 0.0;
    if (!(backlash && in_gap)) {
      const double vi = v[i];
      T dz_dt;
      if (dither) {
        const T speed = dithered_speed(vi, dither_rms);
        dz_dt = ep ? T(vi - speed * plasticity(breakaway, vi, z, g) * z / g) : T(vi - speed * z / g);
      } else {
        dz_dt = ep ? T(vi - std::fabs(vi) * plasticity(breakaway, vi, z, g) * z / g) : T(vi - std::fabs(vi) * z / g);
      }
      const T viscous = asym ? T(fv * (1.0 + asym_viscous * sign_of(vi))) : fv;
      friction = sigma0 * z + sigma1 * dz_dt + viscous * vi;
      rate = value_of(dz_dt);
    }
    sink(i, friction + additive(i), friction, !(backlash && in_gap), rate);
  }
}

template <class T>
void simulate_generic(const ModelData& d, const ModelParams& p, const std::vector<T>& theta, std::vector<T>& force,
                      std::vector<T>* friction_out) {
  const std::size_t n = d.series.size();
  force.resize(n);
  if (friction_out) friction_out->assign(n, T(0.0));
  auto store = [&](std::size_t i, const T& f, const T& friction) {
    force[i] = f;
    if (friction_out) (*friction_out)[i] = friction;
  };
  simulate_streamed<T>(d, p, theta, SampleSink<T>(store));
}

#define TRIBO_INSTANTIATE_SIMULATE(T)                                                                      \
  template void simulate_generic<T>(const ModelData&, const ModelParams&, const std::vector<T>&, std::vector<T>&, \
                                    std::vector<T>*);                                                             \
  template void simulate_streamed<T>(const ModelData&, const ModelParams&, const std::vector<T>&, SampleSink<T>, \
                                     const RestStateLane*, std::size_t, std::size_t);
TRIBO_INSTANTIATE_SIMULATE(double)
TRIBO_INSTANTIATE_SIMULATE(Dual)
// Every even width up to 24 (kJacobianWidths, analysis/models/autodiff.h).
TRIBO_INSTANTIATE_SIMULATE(FixedDual<2>)
TRIBO_INSTANTIATE_SIMULATE(FixedDual<4>)
TRIBO_INSTANTIATE_SIMULATE(FixedDual<6>)
TRIBO_INSTANTIATE_SIMULATE(FixedDual<8>)
TRIBO_INSTANTIATE_SIMULATE(FixedDual<10>)
TRIBO_INSTANTIATE_SIMULATE(FixedDual<12>)
TRIBO_INSTANTIATE_SIMULATE(FixedDual<14>)
TRIBO_INSTANTIATE_SIMULATE(FixedDual<16>)
TRIBO_INSTANTIATE_SIMULATE(FixedDual<18>)
TRIBO_INSTANTIATE_SIMULATE(FixedDual<20>)
TRIBO_INSTANTIATE_SIMULATE(FixedDual<22>)
TRIBO_INSTANTIATE_SIMULATE(FixedDual<24>)
TRIBO_INSTANTIATE_SIMULATE(FixedDual<32>)
#undef TRIBO_INSTANTIATE_SIMULATE

std::optional<AdditiveColumn> additive_column(const ModelData& data, const ModelParams& params, int k, double theta_k) {
  const Index index = index_of(params);
  AdditiveColumn c;
  if (k == index.fv) {
    // friction = sigma0 z + sigma1 dz/dt + Fv v: z does not depend on Fv.
    if (index.asym_levels >= 0) return std::nullopt;
    c.regressor = AdditiveColumn::Regressor::kSlidingVelocity;
  } else if (k == index.sigma1) {
    // friction = sigma0 z + sigma1 dz/dt + Fv v: z does not depend on sigma1.
    c.regressor = AdditiveColumn::Regressor::kBristleRate;
  } else if (k == index.offset) {
    c.regressor = AdditiveColumn::Regressor::kOne;
  } else if (k == index.mass) {
    c.regressor = AdditiveColumn::Regressor::kAcceleration;
  } else if (k == index.tilt) {
    // simulate_streamed adds the tilt only with a normal channel.
    c.regressor = data.series.has_normal() ? AdditiveColumn::Regressor::kNormal : AdditiveColumn::Regressor::kNone;
  } else if (const auto it = std::find(index.drift.begin(), index.drift.end(), k); it != index.drift.end()) {
    c.regressor = AdditiveColumn::Regressor::kDriftFunction;
    c.drift_function = static_cast<std::size_t>(it - index.drift.begin());
  } else {
    return std::nullopt;
  }
  c.through_rest_state = params.structure.state_from_rest && k != index.fv && k != index.sigma1;
  // The derivative the dual numbers seed: transform() on a one-column dual,
  // the same operations on the same values.
  FixedDual<2> t(theta_k);
  t.derivatives()[0] = 1.0;
  c.value_derivative = transform(params.specs[static_cast<std::size_t>(k)], t).derivatives()[0];
  return c;
}

double AdditiveColumn::at(const ModelData& data, std::size_t i, const double* drift_basis, bool evaluated, double rate) const {
  // As simulate_streamed's additive(): value x regressor (the offset: the value).
  switch (regressor) {
    case Regressor::kNone: return 0.0;
    case Regressor::kOne: return value_derivative;
    case Regressor::kAcceleration: return value_derivative * data.series.acceleration_m_per_s2[i];
    case Regressor::kNormal: return value_derivative * data.series.normal_force_n[i];
    case Regressor::kDriftFunction: return value_derivative * drift_basis[drift_function];
    case Regressor::kSlidingVelocity: return evaluated ? value_derivative * data.drive_velocity[i] : 0.0;
    case Regressor::kBristleRate: return evaluated ? value_derivative * rate : 0.0;
  }
  return 0.0;
}

std::vector<double> simulate(const ModelData& data, const ModelParams& params, std::vector<double>* friction) {
  std::vector<double> force;
  simulate_generic<double>(data, params, params.theta, force, friction);
  return force;
}

double steady_state_friction(const ModelParams& p, double velocity, double normal) {
  const bool mu = p.structure.load_scaled;
  const double fc = p.value(mu ? "mu_c" : "Fc"), fs = p.value(mu ? "mu_s" : "Fs"), vs = p.value("vs");
  const double ratio = std::fabs(velocity) / vs;
  const double shape = p.structure.stribeck_exponent == 1.0 ? ratio : std::pow(ratio, p.structure.stribeck_exponent);
  double level = fc + (fs - fc) * std::exp(-shape);
  if (mu) level *= normal;
  // With the unresolved dither the bristle settles at v g / E|v + d|.
  if (p.index("dither_speed") >= 0 && velocity != 0) level *= std::fabs(velocity) / dithered_speed(velocity, p.value("dither_speed"));
  return (velocity > 0 ? level : (velocity < 0 ? -level : 0.0)) + p.value("Fv") * velocity;
}

}  // namespace tribo::analysis
