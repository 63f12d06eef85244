// The friction model the identification fits, driven by the measured motion:
// given x(t), v(t), a(t) (and the normal load N(t)), it predicts the force.
//
// Base model: LuGre (dissertation §2, eqs. 9-13) with the dissertation's Stribeck shape,
//   S(v)  = L (Fc + (Fs - Fc) exp(-(|v|/vs)^delta))    L = N if load-scaled, else 1
//   dz/dt = v - |v| z / g(v),   g(v) = S(v) / sigma0
//   F     = sigma0 z + sigma1 dz/dt + Fv v + offset [+ M a]
// integrated exactly over each sample interval at the interval's mean
// velocity (z relaxes exponentially towards sgn(v) g(v)), so the stiff bristle
// mode needs no sub-steps. Load-scaled models fit mu_c = Fc/N and mu_s = Fs/N.
//
// Each effect of the vocabulary (analysis/effects/effect.h) is an optional extension
// with its own parameters (see effect_parameters() and simulate_generic()).
// Parameters are fitted in normalised form theta: value = scale exp(theta)
// (positive scales), scale theta (signed), or 1/(1 + exp(-theta)) (fractions),
// so every theta is of order one whatever the units.
#pragma once

#include <array>
#include <cstddef>
#include <memory>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "analysis/effects/effect.h"
#include "analysis/input/measured_series.h"
#include "analysis/motion/motion_segmentation.h"

namespace tribo::analysis {

enum class Transform { kLog, kLinear, kLogit };

struct ParamSpec {
  std::string name;
  std::string unit;
  Transform transform = Transform::kLinear;
  double scale = 1;
  bool fixed = false;             // held at its value, not fitted
  std::optional<Effect> effect;   // the extension it belongs to; nullopt: base model
};

double param_value(const ParamSpec& spec, double theta);
double param_theta(const ParamSpec& spec, double value);

struct ModelStructure {
  bool load_scaled = false;        // friction levels proportional to the normal load
  bool fit_mass = false;           // the force also accelerates a mass M (drive data)
  double stribeck_exponent = 1.0;  // delta: 1 the dissertation's exponential, 2 Gaussian
  bool periodic_additive = false;  // position_periodic as a ripple that does not flip with direction
  // The bristle state at the end of each hold is taken from the measured
  // force there (at rest F = sigma0 z + the additive terms), and the holds are
  // left out of the fit and of the held-out error (analysis/diagnosis.h):
  // for records whose holds carry a relaxation the sampled motion cannot
  // show (tribo's closed loop: the 10 kHz position dither drains LuGre's
  // bristle, docs/identification.md "Holds, passes and held-out data"). Each
  // pass is then predicted from the force it starts at, not from a model of
  // the hold.
  bool state_from_rest = false;
  // rate_state: the state's evolution law, Ruina's slip law (true) or
  // Dieterich's ageing law (false); the diagnosis fits both and keeps the one
  // the data favour.
  bool rate_state_slip_law = false;
  // The tip's unresolved dither: a closed position loop feeds its sensor's
  // noise back into the drive, so the tip jitters about the motion the
  // record resolves, faster than the samples show it. LuGre's bristle
  // relaxes at the rate |v| sigma0 / S(v) of the velocity the contact sees,
  // v + d, not of the resolved v: with d zero-mean Gaussian of RMS
  // dither_speed (a base parameter, m/s), the relaxation takes E|v + d|, so
  // the bristle drains below g(v) at low speed and at rest. Without it the
  // fit bends the Stribeck curve to mimic the drain (docs/identification.md,
  // "The unresolved dither"). The level S is kept at the resolved speed.
  bool unresolved_dither = false;
  std::vector<Effect> effects;     // extensions, in the order they were accepted

  bool has(Effect e) const;
};

struct ModelParams {
  ModelStructure structure;
  std::vector<ParamSpec> specs;
  std::vector<double> theta;

