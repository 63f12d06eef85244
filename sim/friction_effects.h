// Optional friction effects on top of LuGre (sim/lugre_friction.h). Each is
// off unless enabled in config (sim.friction.<name>), and each is written as
// a change of the Stribeck magnitude S, or as an extra state of the contact.
// The identification work (analysis/) uses these equations as ground truth.
//
// Once per tick, from the contact load N (sim/instrument.cc):
//   N_eff = N                                           Amontons (default)
//         = N_ref ((N + N_adh) / N_ref)^p               load_dependence: adhesion
//                                                       N_adh, p = 2/3 for friction
//                                                       proportional to Hertz area
//   Fs  = static_coeff  N_eff M_o W
//   Fc  = coulomb_coeff N_eff M_o W
//   Fvs = strengthening_coeff N_eff M_o W
//   M_o = 1 + a_o cos(2 pi (psi - psi_max) / Psi)       orientation_anisotropy;
//                                                       psi = sample.rotation_deg
//   W   = wear factor of the track under the tip         sim/wear_track.h,
//         times this run's spot on the sample            sample.heterogeneity
//
// At every evaluation (sub-step), at tip position x_s on the sample, relative
// velocity v, contact age theta and lagged velocity v_L:
//   S(v) = M_p M_d [Fc + (Fs D - Fc) shape(v_S) + Fvs ln(1 + |v_S| / v_ref)]
//   M_p  = 1 + a_p sin(2 pi x_s / lambda + phi)          position_periodic
//   M_d  = 1 + a_d sgn(v)                                direction_asymmetry
//   D    = 1 + gain theta / (theta + gamma)              dwell_stiction (Armstrong
//          d theta/dt = 1 - |v| theta / D_c              eq. 5 with Dieterich ageing:
//                                                       theta is the rest time at
//                                                       rest, D_c / |v| in sliding)
//        + N_rs [a ln(1 + |v_d| / V*) + b ln(V* phi / D_c)]  (S >= 0.2 Fc)
//          v_d = v_S (default) or the slip rate v - dz/dt  rate_state.direct_rate
//                                                       rate_state (Dieterich-Ruina,
//                                                       regularised at V*; N_rs =
//                                                       N_eff M_o W; its own state phi,
//                                                       ageing or slip law, below)
//   v_S  = v_L, d v_L/dt = (v - v_L) / tau_L            frictional_lag (Armstrong eq.
//                                                       4 as a first-order lag;
//                                                       otherwise v_S = v)
//   Fvs ln(1 + |v_S| / v_ref)                           velocity_strengthening
//   shape(v) = exp(-(|v| / vs)^exponent)
// and g = S / sigma0 in the bristle equation. In steady sliding at v:
//   F_ss = sgn(v) S(v)|theta = D_c/|v|, v_S = v + sigma2 v.
// The dwell term changes F_ss by at most Fs gain (D_c/|v|) / (D_c/|v| + gamma),
// negligible when D_c / |v| << gamma.
#pragma once

#include "sim/lugre_friction.h"
#include "sim/maxwell_slip.h"

