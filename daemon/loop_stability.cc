#include "daemon/loop_stability.h"

#include <Eigen/Dense>
#include <unsupported/Eigen/MatrixFunctions>

#include <array>
#include <cmath>
#include <functional>
#include <sstream>
#include <vector>

#include "daemon/controller.h"

namespace tribo::daemon {

namespace {

// |z| = 1 within rounding is the edge, not beyond it (a loop without gains
// on an undamped plate: its poles lie on the circle).
constexpr double kUnitCircle = 1 + 1e-9;

double filter_time_s(const PidGains& g) {
  return g.derivative_filter_hz > 0 ? 1.0 / (2.0 * M_PI * g.derivative_filter_hz) : 0.0;
}

double spectral_radius(const Eigen::MatrixXd& transition) {
  return Eigen::EigenSolver<Eigen::MatrixXd>(transition, false).eigenvalues().cwiseAbs().maxCoeff();
}

// The controller's rows over a state whose columns `y` and `y_prev` hold the
// measurement and its previous value, `integral` and `derivative` the PID's
// states: the next integral, the new derivative and the drive (r = 0).
struct ControllerRows {
  Eigen::RowVectorXd integral, derivative, drive;
};

ControllerRows controller_rows(const PidGains& g, double dt, int size, int y, int integral, int derivative,
                               int y_prev) {
  const double tf = filter_time_s(g);
  ControllerRows r{Eigen::RowVectorXd::Zero(size), Eigen::RowVectorXd::Zero(size), Eigen::RowVectorXd::Zero(size)};
  r.integral(integral) = 1;
  r.integral(y) = -g.ki * dt;
  r.derivative(derivative) = tf / (tf + dt);
  r.derivative(y) = -g.kd / (tf + dt);
  r.derivative(y_prev) = g.kd / (tf + dt);
  r.drive = r.integral + r.derivative;
  r.drive(y) -= g.kp;
  return r;
}

std::string number(double v) {
  std::ostringstream s;
  s.precision(3);
  s << v;
  return s.str();
}

struct LoopCase {
  std::string plant;                               // what the plant is, for the message
  std::function<double(const PidGains&)> radius;   // spectral radius with these gains
};

struct Loop {
  const char* field;  // controller.<field>
  const char* name;   // for people
  PidGains gains;
  std::vector<LoopCase> cases;
};

// The largest value of one gain, the others as configured, below which the
// loop is stable: scanned from 0 up to the configured value for stable
// values, then the edge above the largest one bisected. nullopt when no value
// of it alone makes the loop stable.
std::optional<double> stable_limit(const LoopCase& c, PidGains gains, double PidGains::*gain) {
  const double configured = gains.*gain;
  if (!(configured > 0)) return std::nullopt;
  const auto stable = [&](double v) {
    gains.*gain = v;
    return c.radius(gains) <= kUnitCircle;
  };
  constexpr int kScan = 200;
  double lo = -1;
  for (int i = kScan - 1; i >= 0; --i) {
    const double v = configured * i / kScan;
    if (stable(v)) {
      lo = v;
      break;
    }
  }
  if (lo < 0) return std::nullopt;
  double hi = lo + configured / kScan;
  for (int i = 0; i < 60; ++i) {
    const double mid = (lo + hi) / 2;
    (stable(mid) ? lo : hi) = mid;
  }
  return hi;
}

std::optional<std::string> check_loop(const Loop& loop, double rate_hz) {
  for (const LoopCase& c : loop.cases) {
    const double radius = c.radius(loop.gains);
    if (radius <= kUnitCircle) continue;
    std::ostringstream unstable;
    unstable << "the sampled " << loop.name << " loop is unstable at controller.loop_rate_hz = " << rate_hz << " ("
             << c.plant << ": closed-loop pole at |z| = " << number(radius) << ", above 1)";
    const std::array<std::pair<const char*, double PidGains::*>, 3> gains{
        {{"kd", &PidGains::kd}, {"kp", &PidGains::kp}, {"ki", &PidGains::ki}}};
    for (const auto& [name, gain] : gains) {
      if (const auto limit = stable_limit(c, loop.gains, gain)) {
        std::ostringstream msg;
        msg << "controller." << loop.field << "." << name << " = " << loop.gains.*gain << ": " << unstable.str()
            << "; with the other gains as they are, " << name << " must be below " << number(*limit)
            << " at this rate (docs/control.md, \"Discrete-time stability\")";
        return msg.str();
      }
    }
    return "controller." + std::string(loop.field) + ": " + unstable.str() +
           "; lowering no single gain of it makes it stable at this rate: change its gains or raise the loop rate";
  }
  return std::nullopt;
}

LoopCase lateral_case(std::string plant, const LateralPlant& p, double dt) {
  return {std::move(plant), [p, dt](const PidGains& g) { return lateral_loop_spectral_radius(g, p, dt); }};
}

// The delayed static plant over g in (0, g_max]: where in that range the
// loop is least stable.
LoopCase delayed_case(std::string plant, double max_gain, double dt) {
  return {std::move(plant), [max_gain, dt](const PidGains& g) {
            double worst = 0;
            constexpr int kPoints = 40;  // log-spaced over three decades
            for (int i = 0; i < kPoints; ++i) {
              const double gain = max_gain * std::pow(10.0, -3.0 * i / (kPoints - 1));
              worst = std::max(worst, delayed_gain_loop_spectral_radius(g, gain, dt));
            }
            return worst;
          }};
}

struct Plants {
  std::vector<std::pair<std::string, LateralPlant>> lateral;
  double normal_spring_n_per_m = 0;
};

std::string lateral_text(const std::string& where, const LateralPlant& p) {
  return where + ", moving mass " + number(p.mass_kg) + " kg, spring " + number(p.spring_n_per_m) + " N/m, damping " +
         number(p.damping_n_s_per_m) + " N s/m";
}

Plants simulated_plants(const v1::SimConfig& sim) {
  Plants p;
  const LateralPlant free{sim.lateral().moving_mass_kg(), sim.lateral().spring_stiffness_n_per_m(),
                          sim.lateral().damping_n_s_per_m()};
  p.lateral.push_back({lateral_text("out of contact", free), free});
  const auto& f = sim.friction();
  if (f.contact_stiffness_n_per_m() > 0) {
    const LateralPlant stuck{free.mass_kg, free.spring_n_per_m + f.contact_stiffness_n_per_m(),
                             free.damping_n_s_per_m + f.bristle_damping_n_s_per_m()};
    p.lateral.push_back({lateral_text("tip stuck on the sample (sim.friction's contact in parallel)", stuck), stuck});
  }
  p.normal_spring_n_per_m = sim.normal().spring_stiffness_n_per_m();
  return p;
}

std::optional<std::string> check_controller(const v1::ControllerConfig& controller, const Plants& plants) {
  const double rate = controller.loop_rate_hz(), dt = 1.0 / rate;
  const ControllerParams params = controller_params_from_config(controller);
  Loop lateral{"lateral_displacement", "lateral displacement", params.lateral, {}};
  for (const auto& [text, plant] : plants.lateral) lateral.cases.push_back(lateral_case(text, plant, dt));
  const Loop loops[] = {
      lateral,
      {"lateral_force", "lateral force", params.lateral_force,
       {delayed_case("the force reading answers the drive a tick later, gain 1", 1.0, dt)}},
      {"normal_force", "normal force", params.normal_force,
       {delayed_case("the contact force answers the drive a tick later, gain up to 1", 1.0, dt)}},
      {"normal_displacement", "normal displacement", params.normal_displacement,
       {delayed_case("the displacement answers the drive a tick later, up to 1/k = " +
                         number(1 / plants.normal_spring_n_per_m) + " m/N",
                     1 / plants.normal_spring_n_per_m, dt)}},
  };
  for (const Loop& loop : loops) {
    if (auto e = check_loop(loop, rate)) return e;
  }
  return std::nullopt;
}

}  // namespace

double lateral_loop_spectral_radius(const PidGains& g, const LateralPlant& p, double dt) {
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  a(0, 1) = 1;
  a(1, 0) = -p.spring_n_per_m / p.mass_kg;
  a(1, 1) = -p.damping_n_s_per_m / p.mass_kg;
  a(1, 2) = 1 / p.mass_kg;
  const Eigen::Matrix3d e = (a * dt).exp();  // [Ad Bd; 0 1]
  // State: x, v, I, D, x_prev.
  enum { kX, kV, kI, kD, kXPrev, kSize };
  const ControllerRows c = controller_rows(g, dt, kSize, kX, kI, kD, kXPrev);
  Eigen::MatrixXd t = Eigen::MatrixXd::Zero(kSize, kSize);
  for (int row = 0; row < 2; ++row) {
    t(row, kX) = e(row, 0);
    t(row, kV) = e(row, 1);
    t.row(row) += e(row, 2) * c.drive;
  }
  t.row(kI) = c.integral;
  t.row(kD) = c.derivative;
  t(kXPrev, kX) = 1;
  return spectral_radius(t);
}

double delayed_gain_loop_spectral_radius(const PidGains& g, double plant_gain, double dt) {
  // State: y, I, D, y_prev; y_{k+1} = g u_k.
  enum { kY, kI, kD, kYPrev, kSize };
  const ControllerRows c = controller_rows(g, dt, kSize, kY, kI, kD, kYPrev);
  Eigen::MatrixXd t = Eigen::MatrixXd::Zero(kSize, kSize);
  t.row(kY) = plant_gain * c.drive;
  t.row(kI) = c.integral;
  t.row(kD) = c.derivative;
  t(kYPrev, kY) = 1;
  return spectral_radius(t);
}

std::optional<std::string> check_loop_stability(const v1::DaemonConfig& config) {
  if (config.backend_case() == v1::DaemonConfig::kSim) {
    return check_controller(config.controller(), simulated_plants(config.sim()));
  }
  const auto& lateral = config.transducer().lateral();
  if (!(lateral.moving_mass_kg() > 0)) {
    return "transducer.lateral.moving_mass_kg = " + number(lateral.moving_mass_kg()) +
           ": must be > 0 (the lateral loop's stability at controller.loop_rate_hz is checked on it)";
  }
  Plants plants;
  const LateralPlant free{lateral.moving_mass_kg(), lateral.spring_n_per_m(), 0};
  plants.lateral.push_back({lateral_text("out of contact (transducer's nominal constants)", free), free});
  plants.normal_spring_n_per_m = config.transducer().normal().spring_n_per_m();
  return check_controller(config.controller(), plants);
}

std::optional<std::string> check_loop_stability(const v1::ControllerConfig& controller,
                                                const v1::DaemonConfig& physics_config) {
  return check_controller(controller, simulated_plants(physics_config.sim()));
}

}  // namespace tribo::daemon
