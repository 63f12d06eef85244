// The diagnosis on measured data (small copies in tests/data/measured/, with
// attribution there): EMPS, the banded rotary friction damper with backlash,
// and a rate-and-state velocity step.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "tests/analysis/analysis_test_support.h"

namespace tribo::analysis {
namespace {

using testing::accepted;
using testing::accepted_names;
using testing::measured_data;

MeasuredSeries emps() {
  ColumnMapping c;
  c.time = "t_s";
  c.position = "x_m";
  c.force = "force_motor_N";
  c.velocity = "v_derived_m_s";
  c.acceleration = "a_derived_m_s2";
  MeasuredSeries s = testing::read_or_throw(measured_data("emps_train_DATA_EMPS.csv"), c);
  derive_motion(s, 0);
  return s;
}

double relative_error(const Eigen::MatrixXd& A, const Eigen::VectorXd& y, Eigen::VectorXd& p) {
  p = A.colPivHouseholderQr().solve(y);
  return (y - A * p).norm() / y.norm();
}

// The published inverse-model least squares (data README): our reproduction
// of the parameters, and the relative error ||tau - tau_hat|| / ||tau|| as we
// compute it on the raw training data (the published 4.08 % / 3.11 % used a
// filtering we do not know; the parameters agree).
TEST(MeasuredEmps, ReproducesThePublishedInverseModelParameters) {
  const MeasuredSeries s = emps();
  const auto n = static_cast<Eigen::Index>(s.size());
  Eigen::MatrixXd A(n, 4), B(n, 6);
  Eigen::VectorXd y(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double v = s.velocity_m_per_s[static_cast<std::size_t>(i)], a = s.acceleration_m_per_s2[static_cast<std::size_t>(i)];
    A.row(i) << a, v, v > 0 ? 1.0 : -1.0, 1.0;
    B.row(i) << a, std::max(v, 0.0), std::min(v, 0.0), v > 0 ? 1.0 : 0.0, v < 0 ? -1.0 : 0.0, 1.0;
    y[i] = s.force_n[static_cast<std::size_t>(i)];
  }
  Eigen::VectorXd p, q;
  const double symmetric = relative_error(A, y, p), asymmetric = relative_error(B, y, q);
  EXPECT_NEAR(p[0], 95.11, 0.5);   // M
  EXPECT_NEAR(p[1], 203.5, 2.0);   // Fv
  EXPECT_NEAR(p[2], 20.39, 0.2);   // Fc
  EXPECT_NEAR(p[3], -3.16, 0.05);  // offset
  EXPECT_NEAR(q[1], 166.7, 2.0);   // Fv+
  EXPECT_NEAR(q[2], 240.4, 2.0);   // Fv-
  EXPECT_NEAR(symmetric, 0.0461, 0.0005);
  EXPECT_NEAR(asymmetric, 0.0379, 0.0005);
}

TEST(MeasuredEmps, DiagnosisFindsTheDirectionAsymmetry) {
  DiagnosisOptions options;
  options.base.fit_mass = true;
  const Diagnosis d = diagnose(emps(), options);
  ASSERT_FALSE(d.accepted.empty());
  EXPECT_EQ(d.accepted.front().effect, Effect::kDirectionAsymmetry) << accepted_names(d);
  // Fv+ < Fv- as published (166.7 against 240.4 N s/m).
  double asym_viscous = 0;
  for (const auto& p : d.accepted.front().parameters) {
    if (p.name == "asym_viscous") asym_viscous = p.value;
  }
  EXPECT_LT(asym_viscous, -0.1);
  EXPECT_LT(d.accepted.front().trial.heldout_rms_after, 0.85 * d.accepted.front().trial.heldout_rms_before);
  EXPECT_LT(d.after.all.relative, 0.036);
  EXPECT_GT(d.before.all.relative, 0.040);
  double mass = 0;
  for (const auto& p : d.final_fit.estimates) {
    if (p.name == "mass") mass = p.value;
  }
  EXPECT_NEAR(mass, 95.1, 1.0);
}

TEST(MeasuredBackslashDamper, DiagnosisFindsTheDeadZoneAfterReversals) {
  ColumnMapping c;
  c.time = "t_s";
  c.position = "x_m";
  c.force = "force_friction_N";
  c.velocity = "v_from_x_m_s";
  MeasuredSeries s = testing::read_or_throw(measured_data("brfd_0.5Hz30lbtension1amplitude.csv"), c);
  derive_motion(s, 0);
  // As the contract command diagnoses a CSV (tribo-fit diagnose): each pass's
  // start chosen on held-out passes. With the holds modelled alone the final
  // model's static level falls below a fifth of the Coulomb level with a
  // viscous coefficient of -1.75e4 N s/m: a model that does not describe the
  // record, which names no effect.
  DiagnosisOptions options;
  options.choose_state_from_rest = true;
  const Diagnosis d = diagnose(s, options);
  EXPECT_TRUE(d.adequacy.describes_record) << accepted_names(d);
  ASSERT_TRUE(accepted(d, Effect::kBacklash)) << accepted_names(d);
  EXPECT_EQ(d.accepted.front().effect, Effect::kBacklash);
  for (const auto& p : d.accepted.front().parameters) {
    if (p.name == "backlash_gap") {
      EXPECT_GT(p.value, 1e-3);  // a few millimetres (data README)
      EXPECT_LT(p.value, 8e-3);
    }
  }
  EXPECT_LT(d.after.heldout.rms, 0.85 * d.before.heldout.rms);
  // What the dead zone does not explain is described, not labelled.
  EXPECT_TRUE(d.unexplained);
}

// A velocity-step record of tests/data/measured: shear stress against the
// effective normal stress, in Pa.
MeasuredSeries velocity_step_record(const std::string& file) {
  ColumnMapping c;
  c.time = "t_s";
  c.position = "x_m";
  c.force = "shear_stress_Pa";
  c.normal = "normal_stress_eff_Pa";
  c.force_unit = "Pa";
  return testing::read_or_throw(measured_data(file), c);
}

TEST(MeasuredRateAndState, VelocityStepLeavesStructureNoCandidateExplains) {
  MeasuredSeries s = velocity_step_record("velstep7_BRAVA_expb819_basalt_Giacomel_et_al_2021.csv");
  derive_motion(s, 1.0);
  DiagnosisOptions options;
  options.base.load_scaled = true;
  const Diagnosis d = diagnose(s, options);
  // One velocity step, one direction: most candidates are not applicable, and
  // none is accepted; the transient after the step is reported as unexplained.
  EXPECT_TRUE(d.accepted.empty()) << accepted_names(d);
  ASSERT_TRUE(d.unexplained);
  EXPECT_LT(d.before.all.relative, 0.01);
  bool offset_warning = false;
  for (const auto& w : d.base.result.warnings) offset_warning |= w.find("one direction only") != std::string::npos;
  EXPECT_TRUE(offset_warning);
  // ... and the report says where the transient is fitted.
  bool choose_hint = false;
  for (const auto& w : d.warnings) choose_hint |= w.find("--base-model choose") != std::string::npos;
  EXPECT_TRUE(choose_hint);
}

// As tribo-fit diagnose on a CSV with --base-model choose.
Diagnosis diagnose_with_contact_chosen(const MeasuredSeries& s) {
  DiagnosisOptions options;
  options.base.load_scaled = true;
  options.choose_base_contact = true;
  options.choose_state_from_rest = true;
  return diagnose(s, options);
}

// Sepiolite velstep3 (0.2 -> 2 um/s) with the contact chosen: a
// rate-and-state law is kept once the level may trend with the distance slid
// (without that trend its evolution comes out opposite to the direct effect
// and it is refused), and no effect accepted after it may leave the law past its
// bounds (drift's refit had taken the direct effect to a = -0.049).
TEST(MeasuredRateAndState, TheSepioliteStepKeepsARateAndStateContactWithinItsBounds) {
  MeasuredSeries s = velocity_step_record("velstep3_TR2_exp013_sepiolite.csv");
  derive_motion_smoothed(s);
  const Diagnosis d = diagnose_with_contact_chosen(s);
  ASSERT_TRUE(d.base_contact);
  EXPECT_NE(d.base_contact->chosen.find("rate_state"), std::string::npos) << d.base_contact->chosen;
  EXPECT_NE(d.base_contact->chosen.find("slip_trend"), std::string::npos) << d.base_contact->chosen;
  EXPECT_LT(d.after.heldout.rms, 0.9 * d.before.heldout.rms);
  const ModelParams& p = d.final_fit.params;
  ASSERT_GE(p.index("rs_a"), 0);
  EXPECT_GT(p.value("rs_a"), 0.0);
  EXPECT_GT(p.value("rs_b"), -p.value("rs_a"));
}

// The final model's rate-and-state law: a and b within the 0.005-0.02 of
// laboratory gouges (Marone 1998), each more than three errors from zero,
// and D_c within (dc_min_m, dc_max_m).
void expect_rate_and_state_of_laboratory_gouge(const Diagnosis& d, double dc_min_m, double dc_max_m) {
  int seen = 0;
  for (const auto& e : d.final_fit.estimates) {
    if (e.name == "rs_a" || e.name == "rs_b") {
      ++seen;
      EXPECT_GT(e.value, 0.005) << e.name;
      EXPECT_LT(e.value, 0.02) << e.name;
      EXPECT_GT(e.value, 3 * e.std_error) << e.name;
    }
    if (e.name == "rs_dc") {
      ++seen;
      EXPECT_GT(e.value, dc_min_m);
      EXPECT_LT(e.value, dc_max_m);
    }
  }
  EXPECT_EQ(seen, 3);
}

// Sepiolite velstep1 (0.2 -> 2 um/s, after 1.5 mm of slip) with the contact
// chosen: the friction jumps at the step, peaks and falls over hundreds of
// um while the layer weakens with slip. The rate-and-state contact with a
// slip trend is kept over a LuGre past its bounds, with a and b within the
// literature's 0.005-0.02 (Marone 1998), each determined, and D_c of
// hundreds of um, as clay-rich gouges evolve (Giacomel et al. 2024). Fitted
// only from a contact stiffer than the record resolves, where its stiffness
// has no gradient, the contact with the trend came out at b = 0.039 over
// D_c = 2.5 mm (more than the record's slip), and the plain contact was kept
// with b = 0.024 over 0.41 mm, 2.4 % better than LuGre on the held-out
// chunks.
TEST(MeasuredRateAndState, TheSepioliteStepWeakeningWithSlipKeepsTheRateAndStateContact) {
  MeasuredSeries s = velocity_step_record("velstep1_TR2_exp013_sepiolite.csv");
  derive_motion_smoothed(s);
  const Diagnosis d = diagnose_with_contact_chosen(s);
  ASSERT_TRUE(d.base_contact);
  EXPECT_EQ(d.base_contact->chosen, "rate_state_contact+slip_trend");
  expect_rate_and_state_of_laboratory_gouge(d, 100e-6, 1e-3);
  const ModelParams& p = d.final_fit.params;
  ASSERT_GE(p.index("slip_trend"), 0);
  EXPECT_LT(p.value("slip_trend"), 0.0);
  EXPECT_LT(d.after.heldout.rms, 0.85 * d.before.heldout.rms);
}

// The same step with the contract command's base (LuGre, no contact choice):
// the fit runs past LuGre's bounds (a static level several times the
// Coulomb level), and the report says the model does not describe the
// record, in its warnings as well as in the adequacy, and names no effect.
TEST(MeasuredRateAndState, OnLugreTheSepioliteStepIsSaidNotToBeDescribed) {
  MeasuredSeries s = velocity_step_record("velstep1_TR2_exp013_sepiolite.csv");
  derive_motion_smoothed(s);
  DiagnosisOptions options;
  options.choose_state_from_rest = true;
  const Diagnosis d = diagnose(s, options);
  EXPECT_FALSE(d.adequacy.describes_record);
  EXPECT_TRUE(d.accepted.empty()) << accepted_names(d);
  bool said = false;
  for (const auto& w : d.warnings) said |= w.find("the model does not describe the record") != std::string::npos;
  EXPECT_TRUE(said);
}

// Basalt velstep4 (3 -> 10 um/s) with the speed steps as velocity jumps and
// the contact chosen: of the jumps the likelihood-ratio test finds, the
// force follows only the step (the position record's surges 4-6 s later,
// 10 -> 14 -> 10 um/s, leave the friction where it was), and the
// rate-and-state contact with a slip trend is kept with a and b within the
// literature's 0.005-0.02 (Marone 1998; basalt near a - b = 0, Giacomel et
// al. 2021), each determined, and D_c within 1-100 um.
TEST(MeasuredRateAndState, TheBasaltStepWithVelocityJumpsKeepsTheRateAndStateContact) {
  MeasuredSeries s = velocity_step_record("velstep4_BRAVA_expb819_basalt_Giacomel_et_al_2021.csv");
  derive_motion_smoothed(s, false, true);
  EXPECT_EQ(s.velocity_jumps, 1);
  EXPECT_GE(s.velocity_jumps_force_did_not_follow, 1);
  const Diagnosis d = diagnose_with_contact_chosen(s);
  ASSERT_TRUE(d.base_contact);
  EXPECT_EQ(d.base_contact->chosen, "rate_state_contact+slip_trend");
  expect_rate_and_state_of_laboratory_gouge(d, 1e-6, 100e-6);
  EXPECT_LT(d.after.heldout.rms, 0.9 * d.before.heldout.rms);
}

}  // namespace
}  // namespace tribo::analysis
