#include "daemon/daemon_config.h"

#include <sched.h>

#include <array>
#include <cmath>
#include <sstream>
#include <utility>

#include "daemon/electrostatic_drive.h"
#include "daemon/loop_stability.h"
#include "hal/backend_factory.h"
#include "sim/fault_injection.h"
#include "proto/text_format_file.h"

namespace tribo::daemon {

namespace {

std::optional<std::string> out_of_range(const std::string& field, double value, double min,
                                        double max) {
  if (value >= min && value <= max) return std::nullopt;
  std::ostringstream msg;
  msg << field << " = " << value << ": must be in [" << min << ", " << max << "]";
  return msg.str();
}

std::optional<std::string> validate_transducer_axis(const std::string& at,
                                                    const v1::TransducerAxisConstants& a,
                                                    double min_stiffness_ratio) {
  const std::pair<const char*, std::array<double, 3>> fields[] = {
      {"spring_n_per_m", {a.spring_n_per_m(), 1e-3, 1e6}},
      {"plate_area_m2", {a.plate_area_m2(), 1e-12, 1}},
      {"gap_positive_m", {a.gap_positive_m(), 1e-9, 1e-2}},
      {"gap_negative_m", {a.gap_negative_m(), 1e-9, 1e-2}},
      {"bias_v", {a.bias_v(), 0, 1e4}},
      {"max_drive_v", {a.max_drive_v(), 1e-3, 1e5}},
      {"relative_permittivity", {a.relative_permittivity(), 1, 1e3}},
      {"moving_mass_kg", {a.moving_mass_kg(), 0, 1}}};
  for (const auto& [name, f] : fields) {
    if (auto e = out_of_range(at + "." + name, f[0], f[1], f[2])) return e;
  }
  // The bias alone must not pull the plate in at rest.
  const DriveAssessment rest = assess_drive(electrostatic_axis_from_config(a), 0.0, 0.0, 0.0);
  if (rest.stiffness_ratio < min_stiffness_ratio) {
    std::ostringstream msg;
    msg << at << ".bias_v = " << a.bias_v() << ": the bias alone adds " << rest.negative_stiffness_n_per_m
        << " N/m of negative stiffness at rest, leaving k_eff/k = " << rest.stiffness_ratio
        << " below supervisor.min_stiffness_ratio = " << min_stiffness_ratio << " (the plate would snap down)";
    return msg.str();
  }
  return std::nullopt;
}

std::optional<std::string> validate_supervisor(const v1::DaemonConfig& c) {
  const auto& s = c.supervisor();
  const double nyquist = c.controller().loop_rate_hz() / 2;
  const std::string at = "supervisor.";
  const std::pair<const char*, std::array<double, 3>> fields[] = {
      {"force_filter_hz", {s.force_filter_hz(), 1e-3, nyquist}},
      {"motion_filter_hz", {s.motion_filter_hz(), 1e-3, nyquist}},
      {"max_lateral_speed_m_per_s", {s.max_lateral_speed_m_per_s(), 1e-9, 10}},
      {"max_lateral_acceleration_m_per_s2", {s.max_lateral_acceleration_m_per_s2(), 1e-9, 1e4}},
      {"frozen_sensor_ticks", {static_cast<double>(s.frozen_sensor_ticks()), 0, 1e7}},
      {"frozen_channel_ticks", {static_cast<double>(s.frozen_channel_ticks()), 0, 1e7}},
      {"stale_sensor_ticks", {static_cast<double>(s.stale_sensor_ticks()), 1, 1e7}},
      {"lateral_position_range_m", {s.lateral_position_range_m(), 1e-9, 1}},
      {"lateral_force_range_n", {s.lateral_force_range_n(), 1e-9, 10}},
      {"normal_force_range_n", {s.normal_force_range_n(), 1e-9, 10}},
      {"normal_displacement_range_m", {s.normal_displacement_range_m(), 1e-9, 1}},
      {"min_stiffness_ratio", {s.min_stiffness_ratio(), 0, 0.99}},
      {"contact_force_n", {s.contact_force_n(), 0, 1}},
      {"overrun_trip_count", {static_cast<double>(s.overrun_trip_count()), 0, 64}},
      {"overrun_window_s", {s.overrun_window_s(), 0, 3600}},
      {"tracking_error_m", {s.tracking_error_m(), 0, 1}},
      {"tracking_lag_s", {s.tracking_lag_s(), 0, 100}},
      {"unload_rate_n_per_s", {s.unload_rate_n_per_s(), 1e-9, 10}},
      {"hold_s", {s.hold_s(), 0, 60}},
      {"retract_speed_m_per_s", {s.retract_speed_m_per_s(), 1e-9, 1e-3}},
      {"max_friction_compensation_n", {s.max_friction_compensation_n(), 0, 1}}};
  for (const auto& [name, f] : fields) {
    if (auto e = out_of_range(at + name, f[0], f[1], f[2])) return e;
  }
  return std::nullopt;
}

}  // namespace

std::optional<std::string> validate_pid_gains(const std::string& at, const v1::PidGains& g) {
  for (auto [name, value] : {std::pair{"kp", g.kp()}, std::pair{"ki", g.ki()}, std::pair{"kd", g.kd()},
                             std::pair{"derivative_filter_hz", g.derivative_filter_hz()},
                             std::pair{"tracking_time_s", g.tracking_time_s()}}) {
    if (auto e = out_of_range(at + "." + name, value, 0, 1e9)) return e;
  }
  for (auto [name, value] : {std::pair{"setpoint_weight_p", g.setpoint_weight_p()},
                             std::pair{"setpoint_weight_d", g.setpoint_weight_d()}}) {
    if (auto e = out_of_range(at + "." + name, value, 0, 1)) return e;
  }
  if (auto e = out_of_range(at + ".feedforward_gain", g.feedforward_gain(), 0, 10)) return e;
  if (!v1::AntiWindup_IsValid(g.anti_windup())) return at + ".anti_windup is not a known value";
  if (!std::isfinite(g.output_min()) || !std::isfinite(g.output_max()) || !(g.output_min() < g.output_max())) {
    std::ostringstream msg;
    msg << at << ".output_min = " << g.output_min() << " must be below output_max = " << g.output_max();
    return msg.str();
  }
  return std::nullopt;
}

std::optional<std::string> validate_daemon_config(const v1::DaemonConfig& c) {
  const auto& ctl = c.controller();
  const auto& lim = c.limits();
  if (c.server().bind_address().empty()) return "server.bind_address is empty";
  if (auto e = out_of_range("server.port", c.server().port(), 0, 65535)) return e;
  if (auto e = out_of_range("server.max_frame_bytes", c.server().max_frame_bytes(), 1024, 64 << 20)) return e;
  if (c.server().client_queue_bytes() != 0) {
    if (auto e = out_of_range("server.client_queue_bytes", c.server().client_queue_bytes(), 64 << 10, 1u << 30)) return e;
  }
  if (c.recorder().data_dir().empty()) return "recorder.data_dir is empty";
  if (auto e = out_of_range("controller.loop_rate_hz", ctl.loop_rate_hz(), 1, 50000)) return e;
  if (auto e = out_of_range("controller.default_acquisition_rate_hz", ctl.default_acquisition_rate_hz(),
                            1e-3, ctl.loop_rate_hz())) return e;
  if (auto e = out_of_range("controller.loop_realtime_priority", ctl.loop_realtime_priority(), 0, 99)) return e;
  if (ctl.has_loop_cpu()) {
    if (auto e = out_of_range("controller.loop_cpu", ctl.loop_cpu(), 0, CPU_SETSIZE - 1)) return e;
  }
  if (auto e = validate_pid_gains("controller.lateral_displacement", ctl.lateral_displacement())) return e;
  if (auto e = validate_pid_gains("controller.lateral_force", ctl.lateral_force())) return e;
  if (auto e = validate_pid_gains("controller.normal_force", ctl.normal_force())) return e;
  if (auto e = validate_pid_gains("controller.normal_displacement", ctl.normal_displacement())) return e;
  const auto& fc = ctl.friction_compensation();
  if (auto e = out_of_range("controller.friction_compensation.observer_gain_per_s", fc.observer_gain_per_s(), 0, 1e6)) return e;
  if (auto e = out_of_range("controller.friction_compensation.velocity_filter_hz", fc.velocity_filter_hz(), 0,
                            ctl.loop_rate_hz())) return e;
  if (!v1::FrictionObserverVelocity_IsValid(fc.velocity_source())) {
    return "controller.friction_compensation.velocity_source is not a known value";
  }
  if (auto e = out_of_range("controller.friction_compensation.velocity_delay_s", fc.velocity_delay_s(), 0, 1)) return e;
  if (auto e = out_of_range("controller.friction_compensation.velocity_lag_s", fc.velocity_lag_s(), 0, 1)) return e;
  for (const auto& [name, value] : {std::pair{"velocity_delay_s", fc.velocity_delay_s()},
                                    std::pair{"velocity_lag_s", fc.velocity_lag_s()}}) {
    if (value != 0 && fc.velocity_source() == v1::MEASURED) {
      std::ostringstream msg;
      msg << "controller.friction_compensation." << name << " = " << value
          << ": must be 0 with velocity_source MEASURED (it shapes the commanded velocity)";
      return msg.str();
    }
  }
  if (fc.contact_state_from_measured_velocity()) {
    if (fc.velocity_source() == v1::MEASURED) {
      return "controller.friction_compensation.contact_state_from_measured_velocity = true: must be false with "
             "velocity_source MEASURED (every state already follows the measured velocity)";
    }
    if (!(fc.velocity_filter_hz() > 0)) {
      std::ostringstream msg;
      msg << "controller.friction_compensation.contact_state_from_measured_velocity = true: needs "
             "velocity_filter_hz > 0, not "
          << fc.velocity_filter_hz() << " (unfiltered differences of the readings are noise)";
      return msg.str();
    }
  }
  if (auto e = out_of_range("limits.max_normal_force_n", lim.max_normal_force_n(), 1e-9, 1)) return e;
  if (auto e = out_of_range("limits.max_lateral_force_n", lim.max_lateral_force_n(), 1e-9, 1)) return e;
  if (auto e = out_of_range("limits.max_lateral_travel_m", lim.max_lateral_travel_m(), 1e-9, 1e-3)) return e;
  if (auto e = out_of_range("limits.min_velocity_m_per_s", lim.min_velocity_m_per_s(), 0, 1)) return e;
  if (auto e = out_of_range("limits.max_velocity_m_per_s", lim.max_velocity_m_per_s(),
                            lim.min_velocity_m_per_s(), 1)) return e;
  if (auto e = out_of_range("limits.max_segment_duration_s", lim.max_segment_duration_s(), 1e-3, 1e6)) return e;
  if (auto e = out_of_range("limits.max_protocol_duration_s", lim.max_protocol_duration_s(), 1e-3, 1e7)) return e;
  if (auto e = out_of_range("limits.max_normal_travel_m", lim.max_normal_travel_m(), 1e-9, 1e-3)) return e;
  if (auto e = out_of_range("limits.breakpoint_guard_m", lim.breakpoint_guard_m(), 0, lim.max_lateral_travel_m())) return e;
  if (auto e = out_of_range("limits.planning_friction_coeff", lim.planning_friction_coeff(), 0, 10)) return e;
  if (auto e = validate_supervisor(c)) return e;
  if (auto e = validate_transducer_axis("transducer.normal", c.transducer().normal(),
                                        c.supervisor().min_stiffness_ratio())) return e;
  if (auto e = validate_transducer_axis("transducer.lateral", c.transducer().lateral(),
                                        c.supervisor().min_stiffness_ratio())) return e;
  const auto& at = c.autotune();
  if (auto e = out_of_range("autotune.relay_amplitude_n", at.relay_amplitude_n(), 1e-9, lim.max_lateral_force_n())) return e;
  if (auto e = out_of_range("autotune.hysteresis_m", at.hysteresis_m(), 0, 1e-6)) return e;
  if (auto e = out_of_range("autotune.position_m", at.position_m(), -lim.max_lateral_travel_m(), lim.max_lateral_travel_m())) return e;
  if (auto e = out_of_range("autotune.cycles", at.cycles(), 1, 1000)) return e;
  if (auto e = out_of_range("autotune.max_duration_s", at.max_duration_s(), 1e-3, 600)) return e;
  if (c.backend_case() == v1::DaemonConfig::kSim) {
    if (auto e = sim::validate_fault_schedule(c.sim().faults())) return e;
  }
  if (auto e = hal::validate_backend_config(c)) return e;
  return check_loop_stability(c);
}

std::optional<std::string> load_daemon_config(const std::string& path, v1::DaemonConfig& config) {
  if (auto e = wire::load_text_proto_file(path, config)) return e;
  if (auto e = validate_daemon_config(config)) return path + ": " + *e;
  return std::nullopt;
}

}  // namespace tribo::daemon
