// The diagnosis' text report, on a Diagnosis set out here.
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "analysis/diagnosis.h"
#include "analysis/report/diagnosis_report.h"
#include "analysis/models/friction_model.h"
#include "daemon/friction_observer.h"
#include "daemon/friction_report.h"

namespace tribo::analysis {
namespace {

// Each contact tried is set beside the chosen one: an option that predicts
// better (past a bound, or not by the gain) is said to lie below it, never
// "-2.20 standard errors above"; its laws' values come with their errors.
TEST(DiagnosisReport, EachContactOptionIsSaidToLieAboveOrBelowTheChosen) {
  MeasuredSeries s;
  Diagnosis d;
  d.base_contact = BaseContactChoice{};
  d.base_contact->chosen = "lugre";
  const double one_block = std::numeric_limits<double>::infinity();
  d.base_contact->options = {{"lugre", 1.0, "", {}, 6, 0.0},
                             {"lugre+elasto_plastic", 0.9, "fitted breakaway_ratio 0.995 is at a bound", {}, 7, -2.2},
                             {"rate_state_contact", 1.2, "", {{"rs_a", "1", 0.0116, 0.0011, false, true, Effect::kRateState}}, 5, 1.5},
                             {"lugre+rate_state", 1.1, "", {}, 9, one_block}};
  const std::string text = diagnosis_text(s, d);
  EXPECT_NE(text.find("held-out RMS 1 (chosen)"), std::string::npos) << text;
  EXPECT_NE(text.find("(2.20 standard errors below the chosen)"), std::string::npos) << text;
  EXPECT_NE(text.find("(1.50 standard errors above the chosen)"), std::string::npos) << text;
  EXPECT_NE(text.find("(one held-out block: no standard error against the chosen)"), std::string::npos) << text;
  EXPECT_EQ(text.find("-2.20"), std::string::npos) << text;
  EXPECT_NE(text.find("rs_a 0.0116 +- 0.0011 1"), std::string::npos) << text;
}

// A record of a slow pass (2 s at 2 µm/s under 1 mN) and a fast one (0.5 s
// at -20 µm/s under 3 mN), each after a hold; the force is not used.
MeasuredSeries two_passes() {
  MeasuredSeries s;
  const double dt = 1e-3;
  double x = 0;
  auto add = [&](double seconds, double velocity, double load) {
    for (int i = 0; i < static_cast<int>(std::lround(seconds / dt)); ++i) {
      x += velocity * dt;
      s.time_s.push_back(static_cast<double>(s.time_s.size()) * dt);
      s.position_m.push_back(x);
      s.velocity_m_per_s.push_back(velocity);
      s.acceleration_m_per_s2.push_back(0.0);
      s.normal_force_n.push_back(load);
      s.force_n.push_back(velocity == 0 ? 0.0 : 0.1 * load * (velocity > 0 ? 1 : -1));
    }
  };
  add(0.5, 0, 1e-3);
  add(2.0, 2e-6, 1e-3);
  add(0.5, 0, 1e-3);
  add(0.5, -20e-6, 3e-3);
  add(0.5, 0, 3e-3);
  return s;
}

// The report states what the model's log-velocity and load terms are
// referred to (the compensation evaluates them from it): the record's median
// sliding speed and median load in contact, here the slow pass's.
TEST(DiagnosisReport, FinalModelGivesTheReferenceSpeedAndLoad) {
  MeasuredSeries s = two_passes();
  Diagnosis d;
  d.motion = segment_motion(s);
  ASSERT_EQ(d.motion.passes.size(), 2u);
  const auto j = nlohmann::json::parse(diagnosis_json(s, d, ReportInfo{}));
  const auto& m = j.at("final_model");
  EXPECT_NEAR(m.at("reference_speed_m_per_s").get<double>(), 2e-6, 1e-12);
  EXPECT_NEAR(m.at("reference_load").get<double>(), 1e-3, 1e-15);

  // Without a normal channel: no reference load.
  s.normal_force_n.clear();
  const auto without = nlohmann::json::parse(diagnosis_json(s, d, ReportInfo{}));
  EXPECT_TRUE(without.at("final_model").at("reference_load").is_null());
  EXPECT_NEAR(without.at("final_model").at("reference_speed_m_per_s").get<double>(), 2e-6, 1e-12);
}

// The report is the contract between the fit and the friction compensation
// (daemon/friction_report.h): a final model with rate-and-state (either law),
// velocity strengthening and load dependence, as diagnosis_json writes it,
// loads in the compensation, and its observer, driven along the record's
// motion, gives the friction the fit's model gives (simulate) at the end of
// each pass: at the reference speed and load (the slow pass), where the
// log-velocity terms vanish, and at ten times the speed and three times the
// load (the fast pass), where they do not.
TEST(DiagnosisReport, ARateAndStateReportLoadsInTheCompensationAndEvaluatesAsTheFit) {
  const MeasuredSeries s = two_passes();
  for (const bool slip : {false, true}) {
    Diagnosis d;
    d.motion = segment_motion(s);
    const ModelData data(s, d.motion);
    ModelStructure structure;
    structure.load_scaled = true;
    structure.rate_state_slip_law = slip;
    ModelParams p = base_params(data, structure);
    p = with_effect(p, Effect::kRateState, data);
    p = with_effect(p, Effect::kVelocityStrengthening, data);
    p = with_effect(p, Effect::kLoadDependence, data);
    for (const auto& [name, value] :
         {std::pair{"mu_c", 0.09}, {"mu_s", 0.12}, {"vs", 1e-6}, {"sigma0", 3000.0}, {"sigma1", 0.05}, {"Fv", 0.5},
          {"offset", 0.0}, {"rs_a", 0.012}, {"rs_b", 0.009}, {"rs_dc", 0.1e-6}, {"log_velocity_coeff", 0.003},
          {"load_exponent", -0.2}}) {
      ASSERT_GE(p.index(name), 0) << name;
      p.set_value(name, value);
    }
    d.base.result.params.structure = structure;
    d.final_fit.params = p;
    for (const ParamSpec& spec : p.specs) {
      ParamEstimate e;
      e.name = spec.name;
      e.unit = spec.unit;
      e.value = p.value(spec.name);
      d.final_fit.estimates.push_back(e);
    }

    const auto read = daemon::read_friction_report(diagnosis_json(s, d, ReportInfo{}));
    ASSERT_TRUE(std::holds_alternative<daemon::FrictionReport>(read)) << std::get<std::string>(read);
    const daemon::IdentifiedFriction& m = std::get<daemon::FrictionReport>(read).model;
    ASSERT_TRUE(m.rate_state && m.velocity_strengthening && m.load_dependence);
    EXPECT_EQ(m.rate_state_slip_law, slip);

    std::vector<double> friction;
    simulate(data, p, &friction);
    daemon::ObserverState state = daemon::observer_at_rest(m);
    std::vector<double> observed(s.size(), 0.0);
    for (std::size_t i = 1; i < s.size(); ++i) {
      daemon::ObserverInput in;
      in.commanded_velocity_m_per_s = s.velocity_m_per_s[i];
      in.normal_force_n = s.normal_force_n[i];
      in.period_s = s.time_s[i] - s.time_s[i - 1];
      observed[i] = daemon::observer_step(m, daemon::ObserverSettings{}, in, state).friction_n;
    }
    for (const auto& pass : d.motion.passes) {
      std::size_t last = pass.last;  // the last sample that slides
      while (last > pass.first && s.velocity_m_per_s[last] == 0) --last;
      const double v = s.velocity_m_per_s[last];
      // The fit's level without its log terms: the test sees that they are evaluated.
      const double plain_level = (0.09 + 0.03 * std::exp(-std::fabs(v) / 1e-6)) * s.normal_force_n[last];
      const double plain = (v > 0 ? plain_level : -plain_level) + 0.5 * v;
      EXPECT_NEAR(observed[last], friction[last], 1e-6 * std::fabs(friction[last])) << slip << " at " << v;
      if (std::fabs(v) > 2.5e-6) {
        EXPECT_GT(std::fabs(friction[last] - plain), 0.05 * plain_level) << slip;
      }
    }
  }
}

}  // namespace
}  // namespace tribo::analysis