  int index(std::string_view name) const;  // -1 when absent
  double value(std::string_view name) const;
  void set_value(std::string_view name, double value);
  std::size_t free_count() const;
};

// Reference scales and per-sample regressors derived once from the data.
// Cubic B-spline basis values at u in [0, 1] with n uniform intervals (n + 3 functions).
std::vector<double> cubic_bspline_basis(double u, int intervals);

// The per-sample arrays that drive a model, derived once from the record
// and its segmentation (ModelData's constructor).
struct DriveArrays {
  std::vector<double> drive_velocity;   // the measured velocity, zero inside holds
  std::vector<char> at_rest;            // inside a hold (motion segmentation)
  std::vector<double> step_velocity;    // mean velocity over (t[i-1], t[i]); [0] unused
  std::vector<double> slip_m;           // distance slid since the record began (|step_velocity| dt summed);
                                        // only for records that slide one way only, else empty
};

struct ModelData {
  ModelData(const MeasuredSeries& series, const MotionSegmentation& motion);
  // A copy shares the per-sample arrays (DriveArrays): the copies that point
  // fitted_force at an injected force cost no array a sample.
  ModelData(const ModelData&) = default;

  const MeasuredSeries& series;
  const MotionSegmentation& motion;
  double force_scale = 1;      // typical |friction| in sliding (force units)
  double mu_scale = 1;         // typical |friction| / N (load-scaled models)
  double speed_ref = 1;        // median sliding speed: log-velocity reference
  double speed_floor = 1e-3;   // log-velocity regularisation (1 % of speed_ref)
  double normal_ref = 1;       // median normal load in contact
  double mass_scale = 1;       // force_scale / typical |a|
  // Drift: a cubic B-spline in time over the record, by default one knot
  // interval per two passes (3 to 12 intervals), the knots at quantiles of the fitted
  // samples' times (friction_model.cc); the basis functions sum to one, so
  // the offset is held fixed while drift is in the model.
  int drift_functions = 6;
  std::vector<double> drift_knot_time_s;
  // Sets the drift spline to this many knot intervals (3 to 12), the knots
  // placed by the rule above (analysis/effects/drift_knot_choice.h chooses the count).
  void set_drift_intervals(int intervals);
  int drift_intervals() const { return drift_functions - 3; }
  // Time mapped to [0, 1], piecewise linearly, knot k to k / intervals.
  double drift_spline_coordinate(double time_s) const;
  // The drift functions' values at sample i into out[0, drift_functions),
  // computed when needed: a stored table would cost drift_functions doubles
  // per sample. Returns the first of the four that are not zero.
  int drift_basis_at(std::size_t i, double* out) const;
  // Sample i's time mapped to [-1, 1] over the record, computed when needed
  // (eight bytes a sample as a stored array).
  double normalised_time(std::size_t i) const {
    const double u = (series.time_s[i] - time_start_s_) / time_span_s_;
    return 2 * u - 1;
  }
  // The force the model is fitted to, a pass starts from and the residual
  // signatures and score test read: the record's, or a copy with an effect
  // injected into it (injection and recovery, and rediagnosis, of a minimum
  // detectable strength, analysis/diagnosis.cc); never null after
  // construction. Copy the data to point it elsewhere.
  const std::vector<double>* fitted_force = nullptr;

 private:
  std::shared_ptr<const DriveArrays> arrays_;  // before the references to its arrays
  double time_start_s_ = 0, time_span_s_ = 1;  // normalised_time's

