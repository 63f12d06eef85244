#include <fmt/printf.h>

#include "analysis/effects/residual_signatures.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <numbers>
#include <utility>

#include "analysis/report/message_format.h"
#include "analysis/effects/regression.h"

namespace tribo::analysis {

namespace {

// Screening only decides which extensions are worth fitting; acceptance is
// decided on held-out data. A t of 2 (with autocorrelation-inflated errors)
// is enough to try.
constexpr double kScreenT = 2.0;

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

double pass_length(const MeasuredSeries& s, const Pass& p) {
  return std::fabs(s.position_m[p.last] - s.position_m[p.first]);
}

Signature not_applicable(Effect e, std::string why) {
  Signature sig;
  sig.effect = e;
  sig.applicable = false;
  sig.summary = std::move(why);
  return sig;
}

// Binned means of y against x over the selected rows (equal-count bins).
SignaturePlot binned(const std::vector<double>& x, const std::vector<double>& y, int bins, std::string xl, std::string yl) {
  SignaturePlot plot{std::move(xl), std::move(yl), {}, {}, {}};
  if (x.empty()) return plot;
  std::vector<std::size_t> order(x.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](auto a, auto b) { return x[a] < x[b]; });
  const std::size_t per = std::max<std::size_t>(1, order.size() / static_cast<std::size_t>(bins));
  for (std::size_t start = 0; start < order.size(); start += per) {
    const std::size_t end = std::min(order.size(), start + per);
    double sx = 0, sy = 0, syy = 0;
    for (std::size_t k = start; k < end; ++k) {
      sx += x[order[k]];
      sy += y[order[k]];
      syy += y[order[k]] * y[order[k]];
    }
    const double c = static_cast<double>(end - start);
    const double mean = sy / c;
    plot.x.push_back(sx / c);
    plot.y.push_back(mean);
    plot.y_error.push_back(c > 1 ? std::sqrt(std::max(syy / c - mean * mean, 0.0) / (c - 1)) : 0.0);
  }
  return plot;
}

// ---------------------------------------------------------------------------
Signature dwell_stiction(const SignatureContext& c) {
  const Effect e = Effect::kDwellStiction;
  // Per onset after a hold: (a) the force excess at onset over the same
  // pass's later sliding level (immune to drift), against ln(dwell); (b) the
  // mean residual of the pass's first 30 % (dwell raises Fs, which also lifts
  // slow sliding through the Stribeck curve), against w ln(dwell), w the
  // Stribeck weight of Fs there, with w and time as controls.
  std::vector<double> dwell, excess, early, when, weight, lengths;
  double level_sum = 0;
  const ModelParams& params = c.in.params;
  const double vs = params.value("vs"), delta = params.structure.stribeck_exponent;
  for (const Pass& p : c.m.passes) {
    if (!p.after_hold || p.dwell_before_s <= 0 || !c.pass_in_fit(p)) continue;
    const double length = pass_length(c.s, p);
    double onset = 0, steady = 0, first = 0, w = 0;
    int n_onset = 0, n_steady = 0, n_first = 0;
    for (std::size_t i = p.first; i <= p.last; ++i) {
      const double d = c.m.distance_since_start_m[i];
      const double signed_r = p.direction * c.r[i];
      if (d < 0.3 * length) {
        first += signed_r;
        // How much Fs weighs here: the Stribeck factor at this speed.
        w += std::exp(-std::pow(std::fabs(c.s.velocity_m_per_s[i]) / vs, delta)) * c.level_factor(i);
        ++n_first;
      }
      if (d < std::max(5 * c.g[i], 0.05 * length) || n_onset < 3) {
        onset += signed_r;
        ++n_onset;
      } else if (d >= 0.2 * length) {
        steady += signed_r;
        ++n_steady;
      }
    }
    if (n_onset == 0 || n_steady == 0 || n_first == 0) continue;
    dwell.push_back(p.dwell_before_s);
    lengths.push_back(length);
    excess.push_back(onset / n_onset - steady / n_steady);
    early.push_back(first / n_first);
    weight.push_back(w / n_first);
    when.push_back(c.in.data.normalised_time((p.first + p.last) / 2));
    level_sum += c.level_factor((p.first + p.last) / 2);
  }
  if (dwell.size() < 4) return not_applicable(e, "fewer than 4 motion onsets after a hold in the fit data");
  const auto [lo, hi] = std::minmax_element(dwell.begin(), dwell.end());
  if (*hi < 3 * *lo) return not_applicable(e, fmt("dwell times span only %.3g-%.3g s (need a factor 3)", *lo, *hi));
  Design onset_design, early_design;
  for (std::size_t k = 0; k < dwell.size(); ++k) {
    onset_design.add_row({1.0, std::log(dwell[k])}, excess[k]);
    early_design.add_row({1.0, weight[k], weight[k] * std::log(dwell[k]), when[k]}, early[k]);
  }
  const Regression a = onset_design.fit(), b = early_design.fit();
  Signature sig;
  sig.effect = e;
  sig.applicable = true;
  sig.plot = {"dwell before onset (s)", "mean direction-signed residual, first 30 % of the pass", dwell, early, {}};
  const double ta = a.ok && a.coef[1] > 0 ? a.t(1) : 0.0, tb = b.ok && b.coef[2] > 0 ? b.t(2) : 0.0;
  sig.strength = std::max(ta, tb) / kScreenT;
  sig.summary = fmt("residual at motion onset grows with ln(dwell): onset excess t = %.1f, early-pass level t = %.1f (time-controlled), %.0f onsets",
                    ta, tb, static_cast<double>(dwell.size()));
  const double mean_factor = level_sum / static_cast<double>(dwell.size());
  const std::vector<double>& y = tb >= ta ? early : excess;
  const double spread = *std::max_element(y.begin(), y.end()) - *std::min_element(y.begin(), y.end());
  // The ageing memory: a tenth of a pass (the extension's fit tries 1/5 and
  // 5 times each scale).
  sig.initial_values = {std::max(2.0 * spread / mean_factor, 1e-12), median(dwell), 0.1 * median(lengths)};
  return sig;
}

// ---------------------------------------------------------------------------
Signature drift(const SignatureContext& c) {
  const Effect e = Effect::kDrift;
  struct Block {
    double t = 0, r = 0, dir = 0, normal = 0;
    int count = 0;
  };
  std::vector<Block> blocks;
  auto add_block = [&](std::size_t first, std::size_t last, int dir) {
    Block b;
    b.dir = dir;
    for (std::size_t i = first; i <= last; ++i) {
      if (!c.in.in_fit[i]) continue;
      b.t += c.in.data.normalised_time(i);
      b.r += c.r[i];
      if (c.s.has_normal()) b.normal += c.s.normal_force_n[i];
      ++b.count;
    }
    if (b.count < 3) return;
    b.t /= b.count;
    b.r /= b.count;
    b.normal /= b.count;
    blocks.push_back(b);
  };
  for (const Pass& p : c.m.passes) add_block(p.first, p.last, p.direction);
  for (const Hold& h : c.m.holds) add_block(h.first, h.last, 0);
  if (blocks.size() < 12) {
    // Few passes (a single velocity step, say): 16 contiguous chunks instead.
    blocks.clear();
    const std::size_t n = c.s.size();
    for (int k = 0; k < 16; ++k) {
      const std::size_t first = n * static_cast<std::size_t>(k) / 16, last = n * static_cast<std::size_t>(k + 1) / 16 - 1;
      add_block(first, last, 0);
    }
  }
  if (blocks.size() < 8) return not_applicable(e, "fewer than 8 fit blocks to follow a trend in time");
  const bool any_direction = std::any_of(blocks.begin(), blocks.end(), [](const Block& b) { return b.dir != 0; });
  auto design_for = [&](bool with_drift) {
    Design d;
    for (const Block& b : blocks) {
      const double u = b.t;
      std::vector<double> row = {1.0};
      if (any_direction) row.push_back(b.dir);
      if (with_drift) {
        row.push_back(u);
        row.push_back(0.5 * (3 * u * u - 1));
        row.push_back(0.5 * (5 * u * u * u - 3 * u));
      }
      if (d.columns.empty()) d.columns.resize(row.size());
      for (std::size_t j = 0; j < row.size(); ++j) d.columns[j].push_back(row[j]);
      d.y.push_back(b.r);
    }
    return d;
  };
  const Regression full = design_for(true).fit(), reduced = design_for(false).fit();
  Signature sig;
  sig.effect = e;
  sig.applicable = true;
  std::vector<double> bt, br;
  for (const Block& b : blocks) {
    bt.push_back(b.t);
    br.push_back(b.r);
  }
  sig.plot = {"normalised time (-1 .. 1)", "mean residual of each pass / hold", bt, br, {}};
  if (!full.ok || !reduced.ok) {
    sig.summary = "block means could not be regressed on time";
    return sig;
  }
  // F statistic of the three drift terms (rows are blocks, close to independent).
  const double nb = static_cast<double>(blocks.size());
  const double k_full = static_cast<double>(full.coef.size());
  const double rss_full = (1 - full.r_squared), rss_reduced = (1 - reduced.r_squared);
  const double f = rss_full > 0 ? ((rss_reduced - rss_full) / 3.0) / (rss_full / std::max(nb - k_full, 1.0)) : 0.0;
  sig.strength = f / 10.0;
  const double trend = full.coef[static_cast<Eigen::Index>(full.coef.size() - 3)];
  sig.summary = fmt("pass/hold mean residual follows time: F = %.1f for 3 Legendre terms over %.0f blocks (linear term %.3g over the record)",
                    f, nb, trend);
  return sig;
}

// ---------------------------------------------------------------------------
Signature frictional_lag(const SignatureContext& c) {
  const Effect e = Effect::kFrictionalLag;
  const ModelParams& p = c.in.params;
  const bool mu = p.structure.load_scaled;
  const double fc = p.value(mu ? "mu_c" : "Fc"), fs = p.value(mu ? "mu_s" : "Fs"), vs = p.value("vs");
  const double delta = p.structure.stribeck_exponent;
  if (std::fabs(fs - fc) < 0.05 * fc) return not_applicable(e, "the fitted Stribeck drop (Fs - Fc) is too small to show a lag");
  const auto& v = c.in.data.drive_velocity;
  const auto& t = c.s.time_s;
  auto stribeck = [&](double speed) { return fc + (fs - fc) * std::exp(-std::pow(speed / vs, delta)); };
  int low_speed = 0;
  for (std::size_t i = 0; i < c.s.size(); ++i) {
    if (c.sliding(i) && std::fabs(v[i]) < 3 * vs) ++low_speed;
  }
  if (low_speed < 20) return not_applicable(e, "the data never slide through the Stribeck region (|v| < 3 vs)");
  // Regressor for a trial delay tau: what the Stribeck level would change by if
  // it saw the velocity tau earlier, dir (S(|v(t - tau)|) - S(|v(t)|)) L.
  const double dt = (t.back() - t.front()) / static_cast<double>(c.s.size() - 1);
  // For the true delay the regression gain is one: shorter trial delays need
  // a larger gain, longer ones a smaller. The delay is where the gain
  // crosses one (log-interpolated); the significance is that delay's t.
  struct Trial {
    double tau, coef, t;
  };
  // The rows, their residuals and S(|v(t)|) are the same for every trial delay.
  std::size_t row_count = 0;
  for (std::size_t i = 0; i < c.s.size(); ++i) {
    if (c.sliding(i) || c.zone[i] == SignatureContext::Zone::kPresliding) ++row_count;
  }
  std::vector<std::size_t> rows;
  std::vector<double> residual, level_now;
  rows.reserve(row_count);
  residual.reserve(row_count);
  level_now.reserve(row_count);
  for (std::size_t i = 0; i < c.s.size(); ++i) {
    if (!(c.sliding(i) || c.zone[i] == SignatureContext::Zone::kPresliding)) continue;
    rows.push_back(i);
    residual.push_back(c.r[i]);
    level_now.push_back(stribeck(std::fabs(v[i])));
  }
  // Each row's regressor for the delay tau, in row order, to each(row, q).
  // Formed again for the delay chosen rather than held for every trial
  // delay (eight bytes a row and delay).
  auto for_each_regressor = [&](double tau, auto each) {
    std::size_t k = 0;
    for (std::size_t row = 0; row < rows.size(); ++row) {
      const std::size_t i = rows[row];
      const double target = t[i] - tau;
      while (k + 1 < c.s.size() && t[k + 1] <= target) ++k;
      const double vl = target <= t.front() ? v.front()
                                            : v[k] + (target - t[k]) / (t[k + 1] - t[k]) * (v[std::min(k + 1, c.s.size() - 1)] - v[k]);
      each(row, c.m.direction[i] * (stribeck(std::fabs(vl)) - level_now[row]) * c.level_factor(i));
    }
  };
  std::vector<Trial> trials;
  for (double steps : {1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0}) {
    const double tau = steps * dt;
    if (tau > 0.5) break;
    Design design;
    design.reserve(3, rows.size());
    for_each_regressor(tau, [&](std::size_t row, double q) {
      const std::size_t i = rows[row];
      design.add_row({1.0, static_cast<double>(c.m.direction[i]), q}, c.r[i]);
    });
    const Regression reg = design.fit();
    if (!reg.ok) continue;
    trials.push_back({tau, reg.coef[2], reg.t(2)});
  }
  double best_t = 0, best_tau = 0, best_coef = 0, best_trial_tau = 0;
  for (std::size_t j = 0; j < trials.size(); ++j) {
    const Trial& a = trials[j];
    if (a.coef <= 0) continue;
    const bool crossing = j + 1 < trials.size() && a.coef >= 1 && trials[j + 1].coef < 1 && trials[j + 1].coef > 0;
    const bool edge = (j == 0 && a.coef < 1) || (j + 1 == trials.size() && a.coef >= 1);
    if (!crossing && !edge) continue;
    double tau = a.tau;
    if (crossing) {
      const Trial& b = trials[j + 1];
      const double f = std::log(a.coef) / (std::log(a.coef) - std::log(b.coef));
      tau = std::exp(std::log(a.tau) + f * (std::log(b.tau) - std::log(a.tau)));
    }
    if (a.t > best_t) {
      best_t = a.t;
      best_tau = tau;
      best_coef = a.coef;
      best_trial_tau = a.tau;
    }
  }
  // The plot: the best trial's regressor against the residual.
  std::vector<double> best_q, best_r;
  if (best_t > 0) {
    best_q.resize(rows.size());
    for_each_regressor(best_trial_tau, [&](std::size_t row, double q) { best_q[row] = q; });
    best_r = std::move(residual);
  }
  Signature sig;
  sig.effect = e;
  sig.applicable = true;
  sig.strength = best_t / kScreenT;
  sig.initial_values = {std::max(best_tau, dt)};
  sig.plot = binned(best_q, best_r, 20, "S(v(t - tau)) - S(v(t)), direction-signed", "residual");
  sig.summary = best_t > 0 ? fmt("sliding residual follows the Stribeck level of the velocity %.3g s earlier (t = %.1f, gain %.2f)",
                                 best_tau, best_t, best_coef)
                           : "no delayed-velocity pattern in the sliding residual";
  return sig;
}

// ---------------------------------------------------------------------------
Signature presliding_hysteresis(const SignatureContext& c) {
  const Effect e = Effect::kPreslidingHysteresis;
  constexpr int kBins = 16;
  constexpr double kZone = 4.0;  // presliding lengths g after each reversal or onset
  std::vector<std::vector<double>> per_pass_means(kBins);
  int resolved = 0, passes = 0;
  for (const Pass& p : c.m.passes) {
    if (!c.pass_in_fit(p)) continue;
    ++passes;
    std::vector<double> sum(kBins, 0.0);
    std::vector<int> count(kBins, 0);
    int within_two = 0;
    for (std::size_t i = p.first; i <= p.last; ++i) {
      const double u = c.m.distance_since_start_m[i] / std::max(c.g[i], 1e-300);
      if (u >= kZone) break;
      if (u < 2) ++within_two;
      const int b = std::min(kBins - 1, static_cast<int>(u / kZone * kBins));
      sum[static_cast<std::size_t>(b)] += p.direction * c.r[i];
      ++count[static_cast<std::size_t>(b)];
    }
    if (within_two >= 4) ++resolved;
    for (int b = 0; b < kBins; ++b) {
      if (count[static_cast<std::size_t>(b)] > 0) per_pass_means[static_cast<std::size_t>(b)].push_back(sum[static_cast<std::size_t>(b)] / count[static_cast<std::size_t>(b)]);
    }
  }
  if (resolved < 3) {
    return not_applicable(e, fmt("presliding not resolved: %.0f of %.0f fit passes have 4 samples within two presliding lengths (g = Fc/sigma0)",
                                 resolved, passes));
  }
  Signature sig;
  sig.effect = e;
  sig.applicable = true;
  sig.plot.x_label = "distance since reversal / presliding length g";
  sig.plot.y_label = "direction-signed residual";
  double chi2 = 0;
  int dof = 0;
  for (int b = 0; b < kBins; ++b) {
    const auto& v = per_pass_means[static_cast<std::size_t>(b)];
    if (v.size() < 3) continue;
    double mean = 0, var = 0;
    for (double x : v) mean += x;
    mean /= static_cast<double>(v.size());
    for (double x : v) var += (x - mean) * (x - mean);
    var /= static_cast<double>(v.size() - 1);
    const double se = std::sqrt(var / static_cast<double>(v.size()));
    sig.plot.x.push_back((b + 0.5) * kZone / kBins);
    sig.plot.y.push_back(mean);
    sig.plot.y_error.push_back(se);
    if (se > 0) {
      chi2 += mean * mean / (se * se);
      ++dof;
    }
  }
  if (dof == 0) {
    sig.summary = "too few passes per presliding bin";
    return sig;
  }
  const double z = (chi2 - dof) / std::sqrt(2.0 * dof);
  sig.strength = z / 4.0;
  sig.summary = fmt("residual within %.0f presliding lengths of reversals differs from zero: chi2 = %.1f over %.0f bins (z = %.1f)",
                    kZone, chi2, dof, z);
  sig.initial_values = {0.5};
  return sig;
}

// ---------------------------------------------------------------------------
// Distance after a reversal over which |F| stays below a fraction of the pass's
// sliding level, before the force first reaches half of it in the new direction.
double dead_zone(const SignatureContext& c, const Pass& p, const std::vector<double>& friction_force, double level) {
  double zone = 0;
  for (std::size_t i = p.first + 1; i <= p.last; ++i) {
    const double f = p.direction * friction_force[i];
    if (f > 0.5 * level) break;
    if (std::fabs(f) < 0.15 * level) zone += std::fabs(c.s.position_m[i] - c.s.position_m[i - 1]);
  }
  return zone;
}

Signature backlash(const SignatureContext& c) {
  const Effect e = Effect::kBacklash;
  // The friction part of the measurement: measured minus the model's additive terms.
  std::vector<double> measured(c.s.size()), model(c.s.size());
  for (std::size_t i = 0; i < c.s.size(); ++i) {
    const double additive = c.in.model[i] - c.in.friction[i];
    measured[i] = (*c.in.data.fitted_force)[i] - additive;
    model[i] = c.in.friction[i];
  }
  std::vector<double> excess, steps;
  double model_zone_sum = 0;
  for (std::size_t k = 1; k < c.m.passes.size(); ++k) {
    const Pass& p = c.m.passes[k];
    if (p.direction == c.m.passes[k - 1].direction || !c.pass_in_fit(p)) continue;
    std::vector<double> sliding_level;
    for (std::size_t i = p.first; i <= p.last; ++i) {
      if (c.steady(i)) sliding_level.push_back(p.direction * measured[i]);
    }
    const double level = median(sliding_level);
    if (!(level > 0)) continue;
    const double zm = dead_zone(c, p, measured, level), zf = dead_zone(c, p, model, level);
    excess.push_back(zm - zf);
    model_zone_sum += zf;
    steps.push_back(std::fabs(c.s.position_m[std::min(p.first + 1, p.last)] - c.s.position_m[p.first]));
  }
  if (excess.size() < 2) return not_applicable(e, "fewer than 2 direction changes with sliding after them in the fit data");
  const double med = median(excess);
  const double model_zone = model_zone_sum / static_cast<double>(excess.size());
  const double positive = static_cast<double>(std::count_if(excess.begin(), excess.end(), [](double x) { return x > 0; })) /
                          static_cast<double>(excess.size());
  const double threshold = std::max({model_zone, 4 * median(steps), 3 * c.m.position_noise_m, 1e-300});
  Signature sig;
  sig.effect = e;
  sig.applicable = true;
  sig.strength = positive >= 0.6 ? med / threshold : 0.0;
  sig.initial_values = {std::max(med, 1e-3 * threshold)};
  sig.summary = fmt("after reversals the measured force stays near zero %.3g m longer than the model's (median over %.0f reversals, %.0f %% of them longer)",
                    med, static_cast<double>(excess.size()), 100 * positive);
  // Plot: direction-signed residual against distance since reversal.
  std::vector<double> x, y;
  const double extent = std::max(4 * med, 10 * threshold);
  for (std::size_t k = 1; k < c.m.passes.size(); ++k) {
    const Pass& p = c.m.passes[k];
    if (p.direction == c.m.passes[k - 1].direction || !c.pass_in_fit(p)) continue;
    for (std::size_t i = p.first; i <= p.last && c.m.distance_since_start_m[i] < extent; ++i) {
      x.push_back(c.m.distance_since_start_m[i]);
      y.push_back(p.direction * c.r[i]);
    }
  }
  sig.plot = binned(x, y, 30, "distance since reversal (m)", "direction-signed residual");
  return sig;
}

// ---------------------------------------------------------------------------
Signature velocity_strengthening(const SignatureContext& c) {
  const Effect e = Effect::kVelocityStrengthening;
  // Per pass: the mean direction-signed residual (relative to the level
  // factor) over its plateau, against the plateau speed. The base model is
  // already viscous (Fv v); a log-velocity law leaves curvature against ln v.
  Design design;
  std::vector<double> px, py, speeds;
  for (const Pass& p : c.m.passes) {
    if (!c.pass_in_fit(p)) continue;
    const double plateau = p.median_speed_m_per_s;
    double sum = 0;
    int k = 0;
    for (std::size_t i = p.first; i <= p.last; ++i) {
      const double speed = std::fabs(c.s.velocity_m_per_s[i]);
      const double factor = c.level_factor(i);
      if (!c.steady(i) || !(factor > 0) || std::fabs(speed - plateau) > 0.2 * plateau) continue;
      sum += p.direction * c.r[i] / factor;
      ++k;
    }
    if (k < 5 || !(plateau > 0)) continue;
    design.add_row({1.0, static_cast<double>(p.direction), plateau, std::log(plateau)}, sum / k);
    px.push_back(plateau);
    py.push_back(sum / k);
    speeds.push_back(plateau);
  }
  if (speeds.size() < 6) return not_applicable(e, "fewer than 6 fit passes with a steady plateau");
  std::sort(speeds.begin(), speeds.end());
  const double* lo = &speeds.front();
  const double* hi = &speeds.back();
  int distinct = 1;
  for (std::size_t k = 1; k < speeds.size(); ++k) distinct += speeds[k] > 1.25 * speeds[k - 1] ? 1 : 0;
  if (*hi < 8 * *lo || distinct < 3) {
    return not_applicable(e, fmt("plateau speeds span a factor %.2g at %.0f distinct levels; log-velocity and viscous "
                                 "friction cannot be told apart below a decade and three speeds", *hi / *lo, distinct));
  }
  Signature sig;
  sig.effect = e;
  sig.applicable = true;
  sig.plot = {"plateau speed (m/s)", "mean direction-signed residual / level factor, per pass", px, py, {}};
  const ModelParams& p = c.in.params;
  const bool mu = p.structure.load_scaled;
  const bool inverted = p.value(mu ? "mu_s" : "Fs") < 0.9 * p.value(mu ? "mu_c" : "Fc");
  const Regression reg = design.fit();
  const double coef = reg.ok ? reg.coef[3] : 0.0, t = reg.ok ? reg.t(3) : 0.0;
  sig.strength = std::max(std::fabs(t) / kScreenT, inverted ? 1.0 : 0.0);
  sig.initial_values = {coef > 0 ? coef : 0.0};
  sig.summary = fmt("pass residual against ln(speed) over %.2g-%.2g m/s: coefficient %.3g (t = %.1f) beside the viscous term", *lo, *hi, coef, t);
  if (inverted) sig.summary += "; the base fit turned the Stribeck term upside down (Fs < Fc), friction rising with speed";
  return sig;
}

// ---------------------------------------------------------------------------
Signature load_dependence(const SignatureContext& c) {
  const Effect e = Effect::kLoadDependence;
  if (!c.s.has_normal()) return not_applicable(e, "no normal-load channel");
  const double normal_ref = c.in.data.normal_ref;
  Design design;
  std::vector<double> px, py;
  double lo = HUGE_VAL, hi = 0;
  for (const Pass& p : c.m.passes) {
    if (!c.pass_in_fit(p)) continue;
    double sr = 0, sl = 0, sn = 0;
    int k = 0;
    for (std::size_t i = p.first; i <= p.last; ++i) {
      if (!c.steady(i)) continue;
      sr += p.direction * c.r[i];
      sl += c.level[i];
      sn += c.s.normal_force_n[i];
      ++k;
    }
    if (k < 5 || !(sn > 0) || !(sl > 0)) continue;
    const double normal = sn / k;
    lo = std::min(lo, normal);
    hi = std::max(hi, normal);
    const double y = sr / sl;  // relative residual of the friction level
    design.add_row({1.0, static_cast<double>(p.direction), std::log(normal / normal_ref)}, y);
    px.push_back(normal);
    py.push_back(y);
  }
  if (design.rows() < 4 || hi < 1.3 * lo) return not_applicable(e, "normal load in sliding varies by less than 30 %");
  const Regression reg = design.fit();
  Signature sig;
  sig.effect = e;
  sig.applicable = true;
  sig.plot = {"normal load", "relative friction residual per pass", px, py, {}};
  if (!reg.ok) {
    sig.summary = "pass residuals could not be regressed on ln N";
    return sig;
  }
  sig.strength = std::fabs(reg.t(2)) / kScreenT;
  sig.initial_values = {reg.coef[2]};
  sig.summary = fmt("relative friction residual against ln(N/N_ref): slope %.3g (t = %.1f) over loads %.3g-%.3g",
                    reg.coef[2], reg.t(2), lo, hi);
  return sig;
}

// ---------------------------------------------------------------------------
Signature tilt_offset(const SignatureContext& c) {
  const Effect e = Effect::kTiltOffset;
  if (!c.s.has_normal()) return not_applicable(e, "no normal-load channel (a constant offset is part of the base model)");
  // (a) at rest: the residual follows the load where it changes between
  // passes (the holds and the load ramps, rest_stretches; the fit mask leaves
  // the holds out when each pass starts from the force at rest, and the
  // segmentation the ramps, so the fit set never holds them).
  std::vector<double> slopes, slope_t;
  std::vector<double> px, py;
  for (const Hold& h : rest_stretches(c.s, c.m, 0.2, 10)) {
    double nmin = HUGE_VAL, nmax = -HUGE_VAL;
    Design d;
    for (std::size_t i = h.first; i <= h.last; ++i) {
      if (c.m.heldout[i]) continue;
      nmin = std::min(nmin, c.s.normal_force_n[i]);
      nmax = std::max(nmax, c.s.normal_force_n[i]);
      d.add_row({1.0, c.s.normal_force_n[i]}, c.r[i]);
      px.push_back(c.s.normal_force_n[i]);
      py.push_back(c.r[i]);
    }
    if (d.rows() < 10 || nmax - nmin < 0.2 * std::max(std::fabs(nmax), 1e-300)) continue;
    const Regression reg = d.fit();
    if (!reg.ok) continue;
    slopes.push_back(reg.coef[1]);
    slope_t.push_back(reg.t(1));
  }
  // (b) in sliding: unsigned residual ~ N, with direction x N absorbing any Amontons misfit.
  Design sliding;
  double lo = HUGE_VAL, hi = 0;
  for (std::size_t i = 0; i < c.s.size(); ++i) {
    if (!c.steady(i)) continue;
    const double normal = c.s.normal_force_n[i], dir = c.m.direction[i];
    lo = std::min(lo, normal);
    hi = std::max(hi, normal);
    sliding.add_row({1.0, dir, normal, dir * normal}, c.r[i]);
  }
  double t_rest = 0, est_rest = 0;
  if (!slopes.empty()) {
    // Combine holds: the t of the mean slope with the holds' own t's as weights.
    double w = 0;
    for (std::size_t k = 0; k < slopes.size(); ++k) {
      est_rest += slopes[k];
      w += slope_t[k];
    }
    est_rest /= static_cast<double>(slopes.size());
    t_rest = w / std::sqrt(static_cast<double>(slopes.size()));
  }
  double t_slide = 0, est_slide = 0;
  if (sliding.rows() > 10 && hi > 1.3 * lo) {
    const Regression reg = sliding.fit();
    if (reg.ok) {
      t_slide = reg.t(2);
      est_slide = reg.coef[2];
    }
  }
  if (slopes.empty() && !(hi > 1.3 * lo)) {
    return not_applicable(e, "the normal load neither changes during a hold nor varies by 30 % in sliding: "
                             "a tilt force would be indistinguishable from the offset");
  }
  Signature sig;
  sig.effect = e;
  sig.applicable = true;
  sig.plot = binned(px.empty() ? std::vector<double>{} : px, py, 20, "normal load during holds", "residual at rest");
  const bool rest = std::fabs(t_rest) >= std::fabs(t_slide);
  sig.strength = std::max(std::fabs(t_rest), std::fabs(t_slide)) / kScreenT;
  sig.initial_values = {rest ? est_rest : est_slide};
  sig.summary = fmt("residual proportional to the normal load: dF/dN = %.3g at rest (t = %.1f over holds), %.3g in sliding (t = %.1f)",
                    est_rest, t_rest, est_slide, t_slide);
  return sig;
}

// ---------------------------------------------------------------------------
Signature direction_asymmetry(const SignatureContext& c) {
  const Effect e = Effect::kDirectionAsymmetry;
  int forward = 0, backward = 0;
  std::vector<double> level, speed, rr, sv;
  for (std::size_t i = 0; i < c.s.size(); ++i) {
    if (!c.steady(i)) continue;
    (c.m.direction[i] > 0 ? forward : backward)++;
    level.push_back(c.level[i]);
    speed.push_back(std::fabs(c.s.velocity_m_per_s[i]));
    rr.push_back(c.r[i]);
    sv.push_back(c.s.velocity_m_per_s[i]);
  }
  if (forward < 10 || backward < 10) return not_applicable(e, "steady sliding in only one direction");
  auto spread = [](const std::vector<double>& v) {
    double mean = 0, var = 0;
    for (double x : v) mean += x;
    mean /= static_cast<double>(v.size());
    for (double x : v) var += (x - mean) * (x - mean);
    return std::sqrt(var / static_cast<double>(v.size())) / std::max(std::fabs(mean), 1e-300);
  };
  // The level and speed columns enter only where they vary; a constant level
  // asymmetry is the offset itself in sliding-only data.
  const bool use_level = spread(level) > 1e-3, use_speed = spread(speed) > 1e-3;
  if (!use_level && !use_speed) return not_applicable(e, "constant level and speed: an asymmetry is indistinguishable from the offset");
  Design design;
  for (std::size_t k = 0; k < rr.size(); ++k) {
    std::vector<double> row = {1.0};
    if (use_level) row.push_back(level[k]);
    if (use_speed) row.push_back(speed[k]);
    if (design.columns.empty()) design.columns.resize(row.size());
    for (std::size_t j = 0; j < row.size(); ++j) design.columns[j].push_back(row[j]);
    design.y.push_back(rr[k]);
  }
  const Regression reg = design.fit();
  Signature sig;
  sig.effect = e;
  sig.applicable = true;
  sig.plot = binned(sv, rr, 30, "velocity (m/s)", "residual (not direction-signed)");
  if (!reg.ok) {
    sig.summary = "residual could not be regressed on level and speed";
    return sig;
  }
  double t_level = 0, t_speed = 0, alpha = 0, beta = 0;
  int j = 1;
  if (use_level) {
    t_level = reg.t(j);
    alpha = reg.coef[j++];
  }
  if (use_speed) {
    t_speed = reg.t(j);
    beta = std::fabs(c.fv) > 0 ? reg.coef[j] / c.fv : 0.0;
  }
  sig.strength = std::max(std::fabs(t_level), std::fabs(t_speed)) / kScreenT;
  sig.initial_values = {alpha, beta};
  if (!use_level) sig.fixed_parameters.push_back("asym_levels");
  if (!use_speed) sig.fixed_parameters.push_back("asym_viscous");
  sig.summary = fmt("residual that does not flip with direction grows with the friction level (x%.3g, t = %.1f) "
                    "and with speed (Fv x%.3g, t = %.1f)", alpha, t_level, beta, t_speed);
  return sig;
}

// ---------------------------------------------------------------------------
Signature position_periodic(const SignatureContext& c) {
  const Effect e = Effect::kPositionPeriodic;
  std::vector<std::size_t> rows;
  std::vector<double> steps;
  for (std::size_t i = 1; i < c.s.size(); ++i) {
    if (!c.sliding(i)) continue;
    rows.push_back(i);
    steps.push_back(std::fabs(c.s.position_m[i] - c.s.position_m[i - 1]));
  }
  if (rows.size() < 64) return not_applicable(e, "too few sliding samples");
  double xmin = HUGE_VAL, xmax = -HUGE_VAL;
  for (std::size_t i : rows) {
    xmin = std::min(xmin, c.s.position_m[i]);
    xmax = std::max(xmax, c.s.position_m[i]);
  }
  // Resolved at (nearly) every speed: a temporal artefact in slow passes
  // would otherwise alias to a short period in position.
  std::sort(steps.begin(), steps.end());
  const double lambda_min = std::max({4 * steps[steps.size() * 9 / 10], 20 * c.m.position_noise_m, 1e-300});
  // Peaks are sought up to three periods in the sliding range; the grid goes
  // on to two, so that a peak there still has a neighbourhood to stand out
  // from. (The peak search had stopped at 4.5 periods, a third below the
  // grid's end: a 1.5 um period on 5 um passes was never looked at, and its
  // leakage peaked at 1.0 um instead.)
  const double lambda_peak_max = (xmax - xmin) / 3;
  const double lambda_max = (xmax - xmin) / 2;
  if (lambda_peak_max < 2 * lambda_min) return not_applicable(e, "the sliding range holds fewer than 3 resolvable periods");

  // Residual binned in position, per direction (bins of lambda_min / 4).
  const int nbins = std::clamp(static_cast<int>((xmax - xmin) / (lambda_min / 4)), 64, 8192);
  std::vector<double> sum[2], cnt[2];
  for (int d = 0; d < 2; ++d) {
    sum[d].assign(static_cast<std::size_t>(nbins), 0.0);
    cnt[d].assign(static_cast<std::size_t>(nbins), 0.0);
  }
  for (std::size_t i : rows) {
    const int b = std::min(nbins - 1, static_cast<int>((c.s.position_m[i] - xmin) / (xmax - xmin) * nbins));
    const int d = c.m.direction[i] > 0 ? 1 : 0;
    sum[d][static_cast<std::size_t>(b)] += c.r[i];
    cnt[d][static_cast<std::size_t>(b)] += 1;
  }
  using cplx = std::complex<double>;
  constexpr int kGrid = 400;
  std::vector<double> lambdas(kGrid), power(kGrid);
  std::vector<cplx> amp_fwd(kGrid), amp_bwd(kGrid);
  for (int g = 0; g < kGrid; ++g) {
    const double lambda = lambda_min * std::pow(lambda_max / lambda_min, g / (kGrid - 1.0));
    const double k = 2 * std::numbers::pi / lambda;
    cplx a[2] = {0, 0};
    double w[2] = {0, 0};
    for (int d = 0; d < 2; ++d) {
      for (int b = 0; b < nbins; ++b) {
        if (cnt[d][static_cast<std::size_t>(b)] == 0) continue;
        const double x = xmin + (b + 0.5) * (xmax - xmin) / nbins;
        const double mean = sum[d][static_cast<std::size_t>(b)] / cnt[d][static_cast<std::size_t>(b)];
        a[d] += mean * std::exp(cplx(0, -k * x));
        w[d] += 1;
      }
      if (w[d] > 0) a[d] /= w[d];
    }
    lambdas[static_cast<std::size_t>(g)] = lambda;
    amp_bwd[static_cast<std::size_t>(g)] = a[0];
    amp_fwd[static_cast<std::size_t>(g)] = a[1];
    power[static_cast<std::size_t>(g)] = std::norm(a[0]) + std::norm(a[1]);
  }
  // Peak, compared with the local median power (within a factor 3 in wavelength).
  int best = 0;
  for (int g = 0; g < kGrid; ++g) {
    if (lambdas[static_cast<std::size_t>(g)] > lambda_peak_max) break;
    if (power[static_cast<std::size_t>(g)] > power[static_cast<std::size_t>(best)]) best = g;
  }
  const double peak_lambda = lambdas[static_cast<std::size_t>(best)];
  std::vector<double> local;
  for (int g = 0; g < kGrid; ++g) {
    const double l = lambdas[static_cast<std::size_t>(g)];
    if (l > peak_lambda / 3 && l < peak_lambda * 3 && std::fabs(std::log(l / peak_lambda)) > 0.1) local.push_back(power[static_cast<std::size_t>(g)]);
  }
  const double ratio = power[static_cast<std::size_t>(best)] / std::max(median(local), 1e-300);
  Signature sig;
  sig.effect = e;
  sig.applicable = true;
  sig.strength = ratio / 25.0;
  const cplx f = amp_fwd[static_cast<std::size_t>(best)], b = amp_bwd[static_cast<std::size_t>(best)];
  // A friction modulation reaches the force through the contact's bristle,
  // a first-order lag in slip distance of the presliding length L = S /
  // sigma0 (LuGre in steady sliding: L eps' + eps = m). Each direction's
  // ripple lags its own motion by psi = atan(k L), so the modulation gives
  // b = -f e^{2 i psi}, not -f; a ripple added to the force gives b = f.
  // (Plain LuGre plant, 0.5 um period, L = 0.12 um: the directions differ
  // by 76 deg, which the test without the lag, 0 against 180 deg, took for
  // a ripple.)
  std::vector<double> lengths;
  double mean_level = 0;
  for (std::size_t i : rows) {
    mean_level += c.level[i];
    lengths.push_back(c.g[i]);
  }
  mean_level /= static_cast<double>(rows.size());
  const double bristle_m = median(std::move(lengths));
  const cplx lag = cplx(1.0, 2 * std::numbers::pi / peak_lambda * bristle_m);  // 1 + i k L
  const cplx turn = lag / std::conj(lag);                                      // e^{2 i psi}
  sig.periodic_additive = std::abs(b - f) <= std::abs(b + f * turn);
  // r = a cos(kx) + b sin(kx)  <=>  mean of r e^{-ikx} = (a - i b) / 2. The
  // modulation's own amplitude, before the bristle's lag: f (1 + i k L) and
  // -b (1 - i k L).
  const cplx a = sig.periodic_additive ? 0.5 * (f + b) : 0.5 * (f * lag - b * std::conj(lag)) / std::max(mean_level, 1e-300);
  sig.initial_values = {2 * a.real(), -2 * a.imag(), peak_lambda};
  sig.summary = fmt("residual against position peaks at a period of %.4g m, %.1f x the local median power", peak_lambda, ratio) +
                (sig.periodic_additive ? " (same phase both ways: a force ripple)"
                                       : fmt(" (phases both ways as a friction modulation behind a %.3g m bristle)", bristle_m));
  sig.plot = {"wavelength (m)", "residual power against position", lambdas, power, {}};
  return sig;
}

// ---------------------------------------------------------------------------
// Rate and state (Dieterich 1979, Ruina 1983): after a speed step while
// sliding, friction jumps by a ln(v2/v1) (the direct effect) and then
// evolves by -b ln(v2/v1) over a slip distance of a few D_c. The signature:
// after each step within a pass, the direction-signed residual (over the
// level factor) against sgn(ln(v2/v1)) exp(-s/D), s the slip since the
// step, for D on a log grid; the best |t| (autocorrelation-inflated) is the
// strength. Onsets after holds are left out (dwell stiction's signature).
Signature rate_state(const SignatureContext& c) {
  const Effect e = Effect::kRateState;
  struct Step {
    std::size_t at, end;
    double log_ratio;
    int direction;
  };
  std::vector<Step> steps;
  double longest = 0;
  for (const Pass& p : c.m.passes) {
    // Steps anywhere (a single velocity-step record is one pass split into
    // time chunks); only fit samples enter the regression below.
    const std::size_t count = p.last - p.first + 1;
    const std::size_t chunk = std::max<std::size_t>(10, count / 40);
    if (count < 4 * chunk) continue;
    std::vector<double> medians;
    std::vector<std::size_t> starts;
    for (std::size_t a = p.first; a + chunk <= p.last + 1; a += chunk) {
      std::vector<double> speeds;
      for (std::size_t i = a; i < a + chunk; ++i) speeds.push_back(std::fabs(c.s.velocity_m_per_s[i]));
      medians.push_back(median(speeds));
      starts.push_back(a);
    }
    // A step: the chunk median speed changes by a factor of 1.5 or more and
    // stays (the next chunk agrees with the new level); the first chunks
    // (the pass's onset) are not steps. A pass that opens the record was
    // already sliding when it began (no onset in it): its first two chunks
    // are compared too (sepiolite velstep2 steps 2 -> 0.2 um/s near the end
    // of its first chunk).
    std::vector<std::size_t> at;
    std::vector<double> ratio;
    const std::size_t first_step_chunk = p.first == 0 ? 1 : 2;
    for (std::size_t k = first_step_chunk; k + 1 < medians.size(); ++k) {
      const double before = medians[k - 1], after = medians[k], next = medians[k + 1];
      if (!(before > 0 && after > 0)) continue;
      const double r = after / before;
      if ((r >= 1.5 || r <= 1 / 1.5) && std::fabs(std::log(next / after)) < std::log(1.25)) {
        if (!at.empty() && starts[k] - at.back() < 3 * chunk) continue;
        at.push_back(starts[k]);
        ratio.push_back(next / before);
      }
    }
    for (std::size_t j = 0; j < at.size(); ++j) {
      const std::size_t end = j + 1 < at.size() ? at[j + 1] : p.last + 1;
      steps.push_back({at[j] > chunk ? at[j] - chunk / 2 : at[j], end, std::log(ratio[j]), p.direction});
      longest = std::max(longest, std::fabs(c.s.position_m[end - 1] - c.s.position_m[at[j]]));
    }
  }
  if (steps.empty()) {
    return not_applicable(e, "no speed step within a sliding pass (the rate-and-state transient needs a velocity change while sliding)");
  }
  Signature sig;
  sig.effect = e;
  sig.applicable = true;
  double best_t = 0, best_coef = 0, best_d = 0;
  std::vector<double> best_x, best_y;
  for (double fraction : {0.003, 0.01, 0.03, 0.1, 0.3}) {
    const double length = fraction * longest;
    Design design;
    std::vector<double> ys, xs;
    for (const Step& st : steps) {
      const double origin = c.s.position_m[st.at];
      for (std::size_t i = st.at; i < st.end; ++i) {
        const double factor = c.level_factor(i);
        if (!c.in.in_fit[i] || !(factor > 0)) continue;
        const double slip = std::fabs(c.s.position_m[i] - origin);
        const double y = st.direction * c.r[i] / factor;
        design.add_row({1.0, (st.log_ratio > 0 ? 1.0 : -1.0) * std::exp(-slip / length)}, y);
        ys.push_back(y);
        xs.push_back(slip);
      }
    }
    if (design.rows() < 20) continue;
    const Regression reg = design.fit();
    if (!reg.ok) continue;
    const double t = std::fabs(reg.t(1));  // errors already autocorrelation-inflated
    if (t > best_t) {
      best_t = t;
      best_coef = reg.coef[1];
      best_d = length;
      best_x = xs;
      best_y = ys;
    }
  }
  double mean_log_ratio = 0;
  for (const Step& st : steps) mean_log_ratio += std::fabs(st.log_ratio);
  mean_log_ratio /= static_cast<double>(steps.size());
  // A speed step within sliding is rare and specific (a velocity-step
  // test): the extension is always fitted there, and the held-out test decides.
  sig.strength = std::max(best_t / kScreenT, 1.0);
  const double a0 = best_coef > 0 ? best_coef / std::max(mean_log_ratio, 1e-3) : 1e-3 * c.in.data.mu_scale;
  sig.initial_values = {a0, a0, best_d > 0 ? best_d : 1e-5};
  sig.plot = binned(best_x, best_y, 40, "slip since the speed step (m)", "direction-signed residual / level factor");
  sig.summary = fmt("after %.0f speed steps within passes (mean |ln v2/v1| %.2f) the residual follows sgn(ln v2/v1) exp(-s/D) with "
                    "D = %.3g m: coefficient %.3g",
                    static_cast<double>(steps.size()), mean_log_ratio, best_d, best_coef);
  sig.summary += fmt(" (t = %.1f, autocorrelation-inflated errors)", best_t);
  return sig;
}

}  // namespace

