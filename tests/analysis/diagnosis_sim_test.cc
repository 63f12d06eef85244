// The diagnosis on runs of tribo's simulated instrument (sim/, the effects of
// docs/physics_and_sources.md): the identification protocol
// (config/protocols/identification.textproto) in the closed loop, one effect
// switched on in the sim config and not declared to the analysis. The
// diagnosis must name that effect first and lower the held-out error; a clean
// run accepts nothing; effects that mimic each other are told apart.
//
// Strengths are the sim config's documented defaults unless a comment says
// why not. Tilt is off except in the tilt test (tests/analysis/
// sim_identification_run.h): on an instrument it is corrected or declared
// (--effects), and with it always on every run would name tilt first.
//
// The analysis sees what tribo-fit would see in the run directory: lateral
// position and force from the sensors, normal force; velocity and
// acceleration derived. No mass is fitted: the plate's m a (1 g) is at most
// 2.8 uN, above 1 uN in 40 of 38 700 samples (the 40 um/s onsets), below the
// force channel's noise. The holds only set each pass's initial state
// (ModelStructure::state_from_rest, as tribo-fit does for a run directory): in
// the closed loop the 10 kHz position noise dithers the stuck contact and
// LuGre's bristle relaxes, by up to 65 % of the friction over an 8 s hold at
// 5000 uN, in a way the 200 Hz record cannot show; fitted, the holds pulled
// the base model off (clean run: mu_s 0.20 against 0.143, Fv -0.87 against
// 0.001 N s/m; now 0.1425 and 0.0001).
//
// Every test runs its own simulation (about 1 s of CPU for the 197 s
// protocol at 10 kHz) and one diagnosis (5-15 s).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/QR>
#include <gtest/gtest.h>

#include "analysis/report/diagnosis_report.h"
#include "analysis/fit_commands.h"
#include "tests/analysis/analysis_test_support.h"
#include "tests/analysis/sim_identification_run.h"

