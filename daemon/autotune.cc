#include "daemon/autotune.h"

#include "daemon/acquisition.h"
#include "tribo/v1/api.pb.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <sstream>
#include <vector>

namespace tribo::daemon {

namespace {

constexpr double kSteadySpread = 0.02;  // (max - min) / mean of the measured cycles
constexpr double kSteadyDrift = 0.005;  // between consecutive windows of cycles
constexpr double kHoldS = 1.0;      // hold before the relay: the I-PD lag decays (tau ~0.2 s)
constexpr double kBiasWindowS = 0.2;  // the bias is the mean drive over this

class Axis {
 public:
  Axis(hal::Transducer& t, const AutotuneParams& p) : t_(t), p_(p), dt_(t.period_s()) { t_.read(frame_); }

  double position() const { return frame_.lateral_position_m; }
  double drive() const { return drive_; }
  std::uint64_t ticks() const { return ticks_; }
  bool out_of_travel() const {
    return !std::isfinite(frame_.lateral_position_m) || std::fabs(frame_.lateral_position_m) > p_.max_travel_m;
  }
  // The experiment must end now: emergency stop or a refused command.
  bool stopped() const { return emergency_ || refused_; }
  bool emergency_stopped() const { return emergency_; }
  bool command_refused() const { return refused_; }

  // One tick. After a stop every call writes a zero drive only.
  void apply(double lateral_drive_n) {
    const bool emergency_now =
        !stopped() && p_.stop_requested != nullptr && p_.stop_requested->load(std::memory_order_relaxed);
    if (emergency_now) emergency_ = true;
    if (!stopped() && !(std::fabs(lateral_drive_n) <= p_.max_lateral_drive_n)) refused_ = true;
    drive_ = stopped() ? 0.0 : lateral_drive_n;
    t_.write(hal::DriveCommand{0.0, drive_});
    // Acted on: the zero drive is written.
    if (emergency_now && p_.stop_acted_ns != nullptr) p_.stop_acted_ns->store(now_ns(), std::memory_order_relaxed);
    t_.wait_next_tick();
    const hal::IoResult read = t_.read(frame_);
    ++ticks_;
    record(read);
  }

  // What the next ticks record: the segment and the lateral setpoint.
  void set_phase(std::uint32_t segment, double setpoint_m) {
    segment_ = segment;
    setpoint_m_ = setpoint_m;
  }

  // Moves the PID setpoint from `from` to `to` at the move speed, then holds
  // for hold_s; returns the mean drive over the last bias window.
  double move(PidState& s, double from, double to, double hold_s) {
    const double distance = to - from;
    const auto move_ticks = static_cast<std::uint64_t>(std::ceil(std::fabs(distance) / p_.move_speed_m_per_s / dt_));
    const auto hold_ticks = static_cast<std::uint64_t>(std::ceil(hold_s / dt_));
    const auto window = static_cast<std::uint64_t>(std::ceil(kBiasWindowS / dt_));
    double sum = 0;
    std::uint64_t n = 0;
    for (std::uint64_t k = 0; k < move_ticks + hold_ticks && !out_of_travel() && !stopped(); ++k) {
      const double r = k < move_ticks ? from + distance * static_cast<double>(k + 1) / static_cast<double>(move_ticks) : to;
      setpoint_m_ = r;
      apply(pid_update(p_.present, r, position(), 0.0, dt_, s));
      if (k + window >= move_ticks + hold_ticks) {
        sum += drive_;
        ++n;
      }
    }
    return n > 0 ? sum / static_cast<double>(n) : drive_;
  }

 private:
  static std::int64_t now_ns() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::steady_clock::now().time_since_epoch()).count();
  }

  // The tick as the run loop records one (time: the reading's, after the wait).
  void record(hal::IoResult read) {
    if (p_.samples == nullptr) return;
    std::uint32_t flags = read == hal::IoResult::kOk ? 0u : static_cast<std::uint32_t>(v1::SENSOR_INVALID);
    if (stopped()) flags |= v1::SAFE_UNLOAD;
    // The lateral position as a run records it (with the record's readout noise, if any).
    const Sample tick{static_cast<double>(ticks_) * dt_, segment_, 0.0, frame_.normal_force_n,
                      frame_.normal_displacement_m, setpoint_m_, frame_.recorded_lateral_position_m(),
                      frame_.lateral_force_n, flags};
    Sample out;
    if (!acquisition_.add(tick, std::max<std::uint32_t>(1, p_.ticks_per_sample), out)) return;
    if (!p_.samples->try_push(out) && p_.samples_dropped != nullptr) {
      p_.samples_dropped->fetch_add(1, std::memory_order_relaxed);
    }
  }

  hal::Transducer& t_;
  const AutotuneParams& p_;
  Acquisition acquisition_;
  std::uint32_t segment_ = 0;
  double setpoint_m_ = 0;
  bool emergency_ = false, refused_ = false;
  double dt_;
  hal::SensorFrame frame_;
  double drive_ = 0;
  std::uint64_t ticks_ = 0;
};

double tail_mean(const std::vector<double>& v, std::size_t n, std::size_t skip = 0) {
  double sum = 0;
  for (std::size_t i = v.size() - n - skip; i < v.size() - skip; ++i) sum += v[i];
  return sum / static_cast<double>(n);
}

