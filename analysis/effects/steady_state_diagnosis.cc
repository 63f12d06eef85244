#include "analysis/effects/steady_state_diagnosis.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

#include <Eigen/Dense>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

namespace tribo::analysis {

namespace {

struct ModelSpec {
  bool stribeck = false;
  bool per_direction = false;
  bool log_velocity = false;
  bool free_load_exponent = false;
};

struct Scales {
  double vs = 1;  // Stribeck velocity, m/s
  double p = 1;   // load exponent
};

// Facts of the data set every model shares.
struct Context {
  double exponent = 1;
  double v_ref = 1;  // geometric mean of |v|: ln(|v|/v_ref) has mean 0
  double n_ref = 1;  // median load
  bool has_load = false;
  double vs_lo = 0, vs_hi = 0;  // where the Stribeck scale is searched
};

int column_count(const ModelSpec& s) {
  const int levels = s.stribeck ? 2 : 1;
  return (s.per_direction ? 2 * (levels + 1) : levels + 2) + (s.log_velocity ? 1 : 0);
}

void fill_row(const ModelSpec& s, const Context& c, const Scales& k, const SteadyPoint& pt, double* phi) {
  const double v = pt.velocity_m_per_s;
  const double sgn = v > 0 ? 1.0 : -1.0;
  const double load = c.has_load ? std::pow(pt.load_n / c.n_ref, k.p) : 1.0;
  const double e = s.stribeck ? std::exp(-std::pow(std::fabs(v) / k.vs, c.exponent)) : 0.0;
  int j = 0;
  if (s.per_direction) {
    const double pos = v > 0 ? 1.0 : 0.0, neg = 1.0 - pos;
    phi[j++] = pos * load;
    phi[j++] = -neg * load;
    if (s.stribeck) {
      phi[j++] = pos * load * e;
      phi[j++] = -neg * load * e;
    }
    phi[j++] = pos * v;
    phi[j++] = neg * v;
  } else {
    phi[j++] = sgn * load;
    if (s.stribeck) phi[j++] = sgn * load * e;
    phi[j++] = v;
    phi[j++] = 1.0;
  }
  if (s.log_velocity) phi[j++] = sgn * load * std::log(std::fabs(v) / c.v_ref);
}

struct Solved {
  Eigen::VectorXd a;
  double cost = std::numeric_limits<double>::infinity();  // weighted sum of squares
  Eigen::MatrixXd covariance;
};

Solved solve(const ModelSpec& s, const Context& c, const Scales& k, const std::vector<SteadyPoint>& pts,
             const std::vector<std::size_t>& use, bool with_covariance) {
  const int m = column_count(s);
  const auto n = static_cast<Eigen::Index>(use.size());
  Eigen::MatrixXd A(n, m);
  Eigen::VectorXd b(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const SteadyPoint& pt = pts[use[static_cast<std::size_t>(i)]];
    const double sw = std::sqrt(pt.weight);
    double phi[16];
    fill_row(s, c, k, pt, phi);
    for (int j = 0; j < m; ++j) A(i, j) = sw * phi[j];
    b[i] = sw * pt.force_n;
  }
  Solved out;
  const auto qr = A.colPivHouseholderQr();
  out.a = qr.solve(b);
  out.cost = (A * out.a - b).squaredNorm();
  if (with_covariance && n > m && qr.rank() == m) {
    // Columns differ by orders of magnitude (N levels against N s/m times
    // µm/s): invert the normal matrix of unit-norm columns, then scale back.
    const double sigma2 = out.cost / static_cast<double>(n - m);
    const Eigen::VectorXd scale = A.colwise().norm().cwiseInverse().transpose();
    const Eigen::MatrixXd As = A * scale.asDiagonal();
    out.covariance = sigma2 * scale.asDiagonal() * (As.transpose() * As).inverse() * scale.asDiagonal();
  }
  return out;
}

double predict(const ModelSpec& s, const Context& c, const Scales& k, const Eigen::VectorXd& a, const SteadyPoint& pt) {
  double phi[16];
  fill_row(s, c, k, pt, phi);
  double y = 0;
  for (int j = 0; j < column_count(s); ++j) y += a[j] * phi[j];
  return y;
}

// The scales that minimise the cost over a grid (vs log-spaced, p linear).
struct ScaleGrid {
  std::vector<double> vs{1.0};
  std::vector<double> p{1.0};
};

ScaleGrid full_grid(const ModelSpec& s, const Context& c) {
  ScaleGrid g;
  if (s.stribeck) {
    g.vs.clear();
    constexpr int kN = 61;
    for (int i = 0; i < kN; ++i) g.vs.push_back(c.vs_lo * std::pow(c.vs_hi / c.vs_lo, i / double(kN - 1)));
  }
  if (s.free_load_exponent) {
    g.p.clear();
    for (int i = 0; i <= 40; ++i) g.p.push_back(0.05 * i);
  }
  return g;
}

// Around the all-data optimum: each held-out fold refits its scales here.
ScaleGrid local_grid(const ModelSpec& s, const Scales& best) {
  ScaleGrid g;
  g.vs = {best.vs};
  g.p = {best.p};
  if (s.stribeck) {
    g.vs.clear();
    for (int i = -8; i <= 8; ++i) g.vs.push_back(best.vs * std::pow(2.0, i / 4.0));
  }
  if (s.free_load_exponent) {
    g.p.clear();
    for (int i = -5; i <= 5; ++i) g.p.push_back(std::max(0.0, best.p + 0.1 * i));
  }
  return g;
}

Scales best_scales(const ModelSpec& s, const Context& c, const ScaleGrid& g, const std::vector<SteadyPoint>& pts,
                   const std::vector<std::size_t>& use, Solved& solved) {
  Scales best{g.vs.front(), g.p.front()};
  solved = Solved{};
  for (double vs : g.vs) {
    for (double p : g.p) {
      Solved trial = solve(s, c, {vs, p}, pts, use, false);
      if (trial.cost < solved.cost) {
        solved = std::move(trial);
        best = {vs, p};
      }
    }
  }
  return best;
}

std::vector<std::vector<std::size_t>> held_out_folds(const std::vector<SteadyPoint>& pts, std::string& scheme) {
  std::vector<std::size_t> order(pts.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return pts[a].velocity_m_per_s < pts[b].velocity_m_per_s;
  });
  const std::size_t k = pts.size() <= 200 ? pts.size() : 10;
  scheme = k == pts.size() ? "leave-one-out" : "10-fold";
  std::vector<std::vector<std::size_t>> folds(k);
  for (std::size_t i = 0; i < order.size(); ++i) folds[i % k].push_back(order[i]);
  return folds;
}

double weighted_rms(double sum_w_r2, double sum_w) { return sum_w > 0 ? std::sqrt(sum_w_r2 / sum_w) : 0; }

std::string model_name(const ModelSpec& s) {
  std::string name = s.stribeck ? "lugre_steady" : "coulomb_viscous";
  if (s.per_direction) name += "+direction_asymmetry";
  if (s.log_velocity) name += "+velocity_strengthening";
  if (s.free_load_exponent) name += "+load_dependence";
  return name;
}

// Named parameters (the Stribeck level as Fs = Fc + excess, with its error).
std::vector<SteadyParameter> parameters(const ModelSpec& s, const Context& c, const Scales& k, const Solved& f) {
  const std::string level_unit = c.has_load ? fmt::format("N at {:.6g} N", c.n_ref) : "N";
  auto se = [&](int i, int j = -1) {
    if (f.covariance.size() == 0) return std::numeric_limits<double>::quiet_NaN();
    double v = f.covariance(i, i);
    if (j >= 0) v += f.covariance(j, j) + 2 * f.covariance(i, j);
    return std::sqrt(std::max(0.0, v));
  };
  std::vector<SteadyParameter> out;
  int j = 0;
  if (s.per_direction) {
    out.push_back({"Fc_pos", f.a[0], se(0), level_unit});
    out.push_back({"Fc_neg", f.a[1], se(1), level_unit});
    j = 2;
    if (s.stribeck) {
      out.push_back({"Fs_pos", f.a[0] + f.a[2], se(0, 2), level_unit});
      out.push_back({"Fs_neg", f.a[1] + f.a[3], se(1, 3), level_unit});
      j = 4;
    }
    out.push_back({"Fv_pos", f.a[j], se(j), "N s/m"});
    out.push_back({"Fv_neg", f.a[j + 1], se(j + 1), "N s/m"});
    j += 2;
  } else {
    out.push_back({"Fc", f.a[0], se(0), level_unit});
    j = 1;
    if (s.stribeck) {
      out.push_back({"Fs", f.a[0] + f.a[1], se(0, 1), level_unit});
      j = 2;
    }
    out.push_back({"Fv", f.a[j], se(j), "N s/m"});
    out.push_back({"offset", f.a[j + 1], se(j + 1), "N"});
    j += 2;
  }
  if (s.log_velocity) out.push_back({"log_velocity_coeff", f.a[j], se(j), level_unit});
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (s.stribeck) out.push_back({"vs", k.vs, nan, "m/s"});
  if (s.log_velocity) out.push_back({"v_ref", c.v_ref, nan, "m/s"});
  if (c.has_load) out.push_back({"load_exponent", k.p, nan, "1"});
  return out;
}

double value_of(const SteadyModelFit& f, const std::string& name) {
  for (const auto& p : f.parameters) {
    if (p.name == name) return p.value;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

// Why a fitted model is not physical, or empty.
std::string unphysical(const ModelSpec& s, const SteadyModelFit& f, bool scale_at_edge, bool load_at_edge) {
  for (const auto& p : f.parameters) {
    const bool level = p.name.rfind("Fc", 0) == 0 || p.name.rfind("Fs", 0) == 0;
    if (level && p.value < 0) return fmt::format("{} = {:.4g} N is negative", p.name, p.value);
    if (p.name.rfind("Fv", 0) == 0 && p.value < 0) {
      return fmt::format("{} = {:.4g} N s/m: negative viscous friction", p.name, p.value);
    }
  }
  if (s.stribeck) {
    for (const char* dir : {"", "_pos", "_neg"}) {
      const double fc = value_of(f, std::string("Fc") + dir), fs = value_of(f, std::string("Fs") + dir);
      if (std::isfinite(fc) && std::isfinite(fs) && fs < fc) {
        return fmt::format("Fs{} = {:.4g} N below Fc{} = {:.4g} N", dir, fs, dir, fc);
      }
    }
    if (scale_at_edge) return "the Stribeck velocity vs is at the edge of the searched range: not determined by these points";
  }
  if (s.log_velocity && value_of(f, "log_velocity_coeff") <= 0) {
    return fmt::format("log_velocity_coeff = {:.4g} N: friction falls with velocity (weakening, not strengthening)",
                       value_of(f, "log_velocity_coeff"));
  }
  if (s.free_load_exponent && load_at_edge) return "the load exponent is at the edge of [0, 2]: not determined";
  return {};
}

struct Evaluated {
  SteadyModelFit fit;
  std::string unphysical;
};

Evaluated evaluate(const ModelSpec& s, const Context& c, const std::vector<SteadyPoint>& pts,
                   const std::vector<std::vector<std::size_t>>& folds) {
  std::vector<std::size_t> all(pts.size());
  std::iota(all.begin(), all.end(), 0);
  const ScaleGrid grid = full_grid(s, c);
  Solved solved;
  const Scales best = best_scales(s, c, grid, pts, all, solved);
  solved = solve(s, c, best, pts, all, true);
  Evaluated e;
  e.fit.name = model_name(s);
  e.fit.parameters = parameters(s, c, best, solved);
  double sum_w = 0, sum_w_r2 = 0;
  for (const auto& p : pts) {
    const double r = p.force_n - predict(s, c, best, solved.a, p);
    sum_w += p.weight;
    sum_w_r2 += p.weight * r * r;
  }
  e.fit.fit_rms_n = weighted_rms(sum_w_r2, sum_w);
  // Held out: each fold refits levels and scales without its points.
  const ScaleGrid local = local_grid(s, best);
  sum_w = sum_w_r2 = 0;
  std::vector<char> held(pts.size());
  for (const auto& fold : folds) {
    std::fill(held.begin(), held.end(), 0);
    for (std::size_t i : fold) held[i] = 1;
    std::vector<std::size_t> train;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      if (!held[i]) train.push_back(i);
    }
    Solved f;
    const Scales k = best_scales(s, c, local, pts, train, f);
    for (std::size_t i : fold) {
      const double r = pts[i].force_n - predict(s, c, k, f.a, pts[i]);
      sum_w += pts[i].weight;
      sum_w_r2 += pts[i].weight * r * r;
    }
  }
  e.fit.held_out_rms_n = weighted_rms(sum_w_r2, sum_w);
  const bool vs_edge = s.stribeck && (best.vs <= grid.vs.front() || best.vs >= grid.vs.back());
  const bool p_edge = s.free_load_exponent && (best.p <= grid.p.front() || best.p >= grid.p.back());
  e.unphysical = unphysical(s, e.fit, vs_edge, p_edge);
  return e;
}

Context make_context(const std::vector<SteadyPoint>& pts, const SteadyOptions& o) {
  Context c;
  c.exponent = o.stribeck_exponent;
  c.has_load = o.has_load;
  double log_sum = 0, lo = HUGE_VAL, hi = 0;
  std::vector<double> loads;
  for (const auto& p : pts) {
    const double a = std::fabs(p.velocity_m_per_s);
    log_sum += std::log(a);
    lo = std::min(lo, a);
    hi = std::max(hi, a);
    loads.push_back(p.load_n);
  }
  c.v_ref = std::exp(log_sum / static_cast<double>(pts.size()));
  c.vs_lo = lo / 3;
  c.vs_hi = hi * 3;
  std::nth_element(loads.begin(), loads.begin() + static_cast<std::ptrdiff_t>(loads.size() / 2), loads.end());
  c.n_ref = o.has_load ? loads[loads.size() / 2] : 1;
  return c;
}

void check_points(const std::vector<SteadyPoint>& pts, const SteadyOptions& o) {
  if (pts.size() < 4) throw std::invalid_argument(fmt::format("{} points: at least 4 are needed", pts.size()));
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const auto& p = pts[i];
    if (!std::isfinite(p.velocity_m_per_s) || !std::isfinite(p.force_n) || !std::isfinite(p.weight) || p.weight < 0) {
      throw std::invalid_argument(fmt::format("point {}: a non-finite value or a negative weight", i + 1));
    }
    if (p.velocity_m_per_s == 0) {
      throw std::invalid_argument(fmt::format("point {}: velocity 0 is not a steady sliding point", i + 1));
    }
    if (o.has_load && !(p.load_n > 0 && std::isfinite(p.load_n))) {
      throw std::invalid_argument(fmt::format("point {}: the load must be positive and finite", i + 1));
    }
  }
}

}  // namespace