 public:
  const std::vector<double>& drive_velocity;
  const std::vector<char>& at_rest;
  const std::vector<double>& step_velocity;
  const std::vector<double>& slip_m;
};

// The base LuGre model (no effects) with rough initial values.
ModelParams base_params(const ModelData& data, const ModelStructure& structure);

// The parameters an effect adds, with neutral initial values (the effect
// switched on but not yet doing much), and its unit-aware names.
std::vector<ParamSpec> effect_parameters(Effect effect, const ModelData& data, const ModelStructure& structure);

// params with a friction level linear in the distance slid (slip_trend, per
// metre, starting at zero): the trend that velocity-step analyses remove
// before reading a and b (Marone 1998, Annu. Rev. Earth Planet. Sci. 26),
// offered by the contact choice on records that slide one way only.
ModelParams with_slip_trend(const ModelParams& params, const ModelData& data);

// params extended by effect (its parameters appended, initial theta given or neutral).
ModelParams with_effect(const ModelParams& params, Effect effect, const ModelData& data,
                        const std::vector<double>& initial_values = {});

// params without effect: its parameters removed, the rest at their values.
// Without drift the offset is free again where the record slides both ways
// (the spline carried the constant; sliding one way the offset is held at
// zero, lugre_fit.cc).
ModelParams without_effect(const ModelParams& params, Effect effect, const ModelData& data);

// Model force per sample, T = double or an autodiff scalar (analysis/models/autodiff.h).
// theta has one entry per spec of params. friction (optional) receives the
// friction part alone: the force without offset, inertia, tilt, drift and ripple.
template <class T>
void simulate_generic(const ModelData& data, const ModelParams& params, const std::vector<T>& theta,
                      std::vector<T>& force, std::vector<T>* friction = nullptr);

// Receives each sample's model force and friction part, in time order, as
// the simulation produces them: callers that keep only some samples or
// reduce them (the fit's residual and Jacobian rows) need no per-sample
// array of T (17 to 33 doubles a sample for the autodiff types). A callable
// with a fourth, bool argument also learns whether the contact's friction
// law was evaluated at the sample (false: no contact level, or a backlash
// gap; the friction part is then zero), one with a fifth, double argument
// also the bristle's rate dz/dt there (zero where not evaluated).
// `taken`, when given, marks the samples the callable reads: it ignores the
// others, and the simulation may leave some of those out (simulate_streamed).
template <class T>
class SampleSink {
 public:
  template <class F>
  explicit SampleSink(F& f, const std::vector<char>* taken = nullptr)
      : target_(&f), taken_(taken), call_([](void* t, std::size_t i, const T& force, const T& friction, bool evaluated, double rate) {
          if constexpr (std::is_invocable_v<F&, std::size_t, const T&, const T&, bool, double>) {
            (*static_cast<F*>(t))(i, force, friction, evaluated, rate);
          } else if constexpr (std::is_invocable_v<F&, std::size_t, const T&, const T&, bool>) {
            (*static_cast<F*>(t))(i, force, friction, evaluated);
          } else {
            (*static_cast<F*>(t))(i, force, friction);
          }
        }) {}
  void operator()(std::size_t i, const T& force, const T& friction, bool evaluated, double rate) const {
    call_(target_, i, force, friction, evaluated, rate);
  }
  // Whether the callable ignores sample i; whether it may ignore any.
  bool ignores(std::size_t i) const { return taken_ && !(*taken_)[i]; }
  bool ignores_some() const { return taken_ != nullptr; }