// (max - min) / mean of the last n values.
double spread(const std::vector<double>& v, std::size_t n) {
  const auto first = v.end() - static_cast<std::ptrdiff_t>(n);
  const auto [lo, hi] = std::minmax_element(first, v.end());
  double sum = 0;
  for (auto it = first; it != v.end(); ++it) sum += *it;
  return (*hi - *lo) / (sum / static_cast<double>(n));
}

// Settled: the last n values spread less than kSteadySpread, and their mean
// differs from the mean of the n before by less than kSteadyDrift (a slowly
// growing or beating oscillation is not yet the limit cycle).
bool settled(const std::vector<double>& v, std::size_t n) {
  if (v.size() < 2 * n) return false;
  const double last = tail_mean(v, n), before = tail_mean(v, n, n);
  return spread(v, n) < kSteadySpread && std::fabs(last - before) < kSteadyDrift * last;
}

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

}  // namespace

AutotuneResult relay_autotune(hal::Transducer& transducer, const AutotuneParams& p) {
  AutotuneResult result;
  const double dt = transducer.period_s();
  Axis axis(transducer, p);
  const double start = std::isfinite(axis.position()) ? axis.position() : 0.0;
  PidState pid;
  pid_reset(p.present, start, start, 0.0, 0.0, pid);
  const auto stopped = [&](AutotuneResult& r) {
    r.ticks = axis.ticks();
    r.emergency_stopped = axis.emergency_stopped();
    r.command_refused = axis.command_refused();
    r.error = axis.emergency_stopped() ? "emergency stop: the experiment stopped and the lateral drive went to zero"
                                       : "command refused: a non-finite or out-of-range lateral drive";
    return r;
  };
  axis.set_phase(0, start);
  const double bias = axis.move(pid, start, p.position_m, kHoldS);
  if (axis.stopped()) return stopped(result);
  if (axis.out_of_travel()) {
    axis.apply(0.0);
    result.error = "the lateral position left the travel while moving to the relay position";
    return result;
  }

  // The relay experiment. A lightly damped plant takes tens of cycles to
  // settle onto the limit cycle: measure once the last `cycles` periods and
  // amplitudes agree within kSteadySpread.
  const double d = p.relay_amplitude_n, eps = p.hysteresis_m;
  const std::size_t n = std::max<std::uint32_t>(2, p.cycles);
  double u = bias + d;
  std::vector<double> switch_times;  // switches to +d
  std::vector<double> periods, amplitudes;  // per cycle
  // At most one switch per two ticks: reserved here, nothing allocates in the loop.
  const std::size_t max_cycles = std::min<std::size_t>(static_cast<std::size_t>(p.max_duration_s / dt) / 2 + 2, 1u << 20);
  switch_times.reserve(max_cycles);
  periods.reserve(max_cycles);
  amplitudes.reserve(max_cycles);
  double lo = axis.position(), hi = axis.position();
  const auto max_ticks = static_cast<std::uint64_t>(p.max_duration_s / dt);
  bool steady = false;
  axis.set_phase(1, p.position_m);
  for (std::uint64_t k = 0; k < max_ticks && !steady; ++k) {
    const double e = p.position_m - axis.position();
    if (e > eps && u < bias) {
      u = bias + d;
      const double t = static_cast<double>(k) * dt;
      if (!switch_times.empty()) {
        periods.push_back(t - switch_times.back());
        amplitudes.push_back(0.5 * (hi - lo));
        steady = settled(periods, n) && settled(amplitudes, n);
      }
      switch_times.push_back(t);
      lo = hi = axis.position();
    } else if (e < -eps && u > bias) {
      u = bias - d;
    }
    lo = std::min(lo, axis.position());
    hi = std::max(hi, axis.position());
    axis.apply(u);
    if (axis.stopped()) return stopped(result);
    if (axis.out_of_travel()) {
      axis.apply(0.0);
      result.error = "the relay oscillation left the travel (" + fmt(p.max_travel_m * 1e6) +
                     " µm); lower the relay amplitude";
      return result;
    }
  }
  // Back to the start with the present PID, bumplessly.
  const double end_position = axis.position();
  pid_reset(p.present, end_position, end_position, 0.0, axis.drive(), pid);
  axis.set_phase(2, p.position_m);
  axis.move(pid, p.position_m, start, kHoldS);
  if (axis.stopped()) return stopped(result);
  result.ticks = axis.ticks();
  if (!steady) {
    result.error = "no steady limit cycle within " + fmt(p.max_duration_s) + " s (" +
                   std::to_string(periods.size()) + " relay cycles)";
    return result;
  }
  const double period = tail_mean(periods, n);
  const double amplitude = tail_mean(amplitudes, n);
  if (!(amplitude > eps)) {
    result.error = "the oscillation amplitude " + fmt(amplitude) + " m does not exceed the hysteresis";
    return result;
  }
  const double ku = 4 * d / (std::numbers::pi * std::sqrt(amplitude * amplitude - eps * eps));
  result.ok = true;
  result.ultimate_gain_n_per_m = ku;
  result.ultimate_period_s = period;
  result.amplitude_m = amplitude;
  result.cycles = static_cast<std::uint32_t>(n);
  result.settling_cycles = static_cast<std::uint32_t>(periods.size() - n);
  result.proposed = p.present;
  result.proposed.kp = 0.6 * ku;
  result.proposed.ki = result.proposed.kp / (period / 2);
  result.proposed.kd = result.proposed.kp * (period / 8);
  result.rule = "Ziegler-Nichols PID from the relay: kp = 0.6 Ku, ki = kp / (Pu/2), kd = kp Pu/8";
  return result;
}

}  // namespace tribo::daemon