SteadyDiagnosis diagnose_steady_state(const std::vector<SteadyPoint>& pts, const SteadyOptions& o) {
  check_points(pts, o);
  SteadyDiagnosis d;
  d.points = pts.size();
  d.has_load = o.has_load;
  const Context c = make_context(pts, o);
  const auto folds = held_out_folds(pts, d.held_out_scheme);

  // The base: the Stribeck term only if these points determine it and it pays.
  ModelSpec spec;
  const Evaluated plain = evaluate(spec, c, pts, folds);
  ModelSpec with_stribeck = spec;
  with_stribeck.stribeck = true;
  const Evaluated lugre = evaluate(with_stribeck, c, pts, folds);
  d.base_evidence = {plain.fit, lugre.fit};
  const bool lugre_pays = lugre.fit.held_out_rms_n <= (1 - o.acceptance_margin) * plain.fit.held_out_rms_n;
  if (lugre.unphysical.empty() && lugre_pays) {
    spec = with_stribeck;
    d.base = lugre.fit;
  } else {
    d.base = plain.fit;
    d.warnings.push_back("base model coulomb_viscous: the Stribeck term " +
                         (lugre.unphysical.empty() ? fmt::format("lowers the held-out RMS only {:+.1f} %",
                                                                 100 * (lugre.fit.held_out_rms_n / plain.fit.held_out_rms_n - 1))
                                                   : "is not physical here (" + lugre.unphysical + ")"));
    if (!plain.unphysical.empty()) d.warnings.push_back("base model: " + plain.unphysical);
  }

  SteadyModelFit current = d.base;
  for (;;) {
    std::vector<SteadyCandidate> round;
    int best = -1;
    ModelSpec best_spec;
    auto consider = [&](const char* effect, ModelSpec s) {
      SteadyCandidate cand;
      cand.effect = effect;
      if (static_cast<std::size_t>(column_count(s)) + 2 > pts.size()) {
        cand.reason = "too few points for its parameters";
        round.push_back(cand);
        return;
      }
      const Evaluated e = evaluate(s, c, pts, folds);
      cand.fit = e.fit;
      cand.change = e.fit.held_out_rms_n / current.held_out_rms_n - 1;
      if (!e.unphysical.empty()) {
        cand.reason = "rejected: " + e.unphysical;
      } else if (cand.change > -o.acceptance_margin) {
        cand.reason = fmt::format("rejected: held-out RMS {:+.1f} % (needs {:.0f} % lower)", 100 * cand.change,
                                  100 * o.acceptance_margin);
      } else {
        cand.accepted = true;
        cand.reason = fmt::format("held-out RMS {:+.1f} %", 100 * cand.change);
      }
      round.push_back(cand);
      if (cand.accepted && (best < 0 || cand.change < round[static_cast<std::size_t>(best)].change)) {
        best = static_cast<int>(round.size()) - 1;
        best_spec = s;
      }
    };
    if (!spec.per_direction) consider("direction_asymmetry", [&] { auto s = spec; s.per_direction = true; return s; }());
    if (!spec.log_velocity) consider("velocity_strengthening", [&] { auto s = spec; s.log_velocity = true; return s; }());
    if (o.has_load && !spec.free_load_exponent) {
      consider("load_dependence", [&] { auto s = spec; s.free_load_exponent = true; return s; }());
    }
    if (round.empty()) break;
    // Only the best of a round joins the model; the others are tried again on top of it.
    for (std::size_t i = 0; i < round.size(); ++i) {
      if (round[i].accepted && static_cast<int>(i) != best) {
        round[i].accepted = false;
        round[i].reason += ": passed, but " + round[static_cast<std::size_t>(best)].effect + " lowered it more";
      }
    }
    d.rounds.push_back(round);
    if (best < 0) break;
    spec = best_spec;
    current = round[static_cast<std::size_t>(best)].fit;
    d.accepted.push_back(round[static_cast<std::size_t>(best)].effect);
  }
  d.final_model = current;
  return d;
}