 private:
  void* target_;
  const std::vector<char>* taken_;
  void (*call_)(void*, std::size_t, const T&, const T&, bool, double);
};

// With ModelStructure::state_from_rest, each pass starts from a bristle state
// z0 read from the force measured at the end of its hold. The Jacobian
// carries d/d z0 as one derivative of the dual numbers (lane) instead of
// one per added term that enters z0 (AdditiveColumn::through_rest_state):
// the simulation seeds that derivative with one wherever it sets z0, and
// tells on_reset where it did: the sample i, the hold's samples [first, i)
// whose mean z0 is, the divisor of their sum (count times sigma0) and
// whether z0 was clamped to the deflection limit (then no added term
// enters it).
struct RestStateLane {
  int lane = -1;
  std::function<void(std::size_t i, std::size_t first, double divisor, bool clamped)> on_reset;
};

// simulate_generic, streamed: sink(i, force, friction) for i = 0 .. n-1.
// The values are those simulate_generic stores, bit for bit (rest changes
// derivatives only), at every sample the sink takes. With
// ModelStructure::state_from_rest (and no backlash), the samples the sink
// ignores (SampleSink's `taken`) that lie before the end of a hold it
// ignores too are not simulated, but the hold's last: the pass after it
// starts from the force measured at rest, and reads only the contact age and
// rate-and-state variable (advanced at every sample) and the hold's last
// level.
//
// begin, end: the samples simulated, [begin, end). A begin past 0 must be a
// pass start of a model that starts each pass afresh (pass_start_near()):
// from there the values are the full simulation's, bit for bit.
template <class T>
void simulate_streamed(const ModelData& data, const ModelParams& params, const std::vector<T>& theta, SampleSink<T> sink,
                       const RestStateLane* rest = nullptr, std::size_t begin = 0,
                       std::size_t end = std::numeric_limits<std::size_t>::max());

// With ModelStructure::state_from_rest each pass starts from the force
// measured at rest, and all else the model carries from one pass to the next
// is the contact age and the rate-and-state variable, functions of the
// record's motion (a simulation that starts afresh advances them to its
// start first), unless it has backlash (whose side in contact and gap carry
// over a hold): the first sample of a pass after a hold nearest to `near`
// (ties: the earlier), or 0 where there is none or the model has backlash.
std::size_t pass_start_near(const ModelData& data, const ModelParams& params, std::size_t near);

// A parameter the force depends on only through an added term, its value
// times a regressor of the data (the offset, the moving mass, the tilt, the
// drift coefficients, and the viscous coefficient Fv, whose term v Fv is
// added to the friction wherever the friction law is evaluated), that no
// other part of the model reads: d force / d theta is d value / d theta
// times the regressor, the very product the dual numbers form (every other
// term adds an exact zero), so a Jacobian fills its column from the data
// instead of carrying it through the simulation (the drift fit
// carries 5 of its 21 columns, not 21). The bristle damping sigma1 too:
// its term sigma1 dz/dt is added to the friction, and nothing else reads
// it (regressor: the bristle rate). With state_from_rest, whose pass
// start subtracts the offset, mass, tilt and drift from the measured force,
// those also enter the bristle state there (through_rest_state); Fv is
// carried with direction asymmetry, which scales it.
struct AdditiveColumn {
  enum class Regressor { kNone, kOne, kAcceleration, kNormal, kDriftFunction, kSlidingVelocity, kBristleRate };
  Regressor regressor = Regressor::kNone;
  std::size_t drift_function = 0;  // kDriftFunction: which one
  double value_derivative = 0;     // d value / d theta at theta
  // With state_from_rest the term also enters each pass's starting state z0
  // (minus its mean over the hold's last samples, over sigma0): the column
  // then adds d force / d z0 (RestStateLane) times d z0 / d theta.
  bool through_rest_state = false;

  // d force / d theta at sample i; drift_basis: the drift functions at i
  // (ModelData::drift_basis_at), read for kDriftFunction only; evaluated:
  // whether the friction law was (SampleSink), read for kSlidingVelocity and
  // kBristleRate; rate: the bristle's dz/dt (SampleSink), for kBristleRate.
  double at(const ModelData& data, std::size_t i, const double* drift_basis, bool evaluated, double rate = 0.0) const;
};

// Parameter k of params (at theta_k) as an additive column, or nullopt.
std::optional<AdditiveColumn> additive_column(const ModelData& data, const ModelParams& params, int k, double theta_k);

std::vector<double> simulate(const ModelData& data, const ModelParams& params,
                             std::vector<double>* friction = nullptr);

// The LuGre steady-state friction of the base model at velocity v and load N
// (N ignored unless load-scaled), without offset and effects; with the
// unresolved dither, the level times |v| / E|v + d|.
double steady_state_friction(const ModelParams& params, double velocity, double normal);

}  // namespace tribo::analysis