SignatureContext::SignatureContext(const SignatureInput& input) : in(input), s(input.data.series), m(input.data.motion) {
  const std::size_t n = s.size();
  const ModelParams& p = in.params;
  sigma0 = p.value("sigma0");
  fv = p.value("Fv");
  r.resize(n);
  level.resize(n);
  g.resize(n);
  zone.assign(n, Zone::kNone);
  const std::vector<double>& force = *in.data.fitted_force;  // the record's, or one with an effect injected
  for (std::size_t i = 0; i < n; ++i) {
    r[i] = force[i] - in.model[i];
    const double w = std::max(std::fabs(s.velocity_m_per_s[i]), 1e-300);
    const double normal = s.has_normal() ? s.normal_force_n[i] : 0.0;
    level[i] = std::max(steady_state_friction(p, w, normal) - fv * w, 0.0);
    g[i] = level[i] / sigma0;
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!in.in_fit[i]) continue;
    const int pi = m.pass_of[i];
    if (pi < 0) {
      zone[i] = Zone::kHold;
      continue;
    }
    const Pass& pass = m.passes[static_cast<std::size_t>(pi)];
    const double d = m.distance_since_start_m[i];
    if (d < 5 * g[i]) zone[i] = Zone::kPresliding;
    else if (s.velocity_m_per_s[i] * pass.direction <= 0) zone[i] = Zone::kNone;
    else if (d >= 0.2 * pass_length(s, pass)) zone[i] = Zone::kSteady;
    else zone[i] = Zone::kSliding;
  }
}

Signature compute_signature(Effect effect, const SignatureInput& input) { return compute_signature(effect, SignatureContext(input)); }

Signature compute_signature(Effect effect, const SignatureContext& c) {
  switch (effect) {
    case Effect::kDwellStiction: return dwell_stiction(c);
    case Effect::kFrictionalLag: return frictional_lag(c);
    case Effect::kVelocityStrengthening: return velocity_strengthening(c);
    case Effect::kLoadDependence: return load_dependence(c);
    case Effect::kPositionPeriodic: return position_periodic(c);
    case Effect::kDirectionAsymmetry: return direction_asymmetry(c);
    case Effect::kTiltOffset: return tilt_offset(c);
    case Effect::kDrift: return drift(c);
    case Effect::kPreslidingHysteresis: return presliding_hysteresis(c);
    case Effect::kBacklash: return backlash(c);
    case Effect::kRateState: return rate_state(c);
  }
  return {};
}

}  // namespace tribo::analysis
