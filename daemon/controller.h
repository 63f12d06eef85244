// The control law of one tick: per axis, the mode of the present segment.
//
// Normal (Z) axis, drive = actuator force (N):
//   open-loop force       drive = setpoint (the springs absorb part of it)
//   closed-loop force     PID on the measured contact force, feed-forward =
//                         the setpoint (the PID adds what the springs absorb)
//   displacement          PID on the measured normal displacement,
//                         feed-forward = k_spring * setpoint (the spring force
//                         that holds the plate there out of contact)
// Lateral (X) axis:
//   displacement          PID on the measured position (the dissertation's
//                         I-PD loop), feed-forward = k_spring * setpoint
//                         (feedforward_gain 0 in the default config); with a
//                         friction model in the setpoints, plus the friction
//                         the observer predicts (daemon/friction_observer.h),
//                         added to the PID's output before its clamp
//   force                 PID on the measured lateral force, feed-forward =
//                         setpoint + k_spring * position (the drive whose
//                         inferred force is the setpoint). Once the tip has
//                         moved max_excursion from where the segment began
//                         (break-away), the axis holds that position with the
//                         displacement loop for the rest of the segment.
//   open-loop drive       drive = setpoint (safe stop sequence only)
// k_spring are the nominal transducer constants of the config.
//
// Every change of mode (and the first tick) resets the new loop bumplessly:
// its output continues from the present drive. So does switching the
// friction compensation on or off: the integrator gives up, or takes over,
// the compensation's share at that tick. The observer starts from a contact
// at rest each time the compensation is switched on (a delayed driving
// velocity, as if the command had been at rest for the whole delay). Gain changes are bumpless too
// (daemon/pid.h). A loop whose measurement is not finite holds its drive and
// flags SENSOR_INVALID; NaN never reaches the drive.
#pragma once

#include <cstddef>
#include <cstdint>

#include "daemon/delay_line.h"
#include "daemon/friction_observer.h"
#include "daemon/load_function.h"
#include "daemon/pid.h"
#include "hal/transducer.h"
#include "tribo/v1/daemon_config.pb.h"

namespace tribo::daemon {

enum class Loop : std::uint8_t {
  kLateralDisplacement,
  kLateralForce,
  kNormalForce,
  kNormalDisplacement,
};
constexpr int kLoopCount = 4;

struct ControllerParams {
  PidGains lateral;              // lateral displacement
  PidGains lateral_force;
  PidGains normal_force;
  PidGains normal_displacement;
  double period_s = 0;
  double lateral_spring_n_per_m = 0;
  double normal_spring_n_per_m = 0;
  ObserverSettings friction_observer;  // controller.friction_compensation
  // COMMANDED observer: how many ticks its driving velocity lags the commanded
  // (controller.friction_compensation.velocity_delay_s x loop_rate_hz, rounded).
  std::size_t friction_velocity_delay_ticks = 0;
  // ... then through a first-order lag of this time constant, s (0: none;
  // controller.friction_compensation.velocity_lag_s).
  double friction_velocity_lag_s = 0;
};

PidGains pid_gains_from_proto(const v1::PidGains& gains);
v1::PidGains pid_gains_to_proto(const PidGains& gains);
// Gains from the controller section, spring constants from the transducer
// section of the same config.
ControllerParams controller_params_from_config(const v1::DaemonConfig& config);
// Without a transducer section (no feed-forward spring constants).
ControllerParams controller_params_from_config(const v1::ControllerConfig& config);

struct ControlOutput {
  hal::DriveCommand drive;
  std::uint32_t flags = 0;  // tribo.v1.StatusFlag bits
  double lateral_setpoint_m = 0;  // the position recorded as the lateral setpoint
  double normal_setpoint_n = 0;   // the force recorded as the normal setpoint
  // The friction compensation's share of drive.lateral_force_n (0 when off).
  double friction_compensation_n = 0;
  bool friction_compensated = false;
};

// Setpoints of the default modes (open-loop normal force, lateral
// displacement), for callers that drive the loop without a protocol.
struct Setpoints {
  std::uint32_t segment = 0;
  double normal_force_n = 0;
  double lateral_position_m = 0;
  std::uint32_t ticks_per_sample = 1;
};

class Controller {
 public:
  explicit Controller(const ControllerParams& params);

  ControlOutput step(const TickSetpoints& setpoints, const hal::SensorFrame& sensors);
  ControlOutput step(const Setpoints& setpoints, const hal::SensorFrame& sensors);

  // Bumpless: the drive continues; the new gains act from the next tick.
  void set_gains(Loop loop, const PidGains& gains);
  const PidGains& gains(Loop loop) const;

  const hal::DriveCommand& last_drive() const { return drive_; }
  bool breakaway_hold() const { return breakaway_; }
  double hold_position_m() const { return hold_position_m_; }
  const ObserverState& friction_observer() const { return observer_; }
  // The friction compensation's share of the last lateral drive (0 when off).
  double last_compensation_n() const { return compensation_n_; }

 private:
  PidGains& gains_ref(Loop loop);
  PidState& state_ref(Loop loop);
  double normal_step(const TickSetpoints& sp, const hal::SensorFrame& f, ControlOutput& out);
  double lateral_step(const TickSetpoints& sp, const hal::SensorFrame& f, ControlOutput& out);
  double lateral_hold(const hal::SensorFrame& f, ControlOutput& out);
  double observer_velocity(double commanded_m_per_s);
  double friction_compensation(const TickSetpoints& sp, const hal::SensorFrame& f, ControlOutput& out);

  PidTerms& terms_ref(Loop loop);

  ControllerParams params_;
  // pid_terms of each loop's gains at params_.period_s, kept with the gains.
  PidTerms lateral_terms_, lateral_force_terms_, normal_force_terms_, normal_displacement_terms_;
  PidState lateral_displacement_, lateral_force_, normal_force_, normal_displacement_;
  bool normal_active_ = false;
  NormalMode normal_mode_ = NormalMode::kOpenLoopForce;
  bool lateral_active_ = false;
  LateralMode lateral_mode_ = LateralMode::kDisplacement;
  bool breakaway_ = false;
  double excursion_origin_m_ = 0;
  double hold_position_m_ = 0;
  const IdentifiedFriction* compensating_ = nullptr;  // the model in use, null: none
  double compensation_n_ = 0;                         // its last share of the drive
  ObserverState observer_;
  DelayLine observer_velocity_delay_;  // the commanded velocity, friction_velocity_delay_ticks ago
  double observer_velocity_lagged_ = 0;  // ... through the lag friction_velocity_lag_s
  hal::DriveCommand drive_;
};

}  // namespace tribo::daemon
