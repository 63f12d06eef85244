// LuGre friction in the dissertation's modified form (Appendix C,
// hysfricfcn04.m), with the friction levels scaled by the contact load:
//
//   Fs = static_coeff * N,  Fc = coulomb_coeff * N
//   S(v)  = Fc + (Fs - Fc) exp(-(|v| / vs)^exponent)     (Stribeck curve)
//   g(v)  = S(v) / sigma0                                 (bristle deflection scale)
//   dz/dt = v - |v| z / g(v)
//   F     = sigma0 z + sigma1 dz/dt + sigma2 v
//
// exponent 1 is the dissertation's exponential shape, 2 the Gaussian one. In
// steady sliding dz/dt = 0 and F_ss(v) = sgn(v) S(v) + sigma2 v. The optional
// effects (dwell, lag, load dependence, ...) change S and live in
// sim/friction_effects.h; this file is the plain model they build on.
//
// Elasto-plastic presliding (Dupont, Hayward, Armstrong, Altpeter 2002),
// switched on by breakaway_ratio r in (0, 1): dz/dt = v - alpha(z, v) |v| z / g,
//   alpha = 0                                          if sgn(z) != sgn(v) or |z| <= r g
//   alpha = (1 + sin(pi (|z| - (1 + r) g / 2) / ((1 - r) g))) / 2   if r g < |z| < g
//   alpha = 1                                          if |z| >= g
// Plain LuGre (r = 0, alpha = 1) unloads a sliding bristle at twice the elastic
// rate on every reversal, so sub-nanometre jitter from sensor noise drains it
// and the friction drops; real contacts are elastic there. Below breakaway
// and while unloading, motion is purely elastic; the steady state is unchanged.
#pragma once

namespace tribo::sim {

struct LugreParams {
  double sigma0_n_per_m = 0;    // bristle (contact) stiffness
  double sigma1_n_s_per_m = 0;  // bristle damping
  double sigma2_n_s_per_m = 0;  // viscous friction
  double static_coeff = 0;      // Fs / N
  double coulomb_coeff = 0;     // Fc / N
  double stribeck_velocity_m_per_s = 0;
  double stribeck_exponent = 1;
  double breakaway_ratio = 0;  // 0: plain LuGre; (0, 1): elasto-plastic presliding
};

// Friction levels at the present contact (load, orientation, wear).
struct FrictionLevels {
  double static_n = 0;        // Fs
  double coulomb_n = 0;       // Fc
  double strengthening_n = 0; // velocity strengthening per e-fold (sim/friction_effects.h)
  double rate_state_n = 0;    // load scale of the rate-and-state terms (sim/friction_effects.h)
  bool in_contact() const { return coulomb_n > 0 && static_n > 0; }
};

// Amontons: Fs = static_coeff N, Fc = coulomb_coeff N.
FrictionLevels friction_levels(const LugreParams& p, double contact_load_n);

// exp(-(|v| / vs)^exponent)
double stribeck_shape(const LugreParams& p, double velocity_m_per_s);

// S(v): the magnitude of the steady friction without the viscous term.
double stribeck_n(const LugreParams& p, const FrictionLevels& levels, double velocity_m_per_s);

// F_ss(v) = sgn(v) S(v) + sigma2 v, the friction in steady sliding (plain model).
double steady_state_friction_n(const LugreParams& p, double contact_load_n,
                               double velocity_m_per_s);

// alpha(z, v) above; 1 for plain LuGre (breakaway_ratio 0).
double plasticity(double breakaway_ratio, double velocity_m_per_s, double z_m, double g_m);

struct LugreOutput {
  double dz_dt_m_per_s = 0;
  double force_n = 0;
  double plasticity = 1;  // alpha(z, v) of the evaluation (the step estimate reuses it)
};

// One bristle with deflection scale g: dz/dt and sigma0 z + sigma1 dz/dt + sigma2 v.
LugreOutput lugre_bristle(const LugreParams& p, double g_m, double velocity_m_per_s, double z_m);

// The same with 1/g given (an integrator that holds g over a sub-step
// divides once, not at every stage).
LugreOutput lugre_bristle_at_inverse_scale(const LugreParams& p, double inverse_g_per_m, double velocity_m_per_s,
                                           double z_m);

// The plain model at velocity v and bristle deflection z (g = S(v) / sigma0).
// Out of contact the force is zero and the bristles do not move.
LugreOutput lugre_evaluate(const LugreParams& p, const FrictionLevels& levels,
                           double velocity_m_per_s, double z_m);

}  // namespace tribo::sim
