// Drift as a creep under a stuck contact (analysis/effects/creep_in_holds.h) on the
// simulated instrument's default config (config/tribod.textproto: the
// elasto-plastic contact holds its force at rest) with the protocol of holds
// of minutes (config/protocols/creep_holds.textproto), diagnosed as
// tribo-fit diagnoses a run directory. The sample creep (sim.sample.drift)
// is the sim's; the position sensor's zero drift (0.03 nm/s by default),
// which the position loop follows and which is a creep of the same kind, is
// off unless a test says otherwise.
#include <cmath>
#include <iostream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "analysis/diagnosis.h"
#include "analysis/report/diagnosis_report.h"
#include "analysis/fit_commands.h"
#include "tests/analysis/sim_identification_run.h"

namespace tribo::analysis {
namespace {

using testing::ConfigEdit;

ConfigEdit sample_creep(double speed_m_per_s) {
  return [=](v1::DaemonConfig& c) {
    c.mutable_sim()->mutable_lateral()->mutable_sensing()->set_drift_m_per_s(0);
    auto& drift = *c.mutable_sim()->mutable_sample()->mutable_drift();
    drift.set_enabled(speed_m_per_s != 0);
    drift.set_rate_m_per_s(speed_m_per_s);
    drift.set_velocity_rms_m_per_s(0);
  };
}

MeasuredSeries creep_record(const std::string& config_file, const ConfigEdit& edit, std::uint64_t seed = 1) {
  return testing::simulated_record(testing::shipped_config(config_file, edit), "creep_holds.textproto", seed);
}

Diagnosis diagnosed(const MeasuredSeries& s, const std::string& label) {
  DiagnoseRequest request;
  request.tribo_run = true;
  DiagnoseOutcome outcome = diagnose_series(s, request);
  if (!outcome.error.empty()) throw std::runtime_error(outcome.error);
  std::cout << "--- " << label << "\n" << diagnosis_text(s, outcome.diagnosis);
  return std::move(outcome.diagnosis);
}

bool drift_accepted(const Diagnosis& d) {
  for (const auto& a : d.accepted) {
    if (a.effect == Effect::kDrift) return true;
  }
  return false;
}

// 0.3 nm/s of sample creep, 8 holds of 150 s at 3000 and 7000 uN: the held
// force falls at sigma0 x 0.3 nm/s ~ 1 uN/s in every hold, whatever its sign.
// The stiffness comes from the holds' settling (the config's sigma0 is
// 1400 uN / 0.41 um = 3415 N/m; the pass model fits 4261), the speed from
// it: 0.290 +- 0.012, 0.281 +- 0.010, 0.296 +- 0.013 nm/s on seeds 1-3.
TEST(CreepInHolds, ASampleCreepIsFoundAsACreepUnderTheStuckContact) {
  const Diagnosis d = diagnosed(creep_record("/config/tribod.textproto", sample_creep(0.3e-9)), "creep 0.3 nm/s");
  ASSERT_TRUE(d.creep);
  EXPECT_EQ(d.creep->holds.size(), 8u);
  EXPECT_EQ(d.creep->form, HoldDriftForm::kCreep) << d.creep->verdict;
  EXPECT_TRUE(drift_accepted(d));
  EXPECT_NEAR(d.creep->stiffness_per_m, 3415, 340);
  EXPECT_NEAR(d.creep->creep_speed_m_per_s, 0.3e-9, 0.03e-9);
  EXPECT_LT(std::fabs(d.creep->creep_speed_m_per_s - 0.3e-9), 3 * d.creep->creep_speed_std_error);
  EXPECT_NEAR(d.creep->reading_share, 0.0, 0.2);
}

// At 1 nm/s the creep loads the contact past what it holds within a hold
// (150 nm x 3415 N/m = 512 uN against about 300 uN at 3000 uN): there the
// held force levels off and the contact slips. The speed comes from the holds
// that stay elastic (0.958 +- 0.062 nm/s on seed 1; the mean over every hold
// gave 0.63).
TEST(CreepInHolds, HoldsThatLevelOffAreLeftOutOfTheSpeed) {
  const Diagnosis d = diagnosed(creep_record("/config/tribod.textproto", sample_creep(1e-9)), "creep 1 nm/s");
  ASSERT_TRUE(d.creep);
  EXPECT_EQ(d.creep->form, HoldDriftForm::kCreep) << d.creep->verdict;
  EXPECT_GT(d.creep->levelling_holds, 0);
  EXPECT_LT(d.creep->speed_holds, static_cast<int>(d.creep->holds.size()));
  EXPECT_NEAR(d.creep->creep_speed_m_per_s, 1e-9, 0.15e-9);
}

TEST(CreepInHolds, WithoutCreepNoneIsFound) {
  const Diagnosis d = diagnosed(creep_record("/config/tribod.textproto", sample_creep(0)), "no creep");
  ASSERT_TRUE(d.creep);
  EXPECT_FALSE(d.creep->accepted) << d.creep->verdict;
  EXPECT_FALSE(drift_accepted(d));
}

// A drift of the force reading (0.3 uN/s added to the record) slopes the
// holds as a creep would, but it also shifts every later pass: drift, in
// that form, not a creep.
TEST(CreepInHolds, ADriftOfTheForceReadingIsNamedOneNotACreep) {
  MeasuredSeries s = creep_record("/config/tribod.textproto", sample_creep(0));
  for (std::size_t i = 0; i < s.size(); ++i) s.force_n[i] += 0.3e-6 * s.time_s[i];
  const Diagnosis d = diagnosed(s, "reading drift 0.3 uN/s");
  ASSERT_TRUE(d.creep);
  EXPECT_EQ(d.creep->form, HoldDriftForm::kReading) << d.creep->verdict;
  EXPECT_NEAR(d.creep->reading_share, 1.0, 0.2);
  EXPECT_NEAR(d.creep->creep_rate_per_s, 0.3e-6, 0.05e-6);
  EXPECT_TRUE(drift_accepted(d));
}

// A creep and a drift of the reading together (0.3 nm/s and +0.3 uN/s): the
// holds slope by the creep's -1 uN/s plus the reading's +0.3, the passes by
// the reading's alone, so they carry a share of -0.5 of the holds' change.
// Both are named, each from its own part.
TEST(CreepInHolds, ACreepAndADriftOfTheReadingTogetherAreBothNamed) {
  MeasuredSeries s = creep_record("/config/tribod.textproto", sample_creep(0.3e-9));
  for (std::size_t i = 0; i < s.size(); ++i) s.force_n[i] += 0.3e-6 * s.time_s[i];
  const Diagnosis d = diagnosed(s, "creep 0.3 nm/s and reading drift 0.3 uN/s");
  ASSERT_TRUE(d.creep);
  EXPECT_EQ(d.creep->form, HoldDriftForm::kCreepAndReading) << d.creep->verdict;
  EXPECT_TRUE(drift_accepted(d));
  EXPECT_NEAR(d.creep->reading_rate_per_s, 0.3e-6, 0.05e-6);
  EXPECT_NEAR(d.creep->creep_speed_m_per_s, 0.3e-9, 0.045e-9);
}

// Plain LuGre (config/instruments/lugre_plain.textproto) does not hold a
// force at rest: under the position wander the held force relaxes, hold by
// hold, at up to 0.9 uN/s with alternating signs. No creep.
TEST(CreepInHolds, AContactThatDrainsItsHeldForceIsNotCalledACreep) {
  const Diagnosis d = diagnosed(creep_record("/config/instruments/lugre_plain.textproto", {}), "plain LuGre");
  ASSERT_TRUE(d.creep);
  EXPECT_FALSE(d.creep->accepted) << d.creep->verdict;
  EXPECT_FALSE(drift_accepted(d));
}

// The identification protocol's holds (0.25-8 s) are too short to assess.
TEST(CreepInHolds, ShortHoldsAssessNothing) {
  MeasuredSeries s;
  MotionSegmentation m;
  for (int i = 0; i < 1000; ++i) {
    s.time_s.push_back(0.01 * i);
    s.force_n.push_back(0);
  }
  m.holds = {Hold{0, 400}, Hold{500, 999}};
  const CreepInHolds c = creep_in_holds(s, m, 3000.0, 100.0);
  EXPECT_TRUE(c.holds.empty());
  EXPECT_FALSE(c.accepted);
}

}  // namespace
}  // namespace tribo::analysis