namespace tribo::sim {

struct DwellStictionParams {
  bool enabled = false;
  double gain = 0;
  double time_constant_s = 1;
  double memory_length_m = 1e-7;
};

struct FrictionalLagParams {
  bool enabled = false;
  double time_constant_s = 0;
};

struct VelocityStrengtheningParams {
  bool enabled = false;
  double coeff = 0;
  double reference_velocity_m_per_s = 1;
};

struct LoadDependenceParams {
  bool enabled = false;
  double adhesion_load_n = 0;
  double exponent = 1;
  double reference_load_n = 1;
};

struct PositionPeriodicParams {
  bool enabled = false;
  double amplitude = 0;
  double period_m = 1;
  double phase_rad = 0;
};

struct OrientationAnisotropyParams {
  bool enabled = false;
  double amplitude = 0;
  double period_deg = 360;
  double max_at_deg = 0;
};

struct DirectionAsymmetryParams {
  bool enabled = false;
  double ratio = 0;
};

// Rate-and-state friction (Dieterich 1979; Ruina 1983), added to S:
//   N_rs [a ln(1 + |v|/V*) + b ln(V* phi / D_c)]
// a direct effect (friction rises at once with the rate) and a state phi (s)
// of its own, evolving with the slip rate v_s (the tip's velocity less the
// bristles' elastic rate) by Dieterich's ageing law or Ruina's slip law:
//   d phi/dt = 1 - x             (ageing)
//   d phi/dt = -x ln x           (slip),   x = (|v_s| + V*) phi / D_c
// V* regularises both ends: the direct effect is linear below V*, and a
// contact at rest relaxes to the state of sliding at V* (phi = D_c / V*, the
// state term 0) over ~D_c / V*. In steady sliding phi = D_c / (|v| + V*)
// and the addition is (a - b) ln(1 + |v|/V*): a = b is friction flat in
// velocity. A fresh contact starts at phi_0 (initial_state_s). With the
// direct effect on the tip's velocity (the default, DirectEffectRate below),
// on loading the stuck contact deflects elastically (breakaway_ratio) at the
// tip's velocity v ~ (dF/dt) / sigma0 while its state stays, so its
// threshold S rises by a ln(1 + v/V*) with the loading rate: the break-away
// peak grows with the commanded velocity (Table 5.1). On the slip rate, the
// stuck contact takes no direct effect; the peak grows with the slip rate
// once slip begins. Once it slips, the
// state falls by b ln(1 + v/V*) over ~D_c of slip: the friction drops and
// the tip overshoots (§5.3.1). S stays at least kRateStateFloor Fc.
enum class StateLaw { kAgeing, kSlip };

// The rate the direct effect takes: the tip's velocity v (the default; while
// stuck, the elastic loading rate) or the slip rate v_s = v - dz/dt, as in
// the rate-and-state literature, where a stuck contact (alpha = 0: no slip)
// takes none and the break-away threshold does not rise with the loading
// rate through it.
enum class DirectEffectRate { kTipVelocity, kSlipRate };

inline constexpr double kRateStateFloor = 0.2;
inline constexpr double kMinRateStateRatio = 1e-12;

struct RateStateParams {
  bool enabled = false;
  double direct_coeff = 0;                   // a, per unit load and per e-fold of velocity
  double state_coeff = 0;                    // b, per unit load and per e-fold of the state
  double reference_velocity_m_per_s = 1e-6;  // V*
  double memory_length_m = 1e-7;             // D_c
  double initial_state_s = 0;                // phi_0 of a fresh contact
  StateLaw law = StateLaw::kSlip;
  DirectEffectRate direct_rate = DirectEffectRate::kTipVelocity;
};

// The direct effect takes the slip rate (and the model has a rate-and-state term).
inline bool direct_effect_on_slip_rate(const RateStateParams& p) {
  return p.enabled && p.direct_rate == DirectEffectRate::kSlipRate;
}

struct FrictionModel {
  LugreParams lugre;
  DwellStictionParams dwell_stiction;
  FrictionalLagParams frictional_lag;
  VelocityStrengtheningParams velocity_strengthening;
  LoadDependenceParams load_dependence;
  PositionPeriodicParams position_periodic;
  OrientationAnisotropyParams orientation_anisotropy;
  DirectionAsymmetryParams direction_asymmetry;
  PreslidingHysteresisParams presliding_hysteresis;
  RateStateParams rate_state;
};

// The rate-and-state addition to S (0 when off).
double rate_state_n(const FrictionModel& m, const FrictionLevels& levels, double velocity_m_per_s,
                    double state_s);

// d phi/dt of the rate-and-state law at slip rate v.
double rate_state_rate(const RateStateParams& p, double velocity_m_per_s, double state_s);

// phi after h at frozen v: exact for both laws (the slip law is linear in ln(|v| phi / D_c)).
double relax_rate_state(const RateStateParams& p, double velocity_m_per_s, double state_s, double h_s);

// N_eff for the contact load N.
double effective_load_n(const LoadDependenceParams& p, double contact_load_n);

// M_o at the sample rotation.
double orientation_factor(const OrientationAnisotropyParams& p, double rotation_deg);

// Fs, Fc, Fvs of the contact for this tick (W: wear and site factor).
FrictionLevels contact_levels(const FrictionModel& m, double contact_load_n, double rotation_deg,
                              double local_factor);

// Where the contact is, for one evaluation of S.
struct ContactPoint {
  double velocity_m_per_s = 0;           // tip relative to the sample
  double stribeck_velocity_m_per_s = 0;  // v_S: the lagged velocity, or v
  double sample_position_m = 0;          // x_s
  double contact_age_s = 0;              // theta
  double rate_state_s = 0;               // phi (rate_state)
  double slip_rate_m_per_s = 0;          // v_s, read only with DirectEffectRate::kSlipRate
};

// S at the contact point (all enabled effects); equals stribeck_n of the
// plain model when none is enabled.
double stribeck_n(const FrictionModel& m, const FrictionLevels& levels, const ContactPoint& c);

// The rates of the contact's own slow states at the point, the bristles'
// slip rate given (the tip's velocity less their elastic rate; sim/lateral_plant.cc):
// d theta/dt of dwell_stiction and d phi/dt of rate_state (0 when off).
// With stribeck_n this is the whole contact law the integrators call
// (sim/step_size.h): a change of the law's formulas goes here and there.
struct ContactStateRates {
  double contact_age = 0;  // d theta/dt
  double rate_state = 0;   // d phi/dt
};
ContactStateRates contact_state_rates(const FrictionModel& m, const ContactPoint& c, double slip_rate_m_per_s);

// S at the point with the bristle at deflection z (single LuGre bristle,
// elasto-plastic ratio m.lugre.breakaway_ratio). With the direct effect on the
// slip rate, S and the slip rate v_s = alpha(z, g) |v| z / g, g = S / sigma0,
// depend on each other: S = F(S) with F(S) = S at v_s(S). S is affine in
// L = ln(1 + |v_s| / V*) (slope K = N_rs a M_p M_d, above the floor), and
// H(L) = L - ln(1 + |v_s(S(L))| / V*) rises with L (dH/dL >= 1: |v_s| falls
// as S rises), so the root is unique. It is found by Halley's method on H
// (its second derivative from the blend's own slopes, no further
// transcendental function), from guess_n's L (S of a nearby evaluation: the previous sub-step's, the
// sub-step's start; none: L = 0), kept within the bracket that each
// evaluation gives (an L below the root bounds it from above by
// ln(1 + |v_s|/V*) there, one above from below) by bisecting where a step
// leaves it, stopping where |S - F(S)| = K |H| <= kSlipRateResidual S, after at
// most kSlipRateIterations evaluations (one logarithm each), without
// allocation. F(S) of the last evaluation is returned; or, where a Halley step
// of size d (at most 1e-3) leaves an error whose estimate K d^3 (1 + (H''/H')^2)
// is within kSlipRateResidual S, S at the step's end, and the slip rate there,
// without the logarithm of a further evaluation. In the elasto-plastic
// blend alpha rises by up to pi / (2 (1 - r)) per unit z/g (19 at r = 0.917)
// and |F'| exceeds 1 at loading rates of a few V*: plain fixed-point iteration
// diverges there, Halley's within the bracket does not. The solved v_s is left
// in c's slip_rate_m_per_s. Otherwise stribeck_n(m, levels, c).
inline constexpr int kSlipRateIterations = 32;
inline constexpr double kSlipRateResidual = 1e-12;
double stribeck_n_at_deflection(const FrictionModel& m, const FrictionLevels& levels, ContactPoint& c,
                                double bristle_m, double guess_n = 0);

// S at rest, pushed towards sgn(direction): the most the contact holds stuck.
double static_friction_n(const FrictionModel& m, const FrictionLevels& levels, const ContactPoint& c,
                         double direction);

// Both at the same contact point (sliding: stribeck_n; at rest towards
// sgn(direction): static_friction_n), the same values bit for bit, with the
// terms they share (dwell, the rate-and-state state's log, M_p) evaluated once.
struct SlidingAndStatic {
  double sliding_n = 0;
  double static_n = 0;
};
SlidingAndStatic stribeck_and_static_n(const FrictionModel& m, const FrictionLevels& levels,
                                       const ContactPoint& c, double direction);

// stribeck_n_at_deflection (c's slip rate set as there) and static_friction_n
// at the same point, its terms (dwell, the rate-and-state state's log, M_p)
// evaluated once: the same values bit for bit.
SlidingAndStatic stribeck_at_deflection_and_static_n(const FrictionModel& m, const FrictionLevels& levels,
                                                     ContactPoint& c, double bristle_m, double direction,
                                                     double guess_n = 0);

// Lower bound on M_p M_d over all positions and directions (for step sizes).
double modulation_floor(const FrictionModel& m);

// Steady sliding friction with every enabled effect at its steady state.
double steady_state_friction_n(const FrictionModel& m, const FrictionLevels& levels,
                               double velocity_m_per_s, double sample_position_m);

}  // namespace tribo::sim
