#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>

#include <gtest/gtest.h>

#include "analysis/models/autodiff.h"
#include "analysis/models/friction_model.h"
#include "analysis/models/model_fit.h"
#include "tests/analysis/synthetic_run.h"

namespace tribo::analysis {
namespace {

struct Fixture {
  Fixture() : Fixture(testing::single_load_run(5)) {}
  explicit Fixture(MeasuredSeries s) : series(std::move(s)), motion(segment_motion(series)), data(series, motion) {}
  // The contact's values in structure st (load-scaled: mu_c, mu_s).
  ModelParams base(const ModelStructure& st) const {
    ModelParams p = base_params(data, st);
    p.set_value("mu_c", 0.10);
    p.set_value("mu_s", 0.143);
    p.set_value("vs", 1.2e-6);
    p.set_value("sigma0", 3414.6);
    p.set_value("sigma1", 5.5);
    p.set_value("Fv", 0.5);
    p.set_value("offset", 1e-6);
    return p;
  }
  ModelParams base() const {
    ModelStructure st;
    st.load_scaled = true;
    return base(st);
  }
  MeasuredSeries series;
  MotionSegmentation motion;
  ModelData data;
};

// Every parameter as a dual number seeded with its own unit derivative.
std::vector<Dual> seeded_duals(const std::vector<double>& values) {
  const auto n = static_cast<int>(values.size());
  std::vector<Dual> out(values.size());
  for (int k = 0; k < n; ++k) {
    out[static_cast<std::size_t>(k)] = Dual(values[static_cast<std::size_t>(k)], DerivativeVector::Zero(n));
    out[static_cast<std::size_t>(k)].derivatives()[k] = 1.0;
  }
  return out;
}

// Every parameter's Jacobian column from the dual numbers against central
// finite differences; each column must move the force somewhere. Switching
// points (the sub-step count, backlash contact, elasto-plastic zones, the
// lag's interpolation interval) make a few samples non-differentiable for
// finite differences: 99 % of them must agree.
void expect_jacobian_matches_finite_differences(const ModelData& data, const ModelParams& p) {
  const auto n = static_cast<int>(p.theta.size());
  ASSERT_LE(n, kMaxFreeParams);
  std::vector<Dual> ad;
  simulate_generic<Dual>(data, p, seeded_duals(p.theta), ad);
  for (int k = 0; k < n; ++k) {
    ModelParams up = p, down = p;
    const double h = 1e-6;
    up.theta[static_cast<std::size_t>(k)] += h;
    down.theta[static_cast<std::size_t>(k)] -= h;
    const auto fu = simulate(data, up), fd = simulate(data, down);
    double scale = 0;
    for (std::size_t i = 0; i < fu.size(); ++i) scale = std::max(scale, std::fabs(fu[i] - fd[i]) / (2 * h));
    std::size_t agree = 0;
    for (std::size_t i = 0; i < fu.size(); ++i) {
      const double numeric = (fu[i] - fd[i]) / (2 * h);
      const double exact = ad[i].derivatives().size() > k ? ad[i].derivatives()[k] : 0.0;
      if (std::fabs(numeric - exact) <= 1e-4 * scale + 1e-6 * std::fabs(exact) + 1e-15) ++agree;
    }
    const std::string& name = p.specs[static_cast<std::size_t>(k)].name;
    EXPECT_GT(scale, 0.0) << name;
    EXPECT_GE(static_cast<double>(agree), 0.99 * static_cast<double>(fu.size())) << name;
  }
}

TEST(FrictionModel, SlidingSettlesOnTheLugreSteadyState) {
  Fixture f;
  const ModelParams p = f.base();
  const auto force = simulate(f.data, p);
  int checked = 0;
  for (const Pass& pass : f.motion.passes) {
    const std::size_t i = (pass.first + pass.last) / 2;  // mid-pass, at plateau speed
    const double v = f.series.velocity_m_per_s[i];
    if (std::fabs(v - pass.direction * pass.median_speed_m_per_s) > 0.01 * pass.median_speed_m_per_s) continue;
    const double expected = steady_state_friction(p, v, f.series.normal_force_n[i]) + 1e-6;
    EXPECT_NEAR(force[i], expected, 0.01 * std::fabs(expected)) << "t = " << f.series.time_s[i];
    ++checked;
  }
  EXPECT_GE(checked, 4);
}

// E|v + d| for d ~ N(0, rms^2), by quadrature over d (not the model's closed form).
double mean_dithered_speed(double v, double rms) {
  double sum = 0, weight = 0;
  for (int k = -4000; k <= 4000; ++k) {
    const double d = rms * k / 500.0, w = std::exp(-0.5 * (d / rms) * (d / rms));
    sum += w * std::fabs(v + d);
    weight += w;
  }
  return sum / weight;
}

// The unresolved dither drains the bristle: in steady sliding the friction
// is the level times |v| / E|v + d| (plus the viscous term), and a dither
// far below the sliding speed leaves the model as it was.
TEST(FrictionModel, TheUnresolvedDitherSettlesSlidingOnTheLevelOverTheDitheredMeanSpeed) {
  Fixture f;
  const ModelParams plain = f.base();
  // Mid-pass samples at plateau speed; the dither set to the fastest of them.
  std::vector<std::size_t> plateau;
  double fastest = 0;
  for (const Pass& pass : f.motion.passes) {
    const std::size_t i = (pass.first + pass.last) / 2;
    const double v = f.series.velocity_m_per_s[i];
    if (std::fabs(v - pass.direction * pass.median_speed_m_per_s) > 0.01 * pass.median_speed_m_per_s) continue;
    plateau.push_back(i);
    fastest = std::max(fastest, std::fabs(v));
  }
  ASSERT_GE(plateau.size(), 4u);
  ModelStructure st = plain.structure;
  st.unresolved_dither = true;
  ModelParams p = f.base(st);
  p.set_value("dither_speed", fastest);
  const auto force = simulate(f.data, p);
  double lowest_share = 1;
  for (std::size_t i : plateau) {
    const double v = f.series.velocity_m_per_s[i], normal = f.series.normal_force_n[i];
    const double fv = p.value("Fv") * v;
    const double share = std::fabs(v) / mean_dithered_speed(v, fastest);
    const double expected = (steady_state_friction(plain, v, normal) - fv) * share + fv + 1e-6;
    EXPECT_NEAR(force[i], expected, 0.01 * std::fabs(expected)) << "t = " << f.series.time_s[i] << ", v = " << v;
    EXPECT_NEAR(steady_state_friction(p, v, normal) + 1e-6, expected, 1e-6 * std::fabs(expected));
    lowest_share = std::min(lowest_share, share);
  }
  EXPECT_LT(lowest_share, 0.7);  // the passes reach speeds where the drain shows

  p.set_value("dither_speed", 1e-6 * f.data.speed_ref);
  const auto faint = simulate(f.data, p), none = simulate(f.data, plain);
  for (std::size_t i = 0; i < none.size(); ++i) ASSERT_NEAR(faint[i], none[i], 1e-4 * f.data.force_scale) << i;
}

// The dither's column of the Jacobian from the dual numbers is the finite
// difference's, and so are the base parameters' beside it.
TEST(FrictionModel, TheUnresolvedDithersJacobianMatchesFiniteDifferences) {
  Fixture f;
  const ModelParams plain = f.base();
  ModelStructure st = plain.structure;
  st.unresolved_dither = true;
  ModelParams p = f.base(st);
  p.set_value("dither_speed", 0.3 * f.data.speed_ref);
  expect_jacobian_matches_finite_differences(f.data, p);
}

TEST(FrictionModel, ExtensionsAtTheirNeutralValuesLeaveTheModelUnchanged) {
  Fixture f;
  const ModelParams base = f.base();
  ModelParams p = base;
  for (Effect e : {Effect::kTiltOffset, Effect::kDirectionAsymmetry, Effect::kDrift, Effect::kVelocityStrengthening,
                   Effect::kLoadDependence, Effect::kPositionPeriodic}) {
    p = with_effect(p, e, f.data);  // neutral: amplitudes zero
  }
  const auto a = simulate(f.data, base), b = simulate(f.data, p);
  for (std::size_t i = 0; i < a.size(); ++i) ASSERT_NEAR(a[i], b[i], 1e-15 + 1e-12 * std::fabs(a[i])) << i;
}

TEST(FrictionModel, AutodiffJacobianMatchesFiniteDifferencesForEveryEffect) {
  Fixture f;
  ModelParams p = f.base();
  p.structure.periodic_additive = false;
  const std::vector<std::pair<Effect, std::vector<double>>> effects = {
      {Effect::kDwellStiction, {0.03, 2.0}},     {Effect::kFrictionalLag, {0.0213}},  // not a whole number of samples: a kink of the interpolation
      {Effect::kVelocityStrengthening, {0.005}}, {Effect::kLoadDependence, {-0.1}},
      {Effect::kPositionPeriodic, {0.05, 0.02, 0.9e-6}}, {Effect::kDirectionAsymmetry, {0.05, -0.1}},
      {Effect::kTiltOffset, {0.01}},             {Effect::kDrift, {}},
      {Effect::kPreslidingHysteresis, {0.4}},    {Effect::kBacklash, {0.05e-6}}};
  for (const auto& [e, values] : effects) p = with_effect(p, e, f.data, values);
  for (std::size_t k = 0; k < p.theta.size(); ++k) {
    if (p.specs[k].name.rfind("drift_", 0) == 0) p.theta[k] = 0.3;
  }
  expect_jacobian_matches_finite_differences(f.data, p);
}

// The fit evaluates its trial points with their Jacobian (analysis/models/model_fit.cc,
// ModelFunctor) and takes the residual from the dual numbers' values: they
// must be the plain simulation's, bit for bit, for every effect and every
// derivative width, or the fit would change with that choice.
TEST(FrictionModel, TheAutodiffSimulationsForceIsThePlainOneBitForBit) {
  Fixture f;
  const std::vector<std::pair<Effect, std::vector<double>>> effects = {
      {Effect::kDwellStiction, {0.03, 2.0}},     {Effect::kFrictionalLag, {0.0213}},
      {Effect::kVelocityStrengthening, {0.005}}, {Effect::kLoadDependence, {-0.1}},
      {Effect::kPositionPeriodic, {0.05, 0.02, 0.9e-6}}, {Effect::kDirectionAsymmetry, {0.05, -0.1}},
      {Effect::kTiltOffset, {0.01}},             {Effect::kDrift, {}},
      {Effect::kPreslidingHysteresis, {0.4}},    {Effect::kBacklash, {0.05e-6}}};
  std::vector<ModelParams> models;
  for (bool from_rest : {false, true}) {
    ModelParams p = f.base();
    p.structure.state_from_rest = from_rest;
    for (const auto& [e, values] : effects) p = with_effect(p, e, f.data, values);
    for (std::size_t k = 0; k < p.theta.size(); ++k) {
      if (p.specs[k].name.rfind("drift_", 0) == 0) p.theta[k] = 0.3;
    }
    models.push_back(p);
  }
  for (bool slip : {false, true}) {
    ModelParams p = f.base();
    p.structure.rate_state_slip_law = slip;
    models.push_back(with_effect(p, Effect::kRateState, f.data));
  }
  std::vector<std::size_t> rows(f.series.size());
  for (std::size_t i = 0; i < rows.size(); ++i) rows[i] = i;
  for (const ModelParams& p : models) {
    const std::vector<double> plain = simulate(f.data, p);
    for (std::size_t width : {std::size_t{1}, std::size_t{3}, std::size_t{6}, std::size_t{9}, std::size_t{13}, p.theta.size()}) {
      if (width > p.theta.size()) continue;
      std::vector<int> columns;
      for (std::size_t k = 0; k < width; ++k) columns.push_back(static_cast<int>(p.theta.size() - 1 - k));
      std::vector<double> dual_force;
      model_jacobian(f.data, p, p.theta, columns, {rows.front()}, &dual_force);
      ASSERT_EQ(dual_force.size(), plain.size());
      std::size_t differing = 0;
      for (std::size_t i = 0; i < plain.size(); ++i) differing += std::memcmp(&plain[i], &dual_force[i], sizeof(double)) != 0;
      EXPECT_EQ(differing, 0u) << width << " derivative columns, " << p.theta.size() << " parameters";
    }
  }
}

// The value and every derivative, bit for bit.
bool same_bits(const Dual& a, const Dual& b) {
  bool same = std::memcmp(&a.value(), &b.value(), sizeof(double)) == 0 && a.derivatives().size() == b.derivatives().size();
  for (Eigen::Index k = 0; same && k < a.derivatives().size(); ++k) {
    same = std::memcmp(&a.derivatives()[k], &b.derivatives()[k], sizeof(double)) == 0;
  }
  return same;
}

// A fit reads its residual and Jacobian rows at its own samples only, and
// with the pass start from rest the simulation leaves out what it ignores
// up to the end of a hold (held-out passes, the holds): at every sample it
// takes, the force and each derivative must be the full simulation's, bit
// for bit, with every effect that carries state across samples (contact
// age, rate-and-state variable, lag, plasticity).
TEST(FrictionModel, ASinkThatIgnoresSamplesGetsTheFullSimulationsValuesAtThoseItTakes) {
  Fixture f;
  std::vector<char> taken(f.series.size());
  for (std::size_t i = 0; i < taken.size(); ++i) taken[i] = !f.motion.heldout[i] && !f.data.at_rest[i];
  for (bool slip : {false, true}) {
    ModelParams p = f.base();
    p.structure.state_from_rest = true;
    p.structure.rate_state_slip_law = slip;
    for (const auto& [e, values] : std::vector<std::pair<Effect, std::vector<double>>>{
             {Effect::kDwellStiction, {0.03, 2.0}}, {Effect::kFrictionalLag, {0.0213}},
             {Effect::kPreslidingHysteresis, {0.4}}, {Effect::kTiltOffset, {0.01}}, {Effect::kRateState, {}}}) {
      p = with_effect(p, e, f.data, values);
    }
    const std::vector<Dual> theta = seeded_duals(p.theta);
    std::vector<Dual> full;
    simulate_generic<Dual>(f.data, p, theta, full);
    std::size_t delivered = 0, differing = 0, taken_seen = 0;
    auto check = [&](std::size_t i, const Dual& force, const Dual&) {
      ++delivered;
      if (!taken[i]) return;
      ++taken_seen;
      differing += !same_bits(full[i], force);
    };
    simulate_streamed<Dual>(f.data, p, theta, SampleSink<Dual>(check, &taken));
    EXPECT_EQ(differing, 0u) << (slip ? "slip law" : "ageing law");
    EXPECT_EQ(taken_seen, static_cast<std::size_t>(std::count(taken.begin(), taken.end(), 1)));
    EXPECT_LT(delivered, f.series.size() * 3 / 4);  // held-out passes and holds were left out
  }
}

// With the pass start from rest, a simulation started at a pass start after
// a hold (its contact age and rate-and-state variable advanced there first)
// gives the full simulation's force and derivatives from there on, bit for
// bit, with every effect that carries state across samples: so a fit
// simulates a long record in pieces at once (model_fit.cc), and its Jacobian
// is the one taken in one sequential run. Backlash carries its side
// in contact over a hold: no such start.
TEST(FrictionModel, ASimulationStartedAtAPassStartGivesTheFullSimulationsValues) {
  MeasuredSeries three_loads = testing::synthetic_run({}, 5);
  derive_motion(three_loads, 0);
  const Fixture f(std::move(three_loads));
  const std::size_t n = f.series.size();
  for (bool slip : {false, true}) {
    ModelStructure st;
    st.load_scaled = true;
    st.state_from_rest = true;
    st.rate_state_slip_law = slip;
    ModelParams p = f.base(st);
    for (const auto& [e, initial] : std::vector<std::pair<Effect, std::vector<double>>>{
             {Effect::kTiltOffset, {0.01}}, {Effect::kPreslidingHysteresis, {0.4}}, {Effect::kDwellStiction, {0.03, 2.0}},
             {Effect::kFrictionalLag, {0.0213}}, {Effect::kRateState, {}}}) {
      p = with_effect(p, e, f.data, initial);
    }
    const std::string law = slip ? "slip law" : "ageing law";
    const std::size_t cut = pass_start_near(f.data, p, n / 2);
    ASSERT_GT(cut, 0u) << law;
    ASSERT_TRUE(f.data.at_rest[cut - 1] && !f.data.at_rest[cut]);

    const std::vector<Dual> theta = seeded_duals(p.theta);
    std::vector<Dual> full;
    simulate_generic<Dual>(f.data, p, theta, full);
    std::size_t delivered = 0, differing = 0;
    auto check = [&](std::size_t i, const Dual& force, const Dual&) {
      ++delivered;
      differing += !same_bits(full[i], force);
    };
    simulate_streamed<Dual>(f.data, p, theta, SampleSink<Dual>(check), nullptr, cut);
    EXPECT_EQ(delivered, n - cut) << law;
    EXPECT_EQ(differing, 0u) << law;

    // Every sample a row: enough rows (10 000 a piece) that the Jacobian is
    // taken in pieces at once on two cores; each half alone, too few for
    // two pieces, is taken in one sequential run.
    std::vector<int> columns(p.theta.size());
    for (std::size_t k = 0; k < columns.size(); ++k) columns[k] = static_cast<int>(k);
    std::vector<std::size_t> rows(n), before(cut), after(n - cut);
    for (std::size_t i = 0; i < n; ++i) (i < cut ? before[i] : after[i - cut]) = rows[i] = i;
    ASSERT_GE(n, 20000u) << "too few rows for the Jacobian to be taken in pieces";
    ASSERT_LT(std::max(cut, n - cut), 20000u) << "a half taken in pieces again";
    const Eigen::MatrixXd whole = model_jacobian(f.data, p, p.theta, columns, rows);
    const Eigen::MatrixXd first = model_jacobian(f.data, p, p.theta, columns, before);
    const Eigen::MatrixXd second = model_jacobian(f.data, p, p.theta, columns, after);
    EXPECT_TRUE((whole.topRows(static_cast<Eigen::Index>(cut)).array() == first.array()).all()) << law;
    EXPECT_TRUE((whole.bottomRows(static_cast<Eigen::Index>(n - cut)).array() == second.array()).all()) << law;

    const ModelParams with_play = with_effect(p, Effect::kBacklash, f.data, {0.05e-6});
    EXPECT_EQ(pass_start_near(f.data, with_play, n / 2), 0u);
    auto ignore = [](std::size_t, const double&, const double&) {};
    EXPECT_THROW(simulate_streamed<double>(f.data, with_play, with_play.theta, SampleSink<double>(ignore), nullptr, cut),
                 std::invalid_argument);
  }
}

// The Jacobian fills the columns of additive parameters (offset, mass, tilt,
// drift, Fv) from the data instead of carrying them through the simulation
// as dual numbers (analysis/models/friction_model.h, AdditiveColumn): every entry
// must still be the one the dual numbers give, for every column, with and
// without the pass start from rest and with direction asymmetry (which
// scales Fv: carried), backlash (whose gaps evaluate no friction). With the
// pass start from rest the added terms also enter each pass's bristle state,
// through one shared derivative (RestStateLane): those columns are the same
// derivatives summed in another order, equal to 1e-9 of the column's
// largest entry; every other entry is the dual numbers' own, bit for bit.
TEST(FrictionModel, TheJacobiansAdditiveColumnsAreTheDualNumbersOwn) {
  Fixture f;
  for (const auto& [from_rest, more] : std::vector<std::pair<bool, Effect>>{
           {false, Effect::kBacklash}, {true, Effect::kBacklash}, {false, Effect::kDirectionAsymmetry}}) {
    ModelStructure st;
    st.load_scaled = true;
    st.fit_mass = true;
    st.state_from_rest = from_rest;
    ModelParams p = f.base(st);
    p.set_value("mass", 2e-3);
    for (const auto& [e, initial] : std::vector<std::pair<Effect, std::vector<double>>>{
             {Effect::kTiltOffset, {0.01}}, {Effect::kDrift, {}}, {Effect::kDwellStiction, {0.03, 2.0}},
             {more, more == Effect::kBacklash ? std::vector<double>{0.05e-6} : std::vector<double>{0.05, -0.1}}}) {
      p = with_effect(p, e, f.data, initial);
    }
    for (std::size_t k = 0; k < p.theta.size(); ++k) {
      if (p.specs[k].name.rfind("drift_", 0) == 0) p.theta[k] = 0.1 * static_cast<double>(k % 5) - 0.2;
    }
    const auto n = static_cast<int>(p.theta.size());
    ASSERT_LE(n, kMaxFreeParams);
    const std::vector<Dual> theta = seeded_duals(p.theta);
    std::vector<Dual> reference;
    simulate_generic<Dual>(f.data, p, theta, reference);
    std::vector<int> columns;
    for (int k = 0; k < n; ++k) columns.push_back(k);
    std::vector<std::size_t> rows;
    for (std::size_t i = 0; i < f.series.size(); i += 3) rows.push_back(i);
    const Eigen::MatrixXd jacobian = model_jacobian(f.data, p, p.theta, columns, rows);
    for (int k = 0; k < n; ++k) {
      const std::string& name = p.specs[static_cast<std::size_t>(k)].name;
      const bool through_rest_state = from_rest && (name == "offset" || name == "mass" || name == "tilt_tan" || name.rfind("drift_", 0) == 0);
      std::size_t differing = 0, nonzero = 0;
      const double tolerance = through_rest_state ? 1e-9 * jacobian.col(k).cwiseAbs().maxCoeff() : 0.0;
      for (std::size_t r = 0; r < rows.size(); ++r) {
        const Dual& d = reference[rows[r]];
        const double expected = d.derivatives().size() > k && std::isfinite(d.derivatives()[k]) ? d.derivatives()[k] : 0.0;
        const double got = jacobian(static_cast<Eigen::Index>(r), k);
        differing += !(std::fabs(got - expected) <= tolerance);  // an exact zero may carry either sign
        nonzero += got != 0.0;
      }
      EXPECT_EQ(differing, 0u) << p.specs[static_cast<std::size_t>(k)].name << (from_rest ? ", state from rest" : "");
      if (p.specs[static_cast<std::size_t>(k)].name.rfind("drift_", 0) != 0) {
        EXPECT_GT(nonzero, rows.size() / 2) << p.specs[static_cast<std::size_t>(k)].name;  // a column that is there
      }
    }
  }
}

// The drift spline's knots split the samples the fit sees (sliding, not held
// out) into equal shares; with knots uniform in time this record's shares
// were 2.77, 0.20, 0.22 and 0.81 times the mean (measured when the test was
// written).
TEST(FrictionModel, TheDriftKnotsShareTheFittedSamplesEqually) {
  Fixture f;
  const auto& knots = f.data.drift_knot_time_s;
  const int intervals = f.data.drift_functions - 3;
  ASSERT_EQ(static_cast<int>(knots.size()), intervals + 1);
  std::vector<int> share(static_cast<std::size_t>(intervals), 0);
  int fitted = 0;
  for (std::size_t i = 0; i < f.series.size(); ++i) {
    if (f.data.at_rest[i] || f.motion.heldout[i] || f.motion.direction[i] == 0) continue;
    const double u = f.data.drift_spline_coordinate(f.series.time_s[i]);
    ++share[std::min(static_cast<std::size_t>(u * intervals), share.size() - 1)];
    ++fitted;
  }
  for (int k = 0; k < intervals; ++k) {
    EXPECT_NEAR(share[static_cast<std::size_t>(k)], static_cast<double>(fitted) / intervals, 2.0) << "interval " << k;
  }
  // The spline coordinate runs from 0 to 1 over the record without going back.
  EXPECT_DOUBLE_EQ(f.data.drift_spline_coordinate(f.series.time_s.front()), 0.0);
  EXPECT_DOUBLE_EQ(f.data.drift_spline_coordinate(f.series.time_s.back()), 1.0);
  for (std::size_t i = 1; i < f.series.size(); ++i) {
    ASSERT_GE(f.data.drift_spline_coordinate(f.series.time_s[i]), f.data.drift_spline_coordinate(f.series.time_s[i - 1]));
  }
}

TEST(FrictionModel, ParameterTransformsKeepThetaOfOrderOne) {
  ParamSpec log_spec{"sigma0", "N/m", Transform::kLog, 3000.0, false, {}};
  EXPECT_DOUBLE_EQ(param_value(log_spec, 0.0), 3000.0);
  EXPECT_NEAR(param_theta(log_spec, 3000.0 * std::exp(1.5)), 1.5, 1e-12);
  ParamSpec logit{"breakaway_ratio", "1", Transform::kLogit, 1.0, false, {}};
  EXPECT_DOUBLE_EQ(param_value(logit, 0.0), 0.5);
  EXPECT_NEAR(param_value(logit, param_theta(logit, 0.8)), 0.8, 1e-12);
}

}  // namespace
}  // namespace tribo::analysis