namespace {

nlohmann::ordered_json model_json(const SteadyModelFit& f) {
  nlohmann::ordered_json j;
  j["name"] = f.name;
  j["parameters"] = nlohmann::ordered_json::array();
  for (const auto& p : f.parameters) {
    nlohmann::ordered_json pj{{"name", p.name}, {"value", p.value}};
    pj["std_error"] = std::isfinite(p.std_error) ? nlohmann::ordered_json(p.std_error) : nlohmann::ordered_json();
    pj["unit"] = p.unit;
    j["parameters"].push_back(pj);
  }
  j["fit_rms_n"] = f.fit_rms_n;
  j["held_out_rms_n"] = f.held_out_rms_n;
  return j;
}

void print_model(std::string& out, const SteadyModelFit& f) {
  out += fmt::format("  {}: held-out RMS {:.4g} N, fit RMS {:.4g} N\n", f.name, f.held_out_rms_n, f.fit_rms_n);
  for (const auto& p : f.parameters) {
    out += std::isfinite(p.std_error) ? fmt::format("    {:<20} {:>12.6g} +- {:<10.3g} {}\n", p.name, p.value, p.std_error, p.unit)
                                      : fmt::format("    {:<20} {:>12.6g}                {}\n", p.name, p.value, p.unit);
  }
}

}  // namespace

