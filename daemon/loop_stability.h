// Discrete-time stability of the controller's loops at the loop rate, checked
// when a config is loaded: a gain that is stable in continuous time can make
// the sampled loop unstable (the derivative of the lateral loop is the usual
// one: kd dt / m must stay below about 2).
//
// Each loop is the PID of daemon/pid.h stepped every dt = 1 / loop_rate_hz
// (its filtered derivative, its integral, set-point weights and feed-forward
// outside the loop) around a linear plant, with the drive held over the tick
// (zero-order hold): the sensors are read at tick k, the drive u_k is written
// and held until tick k + 1, as the lock-step backends do. Stable means every
// pole of the closed loop (the eigenvalues of its one-tick transition
// matrix) lies inside the unit circle; saturation and anti-windup are not
// part of the small-signal loop.
//
// Lateral displacement: the plate, mass m on spring k with damping c,
//   m x'' = u - k x - c x'  (+ the contact: stiffness sigma0, damping sigma1
//                             while the tip is stuck),
// discretised exactly over one tick: [x v]_{k+1} = Ad [x v]_k + Bd u_k with
// Ad, Bd from exp([A B; 0 0] dt). The controller adds the integral I, the
// derivative state D and the previous measurement: with r = 0,
//   I_{k+1} = I_k - ki dt x_k,
//   D_k     = (Tf D_{k-1} - kd (x_k - x_{k-1})) / (Tf + dt),  Tf = 1/(2 pi f_D),
//   u_k     = -kp x_k + I_{k+1} + D_k,
// five states in all. For a free mass under D alone this reduces to
// z^2 - (1 - a/2) z + a/2 with a = kd dt / m, whose Jury conditions give
// a < 2: the config's rule "kd dt / m below 2"; kp, ki, k and the filter move
// the limit (2000 Hz, default gains: kd below 3.59 N s/m out of contact).
// Checked out of contact (the plate alone: approach, retract) and, when the
// config simulates the contact, with the stuck contact's stiffness and
// damping in parallel.
//
// Force loops and the normal axis: the reading answers the drive one tick
// later with a static gain g, y_{k+1} = g u_k (the lateral force reading is
// the drive less the spring, whose k x the loop feeds forward: g = 1; the
// quasi-static normal axis: dN/dF = k_c / (k + k_c) in (0, 1] for the
// contact force, dz/dF = 1 / (k + k_c) in (0, 1/k] for the displacement).
// Same controller states. An integral loop alone has its pole at
// 1 - g ki dt: stable for g ki dt < 2. Checked over g in (0, g_max].
//
// The derivative filter and the supervisor's low-passes are backward-Euler
// first-order filters, y += dt/(Tf + dt) (x - y): their pole Tf/(Tf + dt) lies
// in [0, 1) at any cutoff, so they need no condition of their own.
#pragma once

#include <optional>
#include <string>

#include "daemon/pid.h"
#include "tribo/v1/daemon_config.pb.h"

namespace tribo::daemon {

// m x'' = u - k x - c x'
struct LateralPlant {
  double mass_kg = 0;
  double spring_n_per_m = 0;
  double damping_n_s_per_m = 0;
};

// The largest |z| of the closed-loop poles.
double lateral_loop_spectral_radius(const PidGains& gains, const LateralPlant& plant, double dt_s);
double delayed_gain_loop_spectral_radius(const PidGains& gains, double plant_gain, double dt_s);

// Every loop of the config's controller at its loop rate, on the plant the
// config describes: the sim section's for the simulated backend, otherwise
// the nominal transducer constants (transducer.lateral.moving_mass_kg is
// then required). The first unstable loop as an error naming the field, its
// value and the limit at this rate; nullopt when all are stable.
std::optional<std::string> check_loop_stability(const v1::DaemonConfig& config);

// The controller of one config on the simulated plant of another (the bench
// emulator: the register map's config drives physics_config's instrument).
std::optional<std::string> check_loop_stability(const v1::ControllerConfig& controller,
                                                const v1::DaemonConfig& physics_config);

}  // namespace tribo::daemon
