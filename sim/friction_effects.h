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
//        + N_rs [a ln(1 + |v_S| / V*) + b ln(V* phi / D_c)]  (S >= 0.2 Fc)
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

#include <cmath>

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
// velocity. A fresh contact starts at phi_0 (initial_state_s). On loading,
// the stuck contact deflects elastically (breakaway_ratio, below) at the
// tip's velocity v ~ (dF/dt) / sigma0 while its state stays, so its
// threshold S rises by a ln(1 + v/V*) with the loading rate: the break-away
// peak grows with the commanded velocity (Table 5.1). Once it slips, the
// state falls by b ln(1 + v/V*) over ~D_c of slip: the friction drops and
// the tip overshoots (§5.3.1). S stays at least kRateStateFloor Fc.
enum class StateLaw { kAgeing, kSlip };

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
};

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
};

// S at the contact point (all enabled effects); equals stribeck_n of the
// plain model when none is enabled.
double stribeck_n(const FrictionModel& m, const FrictionLevels& levels, const ContactPoint& c);

// S at rest, pushed towards sgn(direction): the most the contact holds stuck.
double static_friction_n(const FrictionModel& m, const FrictionLevels& levels, const ContactPoint& c,
                         double direction);

// Both at the same contact point (sliding: stribeck_n; at rest towards
// sgn(direction): static_friction_n), the same values bit for bit, with the
// terms they share (dwell, the rate-and-state state's log, M_p) evaluated once.
struct ContactAnchor;  // below

struct SlidingAndStatic {
  double sliding_n = 0;
  double static_n = 0;
};
// With anchor given and rate_state on, it also gets the anchor's terms at c
// but the slip rate's (set_anchor_slip), from the same evaluations: what
// contact_anchor would compute there, without computing it twice.
SlidingAndStatic stribeck_and_static_n(const FrictionModel& m, const FrictionLevels& levels,
                                       const ContactPoint& c, double direction, ContactAnchor* anchor = nullptr);

// The slow and smooth terms of the contact law at the start of an
// integration sub-step, from which its later RK4 stages evaluate theirs
// (issue 14: speed; made when rate_state is on). Over one sub-step the
// stages' state phi, Stribeck speed |v_S|, slip rate |v_s| and contact age
// move by a small fraction (phi: < 1e-3 of itself; the speeds mostly < 1/64
// of V* + speed, measured on sim_bench's scratch; the age by < 1e-4 s of
// age + gamma >= 200 s), so
//   ln(V* phi / D_c)   = ln(V* phi_0 / D_c) + log1p((phi - phi_0) / phi_0)
//   ln(1 + |v| / V*)   = ln(1 + |v_0| / V*) + log1p((|v| - |v_0|) / (V* + |v_0|))
//   exp(-|v| / v_S0)   = exp(-|v_0| / v_S0) exp(-(|v| - |v_0|) / v_S0)   (exponent 1)
//   1 / (theta + gamma) = q (1 - d + d^2),  q = 1 / (theta_0 + gamma), d = (theta - theta_0) q
// with the small log1p and exp by their Taylor series while the fraction
// is within kAnchorReach (1/32; for phi kStateReach, 1/1024; the
// remainders are below 2e-16) and d within 2^-16 (d^3 < 4e-15), the
// functions themselves beyond; and the
// divisions by parameters (v_S0, D_c, the dwell memory) as multiplications
// by reciprocals taken once. The same values but for rounding, at a
// fraction of the cost of glibc's log, log1p, exp and of the divisions.
inline constexpr double kAnchorReach = 1.0 / 32;
inline constexpr double kDwellReach = 1.0 / 65536;
inline constexpr double kStateReach = 1.0 / 1024;  // phi's steps (< 1e-3 of itself, measured)

struct ContactAnchor {
  bool valid = false;       // filled at a contact point (with rate_state on)
  double speed = 0;         // |v_S|
  double shape = 1;         // stribeck_shape(|v_S|)
  double direct_log = 0;    // ln(1 + |v_S| / V*)
  double direct_scale = 0;  // 1 / (V* + |v_S|)
  double state = 0;         // phi
  double state_log = 0;     // ln(V* phi / D_c)
  double state_scale = 0;   // 1 / phi; 0 near the floor kMinRateStateRatio (no series)
  double slip = 0;          // |v_s|
  double slip_log = 0;      // ln(1 + |v_s| / V*)
  double slip_scale = 0;    // 1 / (V* + |v_s|)
  double age = 0;           // theta (dwell)
  double age_scale = 0;     // 1 / (theta + gamma)
  double inv_stribeck_velocity = 0;  // 1 / v_S0
  double state_per_memory = 0;       // V* / D_c
  double inv_memory = 0;             // 1 / D_c
  double inv_dwell_memory = 0;       // 1 / D_c of the dwell
};

// The anchor at contact point c with slip rate v_s (rate_state enabled).
ContactAnchor contact_anchor(const FrictionModel& m, const ContactPoint& c, double slip_rate_m_per_s);

// Sets the anchor's slip-rate terms (the first stage's slip rate).
void set_anchor_slip(const FrictionModel& m, double slip_rate_m_per_s, ContactAnchor& anchor);

// d theta/dt of the dwell age at velocity v (1 - |v| theta / D_c), from the anchor.
inline double dwell_age_rate_near(double velocity_m_per_s, double age_s, const ContactAnchor& a) {
  return 1.0 - std::abs(velocity_m_per_s) * (age_s * a.inv_dwell_memory);
}

// stribeck_n at c, and the state's log ln(max(V* phi / D_c, ...)), from the anchor.
struct NearStribeck {
  double stribeck_n = 0;
  double state_log = 0;
};
NearStribeck stribeck_n_near(const FrictionModel& m, const FrictionLevels& levels, const ContactPoint& c,
                             const ContactAnchor& anchor);

// rate_state_rate at slip rate v_s and state phi, with the state's log from
// stribeck_n_near at the same point (the slip law's ln x is its sum with
// ln(1 + |v_s| / V*)).
double rate_state_rate_near(const RateStateParams& p, double slip_rate_m_per_s, double state_s, double state_log,
                            const ContactAnchor& anchor);

// Lower bound on M_p M_d over all positions and directions (for step sizes).
double modulation_floor(const FrictionModel& m);

// Steady sliding friction with every enabled effect at its steady state.
double steady_state_friction_n(const FrictionModel& m, const FrictionLevels& levels,
                               double velocity_m_per_s, double sample_position_m);

}  // namespace tribo::sim
