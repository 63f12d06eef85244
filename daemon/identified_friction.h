// The friction model an identification found (tribo-fit diagnose --json,
// its final_model), in the form the real-time friction observer evaluates:
// plain numbers, SI, no allocation. The equations are those tribo-fit fits
// (analysis/models/friction_model.h), restricted to the extensions whose states the
// observer can carry along a motion (daemon/friction_report.h says which a
// report may use):
//
//   S(v)  = L (Fc + (Fs' - Fc) exp(-(|v|/vs)^delta)            L = N (N/N_ref)^e if load-scaled
//                                                              (e: load_dependence, else 0), else 1
//              + c_v ln((|v| + v_f)/v_ref)                     velocity_strengthening
//              + a ln((|v| + v_f)/v_ref) + b ln(v_ref theta/Dc))  rate_state
//            (1 + r_a sgn v)                                   direction_asymmetry
//   Fs'   = Fs + dFs age / (age + T_d)                         dwell_stiction (age: ageing law, memory D_d)
//   dz/dt = v - alpha(z, v) |v| z / g(v),  g = S / sigma0      alpha: presliding_hysteresis
//                                                              (Dupont et al. 2002), else 1
//   F     = sigma0 z + sigma1 dz/dt + Fv (1 + r_v sgn v) v + N tan(theta_tilt)
//
// theta: Dieterich's ageing law d theta/dt = 1 - |v| theta / Dc, or Ruina's
// slip law d theta/dt = -(|v| theta/Dc) ln(|v| theta/Dc). v_ref is the
// reference speed of the log-velocity terms (the identified record's median
// sliding speed) and v_f = v_ref / 100 their regularisation; N_ref the
// load load_dependence is referred to (its median load in contact).
#pragma once

namespace tribo::daemon {

struct IdentifiedFriction {
  bool load_scaled = false;        // levels are coefficients of the normal load
  double stribeck_exponent = 1;    // delta
  double coulomb = 0;              // Fc (N) or mu_c
  double static_level = 0;         // Fs (N) or mu_s
  double stribeck_velocity_m_per_s = 0;
  double sigma0_n_per_m = 0;
  double sigma1_n_s_per_m = 0;
  double viscous_n_s_per_m = 0;    // Fv
  double tilt_tan = 0;             // tilt_offset: the tip's lateral share of the load

  bool elasto_plastic = false;     // presliding_hysteresis
  double breakaway_ratio = 0;

  bool dwell = false;              // dwell_stiction
  double dwell_gain = 0;           // dFs (N or a coefficient of N)
  double dwell_time_s = 0;
  double dwell_memory_m = 0;

  bool rate_state = false;
  bool rate_state_slip_law = false;  // false: ageing (Dieterich)
  double rate_state_a = 0;
  double rate_state_b = 0;
  double rate_state_memory_m = 0;    // Dc

  bool velocity_strengthening = false;
  double log_velocity_coeff = 0;

  // Speed the log-velocity terms are referred to (rate_state, velocity_strengthening).
  double reference_speed_m_per_s = 0;

  bool load_dependence = false;    // only with load_scaled, as tribo-fit evaluates it
  double load_exponent = 0;        // e
  double reference_load_n = 0;     // N_ref

  bool direction_asymmetry = false;
  double asymmetry_levels = 0;
  double asymmetry_viscous = 0;
};

}  // namespace tribo::daemon