std::string steady_diagnosis_json(const SteadyDiagnosis& d) {
  nlohmann::ordered_json j;
  j["mode"] = "steady_state";
  j["points"] = d.points;
  j["has_load"] = d.has_load;
  j["held_out"] = d.held_out_scheme;
  j["base_evidence"] = nlohmann::ordered_json::array();
  for (const auto& f : d.base_evidence) j["base_evidence"].push_back(model_json(f));
  j["base_model"] = model_json(d.base);
  j["rounds"] = nlohmann::ordered_json::array();
  for (const auto& round : d.rounds) {
    auto r = nlohmann::ordered_json::array();
    for (const auto& c : round) {
      nlohmann::ordered_json cj{{"effect", c.effect}, {"accepted", c.accepted}, {"held_out_change", c.change},
                                {"reason", c.reason}};
      if (!c.fit.name.empty()) cj["model"] = model_json(c.fit);
      r.push_back(cj);
    }
    j["rounds"].push_back(r);
  }
  j["accepted"] = d.accepted;
  j["final_model"] = model_json(d.final_model);
  j["warnings"] = d.warnings;
  return j.dump(2) + "\n";
}

std::string steady_diagnosis_text(const SteadyDiagnosis& d) {
  std::string out = fmt::format("steady-state diagnosis of {} points{}, held out: {}\n", d.points,
                                d.has_load ? " (with loads)" : "", d.held_out_scheme);
  out += "base model (the lower held-out RMS of):\n";
  for (const auto& f : d.base_evidence) {
    out += fmt::format("  {:<16} held-out RMS {:.4g} N{}\n", f.name, f.held_out_rms_n, f.name == d.base.name ? "  <- base" : "");
  }
  for (std::size_t r = 0; r < d.rounds.size(); ++r) {
    out += fmt::format("round {}:\n", r + 1);
    for (const auto& c : d.rounds[r]) {
      out += fmt::format("  {:<24} {}  {}\n", c.effect, c.accepted ? "ACCEPTED" : "-       ", c.reason);
    }
  }
  out += "accepted: " + (d.accepted.empty() ? std::string("nothing") : fmt::format("{}", fmt::join(d.accepted, ", "))) + "\n";
  out += "final model:\n";
  print_model(out, d.final_model);
  for (const auto& w : d.warnings) out += "warning: " + w + "\n";
  return out;
}

}  // namespace tribo::analysis
