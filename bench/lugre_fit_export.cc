// Exports the benchmark problem for analysis/bench_scipy_lugre.py: a synthetic
// scratch series (1 kHz, first 100 k samples), the inputs the LuGre model is
// driven by, a fixed starting point, and tribo's own fit from that start with
// its wall time. scipy's least_squares then fits the same model to the same
// data from the same start.
//   lugre_fit_export OUT_DIR
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

#include <nlohmann/json.hpp>
#include "analysis/models/lugre_fit.h"
#include "tests/analysis/synthetic_run.h"

using namespace tribo::analysis;

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: lugre_fit_export OUT_DIR\n";
    return 2;
  }
  const std::filesystem::path dir = argv[1];
  std::filesystem::create_directories(dir);
  tribo::testing::SyntheticOptions o;
  o.rate_hz = 1000;
  o.extra_loads = 1;
  MeasuredSeries s = tribo::testing::synthetic_run({}, 1, o);
  s = slice(s, 0, 100000);
  derive_motion(s, 0);
  const MotionSegmentation m = segment_motion(s);
  const ModelData d(s, m);
  std::vector<char> mask(s.size());
  for (std::size_t i = 0; i < mask.size(); ++i) mask[i] = !m.heldout[i];

  ModelStructure st;
  st.load_scaled = true;
  ModelParams start = base_params(d, st);
  // A fixed start away from the truth (0.10, 0.143, 1.2 µm/s, 3414.6, 5.5, 0.5, 0).
  start.set_value("mu_c", 0.08);
  start.set_value("mu_s", 0.18);
  start.set_value("vs", 2e-6);
  start.set_value("sigma0", 2000);
  start.set_value("sigma1", 1.0);
  start.set_value("Fv", 0.2);
  start.set_value("offset", 0.0);

  {
    std::ofstream out(dir / "problem.csv");
    out.precision(17);
    out << "t_s,position_m,drive_velocity_m_per_s,step_velocity_m_per_s,normal_n,force_n,in_fit\n";
    for (std::size_t i = 0; i < s.size(); ++i) {
      out << s.time_s[i] << ',' << s.position_m[i] << ',' << d.drive_velocity[i] << ',' << d.step_velocity[i] << ','
          << s.normal_force_n[i] << ',' << s.force_n[i] << ',' << static_cast<int>(mask[i]) << '\n';
    }
  }

  const auto t0 = std::chrono::steady_clock::now();
  FitOptions fo;
  fo.max_iterations = 100;
  const FitResult single = fit_model(d, start, mask, fo);
  const auto t1 = std::chrono::steady_clock::now();
  const LugreFit full = fit_lugre(d, st, mask);
  const auto t2 = std::chrono::steady_clock::now();

  nlohmann::ordered_json j;
  j["samples"] = s.size();
  j["fit_samples"] = single.n;
  j["force_scale"] = d.force_scale;
  j["speed_ref"] = d.speed_ref;
  j["start"] = nlohmann::ordered_json::array();
  for (std::size_t k = 0; k < start.specs.size(); ++k) {
    const ParamSpec& p = start.specs[k];
    j["start"].push_back({{"name", p.name},
                          {"transform", p.transform == Transform::kLog ? "log" : "linear"},
                          {"scale", p.scale},
                          {"theta", start.theta[k]},
                          {"value", param_value(p, start.theta[k])}});
  }
  nlohmann::ordered_json values;
  for (const auto& e : single.estimates) values[e.name] = e.value;
  j["tribo_single_start"] = {{"seconds", std::chrono::duration<double>(t1 - t0).count()},
                             {"rss", single.rss},
                             {"jacobians", single.iterations},
                             {"values", std::move(values)}};
  j["tribo_full_fit"] = {{"seconds", std::chrono::duration<double>(t2 - t1).count()},
                         {"rss", full.result.rss},
                         {"starts_evaluated", full.starts_evaluated},
                         {"starts_refined", full.starts_refined}};
  const std::string text = j.dump(2) + "\n";
  std::ofstream(dir / "tribo_fit.json") << text;
  std::cout << text;
  return 0;
}
