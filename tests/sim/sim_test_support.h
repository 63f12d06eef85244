// Shared set-up for sim tests: the default config's instrument, optionally
// without sensor noise, and a closed loop (controller + simulated backend)
// driven by explicit setpoint functions.
#pragma once

#include <cmath>
#include <functional>
#include <string>

#include "daemon/controller.h"
#include "daemon/daemon_config.h"
#include "hal/sim_transducer.h"
#include "sim/instrument_params.h"
#include "tests/support/daemon_process.h"

namespace tribo::testing {

inline v1::DaemonConfig default_config() {
  v1::DaemonConfig config;
  if (auto error = daemon::load_daemon_config(DaemonProcess::default_config_path(), config)) {
    throw std::runtime_error(*error);
  }
  return config;
}

// The contact curve-fitted to Table 5.1 and Fig. 4.22
// (config/instruments/fitted_contact.textproto: the direct effect on the tip's
// velocity, a dwell term), everything else the default's. Tests that hold that
// contact's figures use it.
inline v1::DaemonConfig fitted_contact_config() {
  v1::DaemonConfig config;
  const std::string path = std::string(TRIBO_SOURCE_DIR) + "/config/instruments/fitted_contact.textproto";
  if (auto error = daemon::load_daemon_config(path, config)) throw std::runtime_error(*error);
  return config;
}

// The plain LuGre plant: config/instruments/lugre_plain.textproto (LuGre with
// its Stribeck curve, Appendix C's loop gains) with the default's position
// ADC range (excitation 3.5 V; lugre_plain keeps the 5 V that saturated at
// +13.77 um). Tests of the LuGre plant, of
// its optional effects one at a time and of the integrator use it: they test
// the plant model on a declared plant, not the default instrument (whose
// contact adds elasto-plastic presliding and rate-and-state:
// tests/sim/breakaway_test.cc).
inline v1::DaemonConfig plain_lugre_config() {
  v1::DaemonConfig config;
  const std::string path = std::string(TRIBO_SOURCE_DIR) + "/config/instruments/lugre_plain.textproto";
  if (auto error = daemon::load_daemon_config(path, config)) throw std::runtime_error(*error);
  config.mutable_sim()->mutable_lateral()->mutable_sensing()->set_excitation_voltage_v(
      default_config().sim().lateral().sensing().excitation_voltage_v());
  return config;
}

// No sensor noise, drift or quantisation anywhere: the sensors report the truth
// (as the instrument's electronics see it).
inline void silence_sensors(v1::DaemonConfig& config) {
  config.mutable_sim()->mutable_sensors()->Clear();
  auto* sensing = config.mutable_sim()->mutable_lateral()->mutable_sensing();
  sensing->set_white_noise_m(0);
  sensing->set_low_frequency_noise_m(0);
  sensing->set_drift_m_per_s(0);
  sensing->set_adc_bits(0);
}

// The first reading of a fresh simulated session (no faults): the instrument
// at rest, its sensor noise drawn from this seed. Rearm reports this; a run
// starts from it.
inline hal::SensorFrame reading_at_rest(const v1::DaemonConfig& config, std::uint64_t seed) {
  hal::SimTransducer transducer(sim::instrument_params_from_config(config.sim()), seed,
                                config.controller().loop_rate_hz(), false);
  hal::SensorFrame frame;
  transducer.read(frame);
  return frame;
}

// RMS of the lateral position noise at rest (white per sample and the
// low-frequency wander of Table 3.2's floor): a still tip reads within a few
// of these of where it is.
inline double lateral_position_noise_m(const v1::DaemonConfig& config) {
  const auto& s = config.sim().lateral().sensing();
  return std::hypot(s.white_noise_m(), s.low_frequency_noise_m());
}

struct LoopSetpoints {
  double normal_force_n;
  double lateral_position_m;
};

// Runs controller and simulated instrument in lock-step for duration_s;
// observe(time, transducer) is called after every tick.
inline void run_closed_loop(const v1::DaemonConfig& config, std::uint64_t seed, double duration_s,
                            const std::function<LoopSetpoints(double)>& setpoints,
                            const std::function<void(double, const hal::SimTransducer&)>& observe) {
  hal::SimTransducer transducer(sim::instrument_params_from_config(config.sim()), seed,
                                config.controller().loop_rate_hz(), false);
  daemon::Controller controller(daemon::controller_params_from_config(config.controller()));
  const double dt = transducer.period_s();
  const auto ticks = static_cast<long>(std::llround(duration_s / dt));
  for (long k = 0; k < ticks; ++k) {
    const double t = static_cast<double>(k) * dt;
    const LoopSetpoints sp = setpoints(t);
    daemon::Setpoints s;
    s.normal_force_n = sp.normal_force_n;
    s.lateral_position_m = sp.lateral_position_m;
    hal::SensorFrame frame;
    transducer.read(frame);
    transducer.write(controller.step(s, frame).drive);
    transducer.wait_next_tick();
    observe(t + dt, transducer);
  }
}

}  // namespace tribo::testing
