#include "sim/compact_rk4.h"

#include <cmath>

namespace tribo::sim {

namespace {

bool negative_zero(double x) { return x == 0.0 && std::signbit(x); }

// The states in use; with an effect off its state is carried but never
// touched (its rate would be 0).
struct CompactState {
  double x = 0, v = 0, z = 0, lag = 0, age = 0, phi = 0;
};

template <bool kDwell, bool kRateState, bool kLag>
struct CompactPlant {
  // lateral_derivative without backlash and Maxwell-slip elements.
  static CompactState derivative(const LateralPlant& plant, const LateralInputs& in, const CompactState& s) {
    const FrictionModel& m = plant.friction;
    const LateralAxisParams& axis = plant.axis;
    CompactState r;
    double friction_n = 0;
    const double v = s.v - in.sample_velocity_m_per_s;
    if (in.levels.in_contact()) {
      const ContactPoint c{v, kLag ? s.lag : v, s.x - in.sample_offset_m, s.age, s.phi};
      const LugreOutput out = lugre_bristle_at_inverse_scale(m.lugre, m.lugre.sigma0_n_per_m / stribeck_n(m, in.levels, c), v, s.z);
      r.z = out.dz_dt_m_per_s;
      friction_n = out.force_n;
      if constexpr (kDwell || kRateState) {
        const ContactStateRates slow = contact_state_rates(m, c, v - r.z);
        r.age = slow.contact_age;
        r.phi = slow.rate_state;
      }
    }
    if constexpr (kLag) r.lag = (v - s.lag) / m.frictional_lag.time_constant_s;
    const double plate_n = in.drive.force_n(s.x) - axis.spring_n_per_m * s.x - axis.damping_n_s_per_m * s.v;
    r.x = s.v;
    r.v = (plate_n - friction_n + in.tip_force_n) / axis.mass_kg;
    hold_at_stop(in.drive, s.x, r.x, r.v);
    return r;
  }

  // out = s + h r on the states in use (add_scaled).
  static void add_scaled(CompactState& out, const CompactState& s, const CompactState& r, double h) {
    out.x = s.x + h * r.x;
    out.v = s.v + h * r.v;
    out.z = s.z + h * r.z;
    if constexpr (kLag) out.lag = s.lag + h * r.lag;
    if constexpr (kDwell) out.age = s.age + h * r.age;
    if constexpr (kRateState) out.phi = s.phi + h * r.phi;
  }

  // One sub-step, as the general substep without frozen contact.
  static void substep(const LateralPlant& plant, const LateralInputs& in, double h, SubstepScheme scheme,
                      CompactState& s, const CompactState* first) {
    CompactState tmp = s;
    const CompactState k1 = first ? *first : derivative(plant, in, s);
    if (scheme == SubstepScheme::kMidpoint) {
      add_scaled(tmp, s, k1, h / 2);
      add_scaled(s, s, derivative(plant, in, tmp), h);
      return;
    }
    add_scaled(tmp, s, k1, h / 2);
    const CompactState k2 = derivative(plant, in, tmp);
    add_scaled(tmp, s, k2, h / 2);
    const CompactState k3 = derivative(plant, in, tmp);
    add_scaled(tmp, s, k3, h);
    const CompactState k4 = derivative(plant, in, tmp);
    CompactState sum = k1;
    add_scaled(sum, k1, k2, 2.0);
    add_scaled(sum, sum, k3, 2.0);
    add_scaled(sum, sum, k4, 1.0);
    add_scaled(s, s, sum, h / 6);
  }

  static bool integrate(const LateralPlant& plant, const LateralInputs& in, double dt_s, int substeps,
                        LateralState& full, const LateralRate* first, SubstepScheme scheme) {
    CompactState s{full.position_m, full.velocity_m_per_s, full.bristle_m, full.lag_velocity_m_per_s,
            full.contact_age_s, full.rate_state_s};
    CompactState first_rate;
    if (first) {
      first_rate = CompactState{first->position_m, first->velocity_m_per_s, first->bristle_m,
                         first->lag_velocity_m_per_s, first->contact_age_s, first->rate_state_s};
    }
    const double h = dt_s / substeps;
    bool stopped = false;
    for (int i = 0; i < substeps; ++i) {
      substep(plant, in, h, scheme, s, i == 0 && first ? &first_rate : nullptr);
      stopped |= apply_stops(in.drive, s.x, s.v);
    }
    full.position_m = s.x;
    full.velocity_m_per_s = s.v;
    full.bristle_m = s.z;
    if constexpr (kLag) full.lag_velocity_m_per_s = s.lag;
    if constexpr (kDwell) full.contact_age_s = s.age;
    if constexpr (kRateState) full.rate_state_s = s.phi;
    return stopped;
  }
};

}  // namespace

bool compact_rk4_applies(const LateralPlant& plant, const LateralState& s) {
  const FrictionModel& m = plant.friction;
  if (plant.axis.backlash.enabled || m.presliding_hysteresis.enabled || m.frictional_lag.enabled) return false;
  if (direct_effect_on_slip_rate(m.rate_state)) return false;  // S solved with the slip rate: the general path
  // The states the compact path leaves alone gain +0 in the general path.
  return !negative_zero(s.tip_position_m) && !negative_zero(s.tip_velocity_m_per_s) &&
         !negative_zero(s.lag_velocity_m_per_s) &&
         (m.dwell_stiction.enabled || !negative_zero(s.contact_age_s)) &&
         (m.rate_state.enabled || !negative_zero(s.rate_state_s));
}

bool integrate_lateral_compact(const LateralPlant& plant, const LateralInputs& in, double dt_s,
                               int substeps, LateralState& s, const LateralRate* first,
                               SubstepScheme scheme) {
  const FrictionModel& m = plant.friction;
  // The named configs' combinations (plain LuGre; dwell with rate-and-state,
  // dissertation_fit) and their neighbours. Frictional lag, which no named
  // config uses, takes the general path: each instance adds to the unit that
  // GCC's inlining limits weigh (eight instances pushed the normal-axis solve
  // and the sensors out of line: -6 %, measured).
  switch ((m.dwell_stiction.enabled ? 2 : 0) | (m.rate_state.enabled ? 1 : 0)) {
    case 0: return CompactPlant<false, false, false>::integrate(plant, in, dt_s, substeps, s, first, scheme);
    case 1: return CompactPlant<false, true, false>::integrate(plant, in, dt_s, substeps, s, first, scheme);
    case 2: return CompactPlant<true, false, false>::integrate(plant, in, dt_s, substeps, s, first, scheme);
    default: return CompactPlant<true, true, false>::integrate(plant, in, dt_s, substeps, s, first, scheme);
  }
}

}  // namespace tribo::sim
