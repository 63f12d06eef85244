#include "daemon/daemon_config.h"

#include <cmath>
#include <sstream>

#include "hal/backend_factory.h"
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

std::optional<std::string> validate_pid(const std::string& at, const v1::PidGains& g) {
  for (auto [name, value] : {std::pair{"kp", g.kp()}, std::pair{"ki", g.ki()}, std::pair{"kd", g.kd()},
                             std::pair{"derivative_filter_hz", g.derivative_filter_hz()}}) {
    if (auto e = out_of_range(at + "." + name, value, 0, 1e9)) return e;
  }
  for (auto [name, value] : {std::pair{"setpoint_weight_p", g.setpoint_weight_p()},
                             std::pair{"setpoint_weight_d", g.setpoint_weight_d()}}) {
    if (auto e = out_of_range(at + "." + name, value, 0, 1)) return e;
  }
  if (!(g.output_min() < g.output_max())) {
    std::ostringstream msg;
    msg << at << ".output_min = " << g.output_min() << " must be below output_max = " << g.output_max();
    return msg.str();
  }
  return std::nullopt;
}

}  // namespace

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
  if (auto e = validate_pid("controller.lateral_displacement", ctl.lateral_displacement())) return e;
  if (auto e = out_of_range("limits.max_normal_force_n", lim.max_normal_force_n(), 1e-9, 1)) return e;
  if (auto e = out_of_range("limits.max_lateral_force_n", lim.max_lateral_force_n(), 1e-9, 1)) return e;
  if (auto e = out_of_range("limits.max_lateral_travel_m", lim.max_lateral_travel_m(), 1e-9, 1e-3)) return e;
  if (auto e = out_of_range("limits.min_velocity_m_per_s", lim.min_velocity_m_per_s(), 0, 1)) return e;
  if (auto e = out_of_range("limits.max_velocity_m_per_s", lim.max_velocity_m_per_s(),
                            lim.min_velocity_m_per_s(), 1)) return e;
  if (auto e = out_of_range("limits.max_segment_duration_s", lim.max_segment_duration_s(), 1e-3, 1e6)) return e;
  if (auto e = out_of_range("limits.max_protocol_duration_s", lim.max_protocol_duration_s(), 1e-3, 1e7)) return e;
  return hal::validate_backend_config(c);
}

std::optional<std::string> load_daemon_config(const std::string& path, v1::DaemonConfig& config) {
  if (auto e = wire::load_text_proto_file(path, config)) return e;
  if (auto e = validate_daemon_config(config)) return path + ": " + *e;
  return std::nullopt;
}

}  // namespace tribo::daemon
