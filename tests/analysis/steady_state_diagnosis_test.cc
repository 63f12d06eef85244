// tribo-fit stribeck --diagnose: the effect report on steady-state
// points. Synthetic points come from the model's own closed form (not tribo's
// simulated instrument) at a 2 % force noise; the measured case is the EMPS
// drive's 31 velocity plateaus, whose direction asymmetry is published
// (Janot, Gautier and Brunot 2019: Fv+ 166.7, Fv- 240.4 N s/m).
#include <cmath>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>

#include "analysis/input/series_input.h"
#include "analysis/effects/steady_state_diagnosis.h"

namespace tribo::analysis {
namespace {

struct Truth {
  double fc_pos = 40e-6, fc_neg = 40e-6, fs = 60e-6, vs = 2e-6, fv = 0.5, log_coeff = 0, load_exponent = 1;
};

// 20 speeds 0.1-100 µm/s per direction, three loads (1, 2, 4 mN; levels at 2 mN).
std::vector<SteadyPoint> points(const Truth& t, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  std::vector<SteadyPoint> out;
  for (double load : {1e-3, 2e-3, 4e-3}) {
    for (int dir : {1, -1}) {
      for (int k = 0; k < 20; ++k) {
        const double speed = 1e-7 * std::pow(10.0, 3.0 * k / 19.0);
        const double fc = dir > 0 ? t.fc_pos : t.fc_neg;
        const double scale = std::pow(load / 2e-3, t.load_exponent);
        const double level = scale * (fc + (t.fs - fc) * std::exp(-speed / t.vs) + t.log_coeff * std::log(speed / 3.16e-6));
        const double force = dir * (level + t.fv * speed);
        out.push_back({dir * speed, force * (1 + 0.02 * unit(rng)), load, 1.0});
      }
    }
  }
  return out;
}

double param(const SteadyModelFit& f, const std::string& name, double* se = nullptr) {
  for (const auto& p : f.parameters) {
    if (p.name == name) {
      if (se) *se = p.std_error;
      return p.value;
    }
  }
  ADD_FAILURE() << "no parameter " << name << " in " << f.name;
  return NAN;
}

SteadyOptions with_load() {
  SteadyOptions o;
  o.has_load = true;
  return o;
}

TEST(SteadyStateDiagnosis, CleanPointsAcceptNothingOnTheStribeckBase) {
  for (unsigned seed : {1u, 2u, 3u}) {
    const SteadyDiagnosis d = diagnose_steady_state(points(Truth{}, seed), with_load());
    EXPECT_EQ(d.base.name, "lugre_steady") << seed;
    EXPECT_TRUE(d.accepted.empty()) << seed << ": " << steady_diagnosis_text(d);
    EXPECT_EQ(d.held_out_scheme, "leave-one-out");
  }
}

TEST(SteadyStateDiagnosis, PerDirectionLevelsAreFoundAndRecovered) {
  Truth t;
  t.fc_neg = 30e-6;
  const SteadyDiagnosis d = diagnose_steady_state(points(t, 4), with_load());
  ASSERT_FALSE(d.accepted.empty()) << steady_diagnosis_text(d);
  EXPECT_EQ(d.accepted.front(), "direction_asymmetry");
  double se_pos = 0, se_neg = 0;
  const double fc_pos = param(d.final_model, "Fc_pos", &se_pos), fc_neg = param(d.final_model, "Fc_neg", &se_neg);
  EXPECT_NEAR(fc_pos, t.fc_pos, 3 * se_pos);
  EXPECT_NEAR(fc_neg, t.fc_neg, 3 * se_neg);
  EXPECT_LT(se_neg, 1e-6);
}

TEST(SteadyStateDiagnosis, LogVelocityStrengtheningIsNamedAndWeakeningIsNot) {
  Truth t;
  t.log_coeff = 3e-6;  // +3 µN per e-fold of speed
  const SteadyDiagnosis d = diagnose_steady_state(points(t, 5), with_load());
  ASSERT_EQ(d.accepted.size(), 1u) << steady_diagnosis_text(d);
  EXPECT_EQ(d.accepted.front(), "velocity_strengthening");
  double se = 0;
  const double coeff = param(d.final_model, "log_velocity_coeff", &se);
  EXPECT_NEAR(coeff, t.log_coeff, 3 * se);
  t.log_coeff = -3e-6;
  const SteadyDiagnosis weak = diagnose_steady_state(points(t, 5), with_load());
  for (const auto& e : weak.accepted) EXPECT_NE(e, "velocity_strengthening") << steady_diagnosis_text(weak);
}

TEST(SteadyStateDiagnosis, FrictionNotProportionalToLoadIsLoadDependence) {
  Truth t;
  t.load_exponent = 2.0 / 3.0;  // Hertzian contact area
  const SteadyDiagnosis d = diagnose_steady_state(points(t, 6), with_load());
  ASSERT_EQ(d.accepted.size(), 1u) << steady_diagnosis_text(d);
  EXPECT_EQ(d.accepted.front(), "load_dependence");
  EXPECT_NEAR(param(d.final_model, "load_exponent"), 2.0 / 3.0, 0.05);
}

TEST(SteadyStateDiagnosis, TheEmpsPlateausShowThePublishedDirectionAsymmetry) {
  std::string error;
  const auto table = read_csv_columns(TRIBO_SOURCE_DIR "/tests/data/measured/emps_plateaus.csv",
                                      {"v_m_s", "friction_n"}, error);
  ASSERT_TRUE(table) << error;
  std::vector<SteadyPoint> pts;
  for (std::size_t i = 0; i < (*table)[0].size(); ++i) pts.push_back({(*table)[0][i], (*table)[1][i], 0, 1});
  const SteadyDiagnosis d = diagnose_steady_state(pts, SteadyOptions{});
  ASSERT_FALSE(d.accepted.empty()) << steady_diagnosis_text(d);
  EXPECT_EQ(d.accepted.front(), "direction_asymmetry");
  EXPECT_LT(d.final_model.held_out_rms_n, 0.5 * d.base.held_out_rms_n);
  double se_pos = 0, se_neg = 0;
  const double fv_pos = param(d.final_model, "Fv_pos", &se_pos), fv_neg = param(d.final_model, "Fv_neg", &se_neg);
  // Published (a dynamic inverse model on the whole record): 166.7 and 240.4 N s/m.
  EXPECT_NEAR(fv_pos, 166.7, 0.1 * 166.7);
  EXPECT_NEAR(fv_neg, 240.4, 0.1 * 240.4);
  EXPECT_GT(fv_neg - fv_pos, 5 * std::hypot(se_pos, se_neg));
}

TEST(SteadyStateDiagnosis, BadPointsAreRefusedNamingThePoint) {
  std::vector<SteadyPoint> pts = points(Truth{}, 7);
  pts[3].velocity_m_per_s = 0;
  try {
    diagnose_steady_state(pts, SteadyOptions{});
    FAIL() << "a zero velocity was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("point 4"), std::string::npos) << e.what();
  }
  pts = points(Truth{}, 7);
  pts[10].force_n = NAN;
  EXPECT_THROW(diagnose_steady_state(pts, SteadyOptions{}), std::invalid_argument);
  pts = points(Truth{}, 7);
  pts[0].load_n = -1;
  EXPECT_THROW(diagnose_steady_state(pts, with_load()), std::invalid_argument);
  EXPECT_THROW(diagnose_steady_state({{1e-6, 1e-5, 0, 1}}, SteadyOptions{}), std::invalid_argument);
}

}  // namespace
}  // namespace tribo::analysis
