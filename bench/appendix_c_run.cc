// Appendix C's simulated experiment (dissertation Appendix C: hyssim04.m /
// hysitronmod04.m / hysfricfcn04.m) solved by tribo's plant, for the
// comparison with scipy's LSODA in bench/lsoda_compare.py.
//
// The experiment: m = 1 g on no transducer spring, the modified LuGre of
// Appendix C (zs = 0.41 um, z0 = zs / 3.1, Fs = 1400 uN, sigma0 = Fs / zs,
// sigma1 = 3 sqrt(m sigma0), sigma2 = 0.001, vs = 1.2 um/s), pulled for 1 s
// by the continuous I-PD loop Fd = I - mk x - mkd v, dI/dt = mki (r - x),
// r = 18 um/s t, mk = 1394, mki = 7167, mkd = 50.
//
// In tribo's plant the P and D terms are exact: they are a spring mk and a
// damper mkd on the plate. The integral term is the drive, held over each
// tick at its value mid-tick, I_k + mki (r_k - x_k) dt / 2 (second order in
// dt). The contact load is 9810 uN, Fs / N = 1400 / 9810.
//
// Usage: sim_appendix_c LOOP_RATE_HZ MAX_H_LAMBDA OUT.csv [repeats]
// Writes t_s,x_m,v_m_per_s,z_m,friction_n every 1 ms and prints the wall
// time of one run (the fastest of `repeats`), excluding output.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "sim/instrument.h"

namespace {

using namespace tribo::sim;

InstrumentParams appendix_c() {
  const double m = 1e-3, zs = 0.41e-6, z0 = zs / 3.1, fs = 1400e-6, s0 = fs / zs, load = 9810e-6;
  InstrumentParams p;
  p.lateral = LateralAxisParams{m, 1394.0, 50.0, {}};                         // mk, mkd folded in
  p.normal = NormalAxisParams{1e-9, 50e-6, 18e9, 0.785, 0, 0, 0, 0, 1e-9};     // load passes to the contact
  p.friction.lugre = LugreParams{s0, 3 * std::sqrt(m * s0), 0.001, fs / load, s0 * z0 / load, 1.2e-6, 1.0, 0.0};
  p.lateral_sensing.plates = p.lateral_sensing.calibrated = PlateGeometry{1e-4, 120e-6, 120e-6};
  p.lateral_sensing.excitation_voltage_v = 5;
  p.lateral_sensing.feedback_capacitance_f = 1e-12;
  p.integrator = IntegratorSettings{1.0, 100000, false};
  return p;
}

struct Row {
  double t, x, v, z, f;
};

std::vector<Row> run(double rate_hz, double max_h_lambda) {
  InstrumentParams p = appendix_c();
  p.integrator.max_h_lambda = max_h_lambda;
  SimInstrument sim(p, 1);
  const double dt = 1.0 / rate_hz, mki = 7167.0, v_pull = 18e-6;
  const long ticks = std::lround(1.0 / dt), every = std::lround(1e-3 / dt);
  std::vector<Row> rows;
  rows.reserve(1001);
  rows.push_back({0, 0, 0, 0, 0});
  double integral = 0;
  for (long k = 0; k < ticks; ++k) {
    const double t = static_cast<double>(k) * dt;
    const double error = v_pull * t - sim.truth().lateral.position_m;
    sim.step(DriveInput{9810e-6, integral + mki * error * dt / 2}, dt);
    integral += mki * dt * (error + (v_pull * (t + dt) - sim.truth().lateral.position_m)) / 2;
    if ((k + 1) % every == 0) {
      const InstrumentTruth& s = sim.truth();
      rows.push_back({t + dt, s.lateral.position_m, s.lateral.velocity_m_per_s, s.lateral.bristle_m, s.friction_n});
    }
  }
  return rows;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: %s LOOP_RATE_HZ MAX_H_LAMBDA OUT.csv [repeats]\n", argv[0]);
    return 2;
  }
  const double rate = std::atof(argv[1]), h_lambda = std::atof(argv[2]);
  const int repeats = argc > 4 ? std::atoi(argv[4]) : 5;
  std::vector<Row> rows;
  double best = 1e9;
  for (int i = 0; i < repeats; ++i) {
    const auto start = std::chrono::steady_clock::now();
    rows = run(rate, h_lambda);
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  std::FILE* out = std::fopen(argv[3], "w");
  if (!out) return 1;
  std::fprintf(out, "t_s,x_m,v_m_per_s,z_m,friction_n\n");
  for (const Row& r : rows) std::fprintf(out, "%.17g,%.17g,%.17g,%.17g,%.17g\n", r.t, r.x, r.v, r.z, r.f);
  std::fclose(out);
  std::printf("%.9f\n", best);
  return 0;
}