namespace tribo::analysis {
namespace {

using testing::accepted;
using testing::accepted_names;
using testing::ConfigEdit;

DiagnosisOptions options_for_runs(std::vector<Effect> candidates = {kAllEffects.begin(), kAllEffects.end()}) {
  DiagnosisOptions options;
  options.base.load_scaled = true;
  options.base.state_from_rest = true;               // as tribo-fit does for a run directory
  options.segmentation.segment_by_reference = true;  // likewise
  options.candidates = std::move(candidates);
  return options;
}

// One line per run for the record (README table): what was accepted, the
// held-out NRMSE before and after, and each fitted candidate's verdict.
void report(const std::string& name, const Diagnosis& d) {
  std::cout << "[sim-diagnosis] " << name << ": accepted " << accepted_names(d);
  char buf[200];
  std::snprintf(buf, sizeof buf, "| held-out NRMSE %.4f -> %.4f, RMS %.3g -> %.3g N | fit NRMSE %.4f -> %.4f\n",
                d.before.heldout.nrmse, d.after.heldout.nrmse, d.before.heldout.rms, d.after.heldout.rms,
                d.before.fit.nrmse, d.after.fit.nrmse);
  std::cout << buf;
  std::cout << "    base:";
  for (const auto& p : d.base.result.estimates) std::cout << " " << p.name << "=" << p.value;
  std::cout << " (converged " << d.base.result.converged << ", " << d.base.result.iterations << " iterations)\n";
  for (const auto& w : d.base.result.warnings) std::cout << "    base warning: " << w << "\n";
  for (const auto& t : d.trials) {
    std::cout << "    round " << t.round << " " << effect_name(t.effect) << (t.passed ? " PASS " : " fail ") << t.verdict;
    for (const auto& p : t.parameters) std::cout << " " << p.name << "=" << p.value;
    std::cout << "\n";
  }
  for (const auto& a : d.accepted) {
    for (const auto& p : a.parameters) {
      std::cout << "    " << effect_name(a.effect) << "." << p.name << " = " << p.value << " +- " << p.std_error << " "
                << p.unit << "\n";
    }
  }
  for (const auto& r : d.rejected) {
    if (r.minimum_detectable) std::cout << "    " << effect_name(r.effect) << ": " << minimum_detectable_text(*r.minimum_detectable) << "\n";
  }
  if (d.unexplained) std::cout << "    unexplained: " << *d.unexplained << "\n";
}

Diagnosis diagnose_run(const std::string& name, const ConfigEdit& edit, std::uint64_t seed = 1,
                       const DiagnosisOptions& options = options_for_runs()) {
  const MeasuredSeries s = testing::simulated_identification_run(testing::identification_config(edit), seed);
  Diagnosis d = diagnose(s, options);
  report(name, d);
  return d;
}

v1::FrictionParams& friction(v1::DaemonConfig& c) { return *c.mutable_sim()->mutable_friction(); }

double parameter_value(const AcceptedEffect& a, const std::string& name) {
  for (const auto& p : a.parameters) {
    if (p.name == name) return p.value;
  }
  ADD_FAILURE() << "no parameter " << name;
  return NAN;
}

struct Case {
  const char* name;
  Effect effect;
  ConfigEdit edit;
  std::vector<Effect> mimics;  // effects it could be mistaken for: not accepted
  std::function<void(const AcceptedEffect&)> check_parameters = {};  // against the sim's values
};

void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

ConfigEdit dwell_stiction() {
  // gain 0.3 (the config's); time constant 2 s instead of the config's 100 s
  // (Fig. 4.22's rise over 30-1000 s would need holds of minutes): the
  // protocol's holds of 0.25-8 s span it.
  return [](v1::DaemonConfig& c) {
    auto& d = *friction(c).mutable_dwell_stiction();
    d.set_enabled(true);
    d.set_gain(0.3);
    d.set_time_constant_s(2.0);
  };
}

// Each at the config's documented strength (docs/physics_and_sources.md "Simulated instrument
// physics"): lag 5 ms (Hess and Soom), log-velocity coefficient 0.002 per
// e-fold above 0.1 um/s (Fig. 4.17: +9 % of mu over 0.4-40 um/s), friction
// ~ N^(2/3) (Hertz area), 10 % over 0.5 um, 5 % direction asymmetry, tilt
// 1.5 deg (Sec. 5.2), creep 0.1 nm/s RMS (Fig. 3.12), a 4-element Maxwell
// slip with breakaway 0.9, a 20 nm dead zone.
ConfigEdit frictional_lag() { return [](v1::DaemonConfig& c) { friction(c).mutable_frictional_lag()->set_enabled(true); }; }
ConfigEdit velocity_strengthening() {
  return [](v1::DaemonConfig& c) { friction(c).mutable_velocity_strengthening()->set_enabled(true); };
}
ConfigEdit load_dependence() { return [](v1::DaemonConfig& c) { friction(c).mutable_load_dependence()->set_enabled(true); }; }
ConfigEdit position_periodic() { return [](v1::DaemonConfig& c) { friction(c).mutable_position_periodic()->set_enabled(true); }; }
ConfigEdit direction_asymmetry() {
  return [](v1::DaemonConfig& c) { friction(c).mutable_direction_asymmetry()->set_enabled(true); };
}
ConfigEdit tilt_offset() {
  return [](v1::DaemonConfig& c) { c.mutable_sim()->mutable_tip()->mutable_tilt_offset()->set_enabled(true); };
}
ConfigEdit drift() { return [](v1::DaemonConfig& c) { c.mutable_sim()->mutable_sample()->mutable_drift()->set_enabled(true); }; }
ConfigEdit presliding_hysteresis() {
  return [](v1::DaemonConfig& c) { friction(c).mutable_presliding_hysteresis()->set_enabled(true); };
}
ConfigEdit backlash() { return [](v1::DaemonConfig& c) { c.mutable_sim()->mutable_tip()->mutable_backlash()->set_enabled(true); }; }

// Identified on the sim runs: named first, held-out error down, mimic not accepted.
std::vector<Case> identified() {
  return {
      {"velocity_strengthening", Effect::kVelocityStrengthening, velocity_strengthening(), {}},
      {"load_dependence", Effect::kLoadDependence, load_dependence(), {Effect::kTiltOffset}},
      {"tilt_offset", Effect::kTiltOffset, tilt_offset(), {Effect::kDirectionAsymmetry}},
      {"position_periodic", Effect::kPositionPeriodic, position_periodic(), {}},
      {"direction_asymmetry", Effect::kDirectionAsymmetry, direction_asymmetry(), {Effect::kTiltOffset}},
      // Dwell stiction: a positive dwell term with a memory inside the
      // presliding deflection was once accepted third here (a wrong label).
      {"presliding_hysteresis",
       Effect::kPreslidingHysteresis,
       presliding_hysteresis(),
       {Effect::kFrictionalLag, Effect::kDwellStiction}},
      {"backlash", Effect::kBacklash, backlash(), {Effect::kPreslidingHysteresis}},
      // Once a known gap: the extension held the dwell for the whole pass
      // after a hold; it now follows the contact age of Dieterich's law, as
      // the instrument does (a pass after a short hold starts from the age
      // the previous pass left: up to 2.5 s after the 0.4 um/s passes).
      {"dwell_stiction", Effect::kDwellStiction, dwell_stiction(), {Effect::kDrift},
       [](const AcceptedEffect& a) {
         // gain 0.3 of mu_s 0.1427, time constant 2 s, memory 1 um (fitted
         // 0.0398, 1.64 s, 1.09 um)
         EXPECT_NEAR(parameter_value(a, "dwell_dFs"), 0.3 * 0.14271, 0.01);
         EXPECT_NEAR(parameter_value(a, "dwell_time"), 2.0, 0.8);
         EXPECT_NEAR(parameter_value(a, "dwell_memory"), 1e-6, 0.3e-6);
       }},
  };
}

class SimulatedEffect : public ::testing::TestWithParam<Case> {};

TEST_P(SimulatedEffect, IsNamedFirstAndLowersTheHeldOutError) {
  const Case& c = GetParam();
  const Diagnosis d = diagnose_run(c.name, c.edit);
  ASSERT_FALSE(d.accepted.empty()) << c.name << ": nothing accepted";
  EXPECT_EQ(d.accepted.front().effect, c.effect) << "accepted: " << accepted_names(d);
  for (Effect m : c.mimics) EXPECT_FALSE(accepted(d, m)) << "mimic accepted: " << accepted_names(d);
  EXPECT_LT(d.after.heldout.rms, 0.95 * d.before.heldout.rms);
  // Its parameters come with uncertainties, or say they have none: a factor
  // on a term these data do not carry (asym_viscous on a contact whose
  // viscous friction is 0.001 N s/m) lies along a null direction of the fit.
  for (const auto& p : d.accepted.front().parameters) {
    if (!p.fixed) {
      EXPECT_TRUE(std::isfinite(p.std_error) || (std::isnan(p.std_error) && !p.determined)) << p.name;
    }
  }
  if (c.check_parameters && d.accepted.front().effect == c.effect) c.check_parameters(d.accepted.front());
}

INSTANTIATE_TEST_SUITE_P(Sim, SimulatedEffect, ::testing::ValuesIn(identified()),
                         [](const auto& info) { return std::string(info.param.name); });

// The effect's minimum detectable strength as the diagnosis reported it (rejected), or NaN.
double minimum_detectable(const Diagnosis& d, Effect e) {
  for (const auto& r : d.rejected) {
    if (r.effect == e && r.minimum_detectable) return r.minimum_detectable->value;
  }
  return std::nan("");
}

// Two effects this protocol cannot reveal at their documented strengths
// (the report says so, with the strength it would need; docs/identification.md "Minimum detectable strength").
//   frictional_lag 5 ms: given the measured motion, the lagged Stribeck speed
//     changes the force too little to see: in the passes the 5 ms run's force
//     differs from the clean run's by 0.75 uN RMS (same seed; the noise is
//     2 uN); LuGre's bristle already lags by g/|v| (30-150 ms at 1 um/s), and
//     above a few vs the Stribeck curve is flat. The report must name it, or
//     say that it needs more than 5 ms.
TEST(DiagnosisSim, FrictionalLagAtItsDocumentedStrengthIsNamedOrReportedBelowDetection) {
  const Diagnosis d = diagnose_run("frictional_lag", frictional_lag());
  if (!d.accepted.empty() && d.accepted.front().effect == Effect::kFrictionalLag) return;
  EXPECT_FALSE(accepted(d, Effect::kFrictionalLag)) << accepted_names(d);
  const double needed_s = minimum_detectable(d, Effect::kFrictionalLag);
  ASSERT_TRUE(std::isfinite(needed_s)) << "no minimum detectable lag reported";
  EXPECT_GT(needed_s, 5e-3) << "the report says a 5 ms lag is detectable, yet it was not found";
}

//   drift (sample creep, 0.1 nm/s RMS): sigma0 v_creep moves the force only
//     while the tip is stuck, and the holds only set each pass's state; in
//     sliding the creep changes nothing. The plain LuGre contact drains any
//     held force under the position wander. The creep's whole effect on the
//     force (this run against the clean one, same seed: every noise channel
//     has its own stream), as far as a drift can model it (its time basis),
//     must be smaller than the smallest drift the report says this record
//     reveals (a linear drift of total change s has RMS s / sqrt(12)).
TEST(DiagnosisSim, SampleCreepMovesTheForceLessThanTheRecordCanReveal) {
  const MeasuredSeries creep = testing::simulated_identification_run(testing::identification_config(drift()), 1);
  const MeasuredSeries clean = testing::simulated_identification_run(testing::identification_config(), 1);
  ASSERT_EQ(creep.size(), clean.size());
  const Diagnosis d = diagnose(creep, options_for_runs());
  report("drift", d);
  // Over the passes (the samples the diagnosis compares: the holds only set
  // each pass's state), the part of the creep's force a drift can take: its
  // least-squares fit on the drift extension's own time basis
  // (ModelData::drift_basis_at).
  const ModelData data(creep, d.motion);
  std::vector<std::size_t> rows;
  for (std::size_t i = 0; i < creep.size(); ++i) {
    if (d.motion.pass_of[i] >= 0) rows.push_back(i);
  }
  ASSERT_GT(rows.size(), creep.size() / 2);
  Eigen::MatrixXd basis(static_cast<Eigen::Index>(rows.size()), data.drift_functions);
  Eigen::VectorXd change(static_cast<Eigen::Index>(rows.size()));
  std::vector<double> b(static_cast<std::size_t>(data.drift_functions));
  for (std::size_t r = 0; r < rows.size(); ++r) {
    data.drift_basis_at(rows[r], b.data());
    for (int k = 0; k < data.drift_functions; ++k) basis(static_cast<Eigen::Index>(r), k) = b[static_cast<std::size_t>(k)];
    change[static_cast<Eigen::Index>(r)] = creep.force_n[rows[r]] - clean.force_n[rows[r]];
  }
  const Eigen::VectorXd slow = basis * basis.colPivHouseholderQr().solve(change);
  const double creep_rms_n = std::sqrt(slow.squaredNorm() / static_cast<double>(rows.size()));
  const double all_rms_n = std::sqrt(change.squaredNorm() / static_cast<double>(rows.size()));
  EXPECT_FALSE(accepted(d, Effect::kDrift)) << accepted_names(d);
  const double needed_n = minimum_detectable(d, Effect::kDrift);
  ASSERT_TRUE(std::isfinite(needed_n)) << "no minimum detectable drift reported";
  std::cout << "[sim-diagnosis] creep moves the force in the passes by " << all_rms_n << " N RMS, of which a drift could take "
            << creep_rms_n << " N RMS; minimum detectable drift "
            << needed_n << " N (RMS " << needed_n / std::sqrt(12.0) << " N)\n";
  EXPECT_LT(creep_rms_n, needed_n / std::sqrt(12.0));
}

// The contact law as a decision on held-out data (base-model
// choice; DiagnosisOptions::choose_base_contact): on the fitted contact
// (config/instruments/fitted_contact.textproto: elasto-plastic presliding and
// rate-and-state, dwell off) plain LuGre
// leaves a structured residual and a richer contact is kept; on the plain
// LuGre instrument LuGre is kept. Neither contact is reported as an effect.
TEST(DiagnosisSim, TheContactLawIsChosenOnHeldOutData) {
  DiagnosisOptions options = options_for_runs();
  options.choose_base_contact = true;
  const MeasuredSeries fitted_contact =
      testing::simulated_identification_run(testing::fitted_contact_identification_config(), 1);
  const Diagnosis d = diagnose(fitted_contact, options);
  report("fitted contact, contact chosen", d);
  ASSERT_TRUE(d.base_contact);
  for (const auto& o : d.base_contact->options) std::cout << "    contact " << o.name << ": held-out RMS " << o.heldout_rms << " N " << o.note << "\n";
  EXPECT_NE(d.base_contact->chosen, "lugre");
  EXPECT_LT(d.after.heldout.rms, 0.7 * d.before.heldout.rms);
  EXPECT_FALSE(accepted(d, Effect::kPreslidingHysteresis)) << "the contact is the base, not an effect";
  for (const auto& r : d.rejected) EXPECT_FALSE(d.final_fit.params.structure.has(r.effect)) << effect_name(r.effect);

  const Diagnosis plain = diagnose_run("plain LuGre instrument, contact chosen", {}, 1, options);
  ASSERT_TRUE(plain.base_contact);
  EXPECT_EQ(plain.base_contact->chosen, "lugre");
  EXPECT_TRUE(plain.accepted.empty()) << accepted_names(plain);
}

// The fitted contact's identification run at 5 uN of lateral force noise,
// with `inject` applied to its config, diagnosed as the contact-choice
// reliability map (config/campaigns/identification_reliability_contact_choice.toml)
// diagnoses its runs; the map's plant is the default instrument, these tests'
// the fitted contact. The contact-choice tests below hold that contact's
// figures (its breakaway ratio 0.917 among them).
DiagnoseOutcome diagnose_default_run_with_contact_choice(std::uint64_t seed, const std::function<void(v1::DaemonConfig&)>& inject) {
  const MeasuredSeries s = testing::simulated_identification_record(
      testing::fitted_contact_identification_config([&](v1::DaemonConfig& c) {
        c.mutable_sim()->mutable_sensors()->set_lateral_force_noise_n(5e-6);
        inject(c);
      }),
      seed);
  DiagnoseRequest request;
  request.tribo_run = true;
  request.choose_base_contact = true;
  return diagnose_series(s, request);
}

DiagnoseOutcome diagnose_clean_default_run_with_contact_choice(std::uint64_t seed) {
  return diagnose_default_run_with_contact_choice(seed, [](v1::DaemonConfig&) {});
}

// A contact law replaces LuGre only if it is physical and predicts the
// held-out passes no worse than LuGre. On the fitted contact's clean run
// (seed 4, lateral force noise 5 uN, diagnosed as the contact-choice
// reliability map diagnoses its runs) LuGre and the elasto-plastic fits are past their bounds and the
// rate-and-state contact is not: taken as the only physical one it was kept
// at 43 uN of held-out RMS beside LuGre's 22, and the final held-out NRMSE
// rose to 0.146 from LuGre's 0.073.
TEST(DiagnosisSim, AContactThatPredictsWorseThanLugreIsNotChosen) {
  const DiagnoseOutcome outcome = diagnose_clean_default_run_with_contact_choice(4);
  ASSERT_TRUE(outcome.error.empty()) << outcome.error;
  const Diagnosis& d = outcome.diagnosis;
  report("fitted contact, clean, seed 4, contact chosen", d);
  ASSERT_TRUE(d.base_contact);
  const auto& options = d.base_contact->options;
  const auto chosen = std::find_if(options.begin(), options.end(), [&](const auto& o) { return o.name == d.base_contact->chosen; });
  ASSERT_NE(chosen, options.end());
  EXPECT_LE(chosen->heldout_rms, options.front().heldout_rms) << d.base_contact->chosen << " against lugre";
  EXPECT_LT(d.after.heldout.rms, d.before.heldout.rms);
}

// A direction asymmetry and a tilt both shift the sliding friction by an
// offset proportional to the load; only a tilt reads at rest too. On the
// default instrument (config/tribod.textproto, diagnosed as the
// contact-choice reliability map diagnoses its runs) a 5 % asymmetry at
// 5 uN of force noise, seed 5, had a tilt accepted in its place at -41 %
// held out when the load changes at rest were not tested; the map's 20
// asymmetry runs had it in 10. The tilt's first fit is refused by the load
// changes at rest and the asymmetry is named.
TEST(DiagnosisSim, ATiltTheLoadChangesAtRestContradictIsNotAccepted) {
  const MeasuredSeries s = testing::simulated_identification_record(
      testing::default_instrument_identification_config([](v1::DaemonConfig& c) {
        c.mutable_sim()->mutable_sensors()->set_lateral_force_noise_n(5e-6);
        auto* asymmetry = c.mutable_sim()->mutable_friction()->mutable_direction_asymmetry();
        asymmetry->set_enabled(true);
        asymmetry->set_ratio(0.05);
      }),
      5);
  DiagnoseRequest request;
  request.tribo_run = true;
  request.choose_base_contact = true;
  const DiagnoseOutcome outcome = diagnose_series(s, request);
  ASSERT_TRUE(outcome.error.empty()) << outcome.error;
  const Diagnosis& d = outcome.diagnosis;
  report("default instrument, direction asymmetry 5 %, seed 5, contact chosen", d);
  for (const auto& a : d.accepted) EXPECT_NE(a.effect, Effect::kTiltOffset);
  const auto tilt = std::find_if(d.trials.begin(), d.trials.end(), [](const auto& t) { return t.effect == Effect::kTiltOffset && t.round == 0; });
  ASSERT_NE(tilt, d.trials.end());
  EXPECT_FALSE(tilt->passed);
  EXPECT_NE(tilt->verdict.find("load changes at rest"), std::string::npos) << tilt->verdict;
  ASSERT_FALSE(d.accepted.empty());
  EXPECT_EQ(d.accepted.front().effect, Effect::kDirectionAsymmetry);
}

// The nested elasto-plastic, rate-and-state contact on the fitted contact's
// clean runs (5 uN, diagnosed as the contact-choice reliability map
// diagnoses its runs): fitted only from the elasto-plastic fit, whose breakaway ratio runs
// to 1 when the rate-and-state law is left out, it stayed at the bound (0.999
// and 0.993 on seeds 1 and 2) with a and b of 1e-4. Restarted
// (contact_choice.cc, fit_nested_law), it is physical: the ratio inside its
// bound (the sim's is 0.917), a and b positive, and it predicts the held-out
// passes better than the contact fitted before it.
void expect_a_physical_nested_contact(std::uint64_t seed) {
  {
    const DiagnoseOutcome outcome = diagnose_clean_default_run_with_contact_choice(seed);
    ASSERT_TRUE(outcome.error.empty()) << outcome.error;
    const Diagnosis& d = outcome.diagnosis;
    report("fitted contact, clean, contact chosen, seed " + std::to_string(seed), d);
    ASSERT_TRUE(d.base_contact);
    const auto& options = d.base_contact->options;
    const auto nested = std::find_if(options.begin(), options.end(), [](const auto& o) { return o.name == "lugre+elasto_plastic+rate_state"; });
    ASSERT_NE(nested, options.end());
    const auto value = [&](const std::string& name) {
      for (const auto& e : nested->parameters) {
        if (e.name == name) return e.value;
      }
      return std::nan("");
    };
    std::cout << "    nested contact: breakaway_ratio " << value("breakaway_ratio") << ", rs_a " << value("rs_a") << ", rs_b "
              << value("rs_b") << ", held-out RMS " << nested->heldout_rms << " N " << nested->note << "\n";
    EXPECT_TRUE(nested->note.empty()) << nested->note;
    EXPECT_GT(value("breakaway_ratio"), 0.85);
    EXPECT_LT(value("breakaway_ratio"), 0.98);
    EXPECT_GT(value("rs_a"), 0.0);
    EXPECT_GT(value("rs_b"), 0.0);
    EXPECT_LT(nested->heldout_rms, std::prev(nested)->heldout_rms);
    EXPECT_EQ(d.base_contact->chosen, "lugre+elasto_plastic+rate_state");
  }
}

TEST(DiagnosisSim, TheNestedRateStateContactIsPhysicalOnTheFittedContact) { expect_a_physical_nested_contact(1); }

TEST(DiagnosisSim, TheNestedRateStateContactIsPhysicalOnTheFittedContactSeed2) { expect_a_physical_nested_contact(2); }

// The minimum detectable strength is a prediction the diagnosis can be held
// to: velocity strengthening at what the clean record needs (the strength
// found with 90 % probability) is found on the same protocol, and at 0.3 of
// it is not.
TEST(DiagnosisSim, TheMinimumDetectableStrengthPredictsWhatIsFound) {
  const Diagnosis clean = diagnose_run("clean", {});
  const double needed = minimum_detectable(clean, Effect::kVelocityStrengthening);
  ASSERT_TRUE(std::isfinite(needed));
  const Diagnosis at_figure = diagnose_run("velocity_strengthening at the minimum", [&](v1::DaemonConfig& c) {
    auto& v = *friction(c).mutable_velocity_strengthening();
    v.set_enabled(true);
    v.set_coeff(needed);
  });
  EXPECT_TRUE(accepted(at_figure, Effect::kVelocityStrengthening)) << accepted_names(at_figure);
  for (const auto& r : clean.rejected) {
    if (r.effect == Effect::kPositionPeriodic || r.effect == Effect::kPreslidingHysteresis) {
      EXPECT_FALSE(r.minimum_detectable) << effect_name(r.effect) << ": its strength is not one axis";
    } else {
      ASSERT_TRUE(r.minimum_detectable) << effect_name(r.effect);
      EXPECT_GT(r.minimum_detectable->value, 0) << effect_name(r.effect);
    }
  }
  const Diagnosis weak = diagnose_run("velocity_strengthening at 0.3 of the minimum", [&](v1::DaemonConfig& c) {
    auto& v = *friction(c).mutable_velocity_strengthening();
    v.set_enabled(true);
    v.set_coeff(0.3 * needed);
  });
  EXPECT_FALSE(accepted(weak, Effect::kVelocityStrengthening)) << accepted_names(weak);
}

// Velocity strengthening at coeff 0.005 (2.5 times the config's), the
// record's position at the default instrument's 10 nm floor, diagnosed as
// tribo-fit diagnoses a run directory.
Diagnosis diagnose_velocity_strengthening_run(std::uint64_t seed) {
  const MeasuredSeries s = testing::simulated_identification_record(testing::identification_config([](v1::DaemonConfig& c) {
    auto& v = *friction(c).mutable_velocity_strengthening();
    v.set_enabled(true);
    v.set_coeff(0.005);
    c.mutable_sim()->mutable_sensors()->set_lateral_position_record_noise_m(10e-9);
  }), seed);
  DiagnoseRequest request;
  request.tribo_run = true;
  DiagnoseOutcome outcome = diagnose_series(s, request);
  if (!outcome.error.empty()) throw std::runtime_error(outcome.error);
  report("velocity_strengthening 0.005, record position noise 10 nm, seed " + std::to_string(seed), outcome.diagnosis);
  return std::move(outcome.diagnosis);
}

// Rate-and-state whose evolution b is not told from zero is its direct
// effect a ln v alone: velocity strengthening, in the same form. On seed 1
// both candidates lowered the held-out error by 17.5 % in the first round,
// and rate_state won by 0.1 % with a = 0.0048 (the 0.005 injected) and
// b = -0.0007 +- 0.0036; velocity strengthening then showed no signature and
// its linearised figure called 0.0014 identifiable (docs/identification.md,
// "Rate-and-state without an evolution").
TEST(DiagnosisSim, VelocityStrengtheningIsNotNamedRateStateWithoutAnEvolution) {
  const Diagnosis d = diagnose_velocity_strengthening_run(1);
  EXPECT_TRUE(accepted(d, Effect::kVelocityStrengthening)) << accepted_names(d);
  EXPECT_FALSE(accepted(d, Effect::kRateState)) << accepted_names(d);
}

// Friction modulated with the sample position over 0.5 um (the config's
// period) reaches the force through the contact's bristle, a lag of
// S / sigma0 = 0.04-0.12 um in slip distance, so the two directions'
// ripples differ in phase by less than 180 deg (76 deg on seed 4 at 10 %).
// Read as 0 against 180 deg, the signature took that for a force ripple;
// the ripple's fit then helped one direction only (held-out -29 %, 67 % of
// the blocks) and was rejected. At 5 % seeds 1, 3, 4 and 5 of the full
// map's 1.4 nm runs were missed so.
TEST(DiagnosisSim, AFrictionModulationBehindTheBristleIsNamedWithItsAmplitude) {
  for (std::uint64_t seed : {3, 4}) {
    const Diagnosis d = diagnose_run("position_periodic 0.05, seed " + std::to_string(seed), [](v1::DaemonConfig& c) {
      auto& p = *friction(c).mutable_position_periodic();
      p.set_enabled(true);
      p.set_amplitude(0.05);
    }, seed);
    ASSERT_FALSE(d.accepted.empty()) << "seed " << seed;
    const AcceptedEffect& a = d.accepted.front();
    ASSERT_EQ(a.effect, Effect::kPositionPeriodic) << accepted_names(d);
    EXPECT_FALSE(a.trial.signature.periodic_additive) << a.trial.signature.summary;
    EXPECT_NEAR(std::hypot(parameter_value(a, "periodic_cos"), parameter_value(a, "periodic_sin")), 0.05, 0.005) << "seed " << seed;
    EXPECT_NEAR(parameter_value(a, "periodic_length"), 0.5e-6, 0.005e-6) << "seed " << seed;
    EXPECT_LT(d.after.heldout.rms, 0.5 * d.before.heldout.rms) << "seed " << seed;
  }
}

// A velocity strengthening the diagnosis misses is not called identifiable
// below its strength. On seed 2 rate_state is accepted with an evolution
// clear of zero (a = 0.0125, b = 0.0076 +- 0.0007, D_c 44 nm: a - b is the
// 0.005 injected) and takes the log-velocity term up; the linearised figure
// of velocity strengthening was 0.0028. Injected into the
// record at 0.0028, 0.0055 and 0.011 and the record diagnosed again for it,
// it is never accepted (docs/identification.md, "The figures checked by
// rediagnosis").
TEST(DiagnosisSim, AMissedVelocityStrengtheningIsNotCalledIdentifiableBelowItsStrength) {
  const Diagnosis d = diagnose_velocity_strengthening_run(2);
  if (accepted(d, Effect::kVelocityStrengthening)) return;
  const double figure = minimum_detectable(d, Effect::kVelocityStrengthening);
  EXPECT_TRUE(!std::isfinite(figure) || figure > 0.005) << "called identifiable at " << figure << ", yet 0.005 was missed";
}

// A backlash play near the position noise is found from the force. Play
// 20 nm under 9.9 nm of position noise per recorded sample (70 nm per loop
// sample), seed 1 of the full reliability map: backlash lowers the held-out
// error by 16 % and its fitted gap (16 +- 3 nm) stands clear of none, below
// three resolved lengths (30 nm). A bound that refused gaps below those
// lengths refused it; scored on the validation split without that bound, no
// row changed.
TEST(DiagnosisSim, ABacklashNearThePositionNoiseIsFoundFromTheForce) {
  const MeasuredSeries s = testing::simulated_identification_record(testing::identification_config([](v1::DaemonConfig& c) {
    auto& b = *c.mutable_sim()->mutable_tip()->mutable_backlash();
    b.set_enabled(true);
    b.set_width_m(20e-9);
    c.mutable_sim()->mutable_sensors()->set_lateral_position_record_noise_m(70e-9);
  }), 1);
  DiagnoseRequest request;
  request.tribo_run = true;
  const DiagnoseOutcome outcome = diagnose_series(s, request);
  ASSERT_TRUE(outcome.error.empty()) << outcome.error;
  const Diagnosis& d = outcome.diagnosis;
  report("backlash 20 nm, record position noise 70 nm per loop sample, seed 1", d);
  ASSERT_FALSE(d.accepted.empty());
  ASSERT_EQ(d.accepted.front().effect, Effect::kBacklash) << accepted_names(d);
  const auto gap = std::find_if(d.accepted.front().parameters.begin(), d.accepted.front().parameters.end(),
                                [](const auto& p) { return p.name == "backlash_gap"; });
  ASSERT_NE(gap, d.accepted.front().parameters.end());
  ASSERT_TRUE(std::isfinite(gap->std_error));
  EXPECT_LT(std::fabs(gap->value - 20e-9), 3 * gap->std_error) << gap->value << " +- " << gap->std_error << " m";
}

TEST(DiagnosisSim, ACleanRunAcceptsNothing) {
  const Diagnosis d = diagnose_run("clean", {});
  EXPECT_TRUE(d.accepted.empty()) << accepted_names(d);
  EXPECT_EQ(d.rejected.size(), kAllEffects.size());
  // The base fit recovers the sim's LuGre (config/tribod.textproto).
  const ModelParams& p = d.base.result.params;
  EXPECT_NEAR(p.value("mu_c"), 0.0996, 0.001);
  EXPECT_NEAR(p.value("mu_s"), 0.14271, 0.004);
  EXPECT_NEAR(p.value("vs"), 1.2e-6, 0.15e-6);
  EXPECT_NEAR(p.value("sigma0"), 3414.6, 340);
  EXPECT_NEAR(p.value("Fv"), 0.001, 0.05);
}

// A base fit biased by the holds would let a negative log-velocity term take
// up part of the 2 N s/m (0.8 of it has been seen); Fv is fitted as 2.01.
TEST(DiagnosisSim, StrongViscousFrictionIsNotMistakenForLogVelocity) {
  // Viscous friction 2 N s/m (80 uN at 40 um/s) instead of the config's
  // 0.001: it belongs in the base model's Fv, not in a log-velocity law.
  const Diagnosis d = diagnose_run("viscous", [](v1::DaemonConfig& c) { friction(c).set_viscous_n_s_per_m(2.0); });
  EXPECT_FALSE(accepted(d, Effect::kVelocityStrengthening)) << accepted_names(d);
  EXPECT_NEAR(d.final_fit.params.value("Fv"), 2.0, 0.1);
}

// A contact law that a later effect's fit takes past its bound leaves the
// model with that effect. On the tilted runs (1.5 deg, tan 0.0262, as
// tribod's default instrument) the contact choice keeps the rate-and-state
// contact, which takes up part of the tilt's direction-signed offset; tilt
// then refits its law past a bound (seed 1: a and b above half the friction
// level; seed 2: a < 0). Refused for that, tilt was missed: direction
// asymmetry was accepted in its place (seed 1, held-out 27 uN), or nothing
// (seed 2, 60 uN). Fitted without the law, the LuGre curve the law held
// flat freed again, tilt predicts the held-out passes at 2 uN.
void expect_the_law_to_leave_with_the_tilt(std::uint64_t seed) {
  DiagnosisOptions options = options_for_runs();
  options.choose_base_contact = true;
  const MeasuredSeries s = testing::simulated_identification_run(testing::identification_config(tilt_offset()), seed);
  const Diagnosis d = diagnose(s, options);
  report("tilt, contact chosen, seed " + std::to_string(seed), d);
  ASSERT_TRUE(d.base_contact);
  EXPECT_EQ(d.base_contact->chosen, "rate_state_contact");
  EXPECT_NE(d.base_contact->left_model.find("rate_state left the model"), std::string::npos) << d.base_contact->left_model;
  EXPECT_FALSE(d.final_fit.params.structure.has(Effect::kRateState));
  ASSERT_EQ(d.accepted.size(), 1u) << accepted_names(d);
  EXPECT_EQ(d.accepted[0].effect, Effect::kTiltOffset);
  EXPECT_NEAR(d.final_fit.params.value("tilt_tan"), -0.0262, 0.002);
  EXPECT_LT(d.after.heldout.rms, 5e-6);
  const std::string json = diagnosis_json(s, d, {});
  EXPECT_NE(json.find("\"left_model\""), std::string::npos);
}

TEST(DiagnosisSim, AContactLawTheTiltTakesPastItsBoundLeavesTheModel) { expect_the_law_to_leave_with_the_tilt(1); }

TEST(DiagnosisSim, AContactLawTheTiltTakesPastItsBoundLeavesTheModelSeed2) { expect_the_law_to_leave_with_the_tilt(2); }

// Also when the candidates are fitted one at a time instead of at once.
TEST(DiagnosisSim, TheSameSeedGivesTheSameDiagnosis) {
  const std::vector<Effect> two = {Effect::kTiltOffset, Effect::kDirectionAsymmetry};
  DiagnosisOptions serial = options_for_runs(two);
  serial.threads = 1;
  DiagnosisOptions parallel = options_for_runs(two);
  parallel.threads = 2;
  const Diagnosis a = diagnose_run("tilt, seed 3", tilt_offset(), 3, parallel);
  const Diagnosis b = diagnose_run("tilt, seed 3 again, serial", tilt_offset(), 3, serial);
  ASSERT_EQ(a.accepted.size(), b.accepted.size());
  ASSERT_EQ(a.model_after.size(), b.model_after.size());
  for (std::size_t i = 0; i < a.model_after.size(); ++i) ASSERT_EQ(a.model_after[i], b.model_after[i]) << i;
}

}  // namespace
}  // namespace tribo::analysis
