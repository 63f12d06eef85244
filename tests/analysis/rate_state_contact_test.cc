// The rate-and-state contact as a base-model choice ("Base-model
// choice" and "rate_state in the vocabulary") on velocity steps made here,
// not by tribo's simulator nor by the analysis model: a rigid contact whose
// friction follows Dieterich's law, integrated in closed form, sampled and
// disturbed at the floors of the shipped basalt record (10 Hz, 0.14 um of
// position noise, 4e-4 in friction coefficient; docs/identification.md),
// the motion estimated with velocity jumps, as for a drive that steps its
// speed.
#include <cmath>
#include <functional>
#include <iostream>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "analysis/diagnosis.h"
#include "analysis/input/measured_series.h"

namespace tribo::analysis {
namespace {

struct RateStateTruth {
  double mu0 = 0.6, a = 0.010, b = 0.008, dc_m = 20e-6, v_ref_m_per_s = 1e-6;
  double trend_per_m = 0;  // friction coefficient gained per metre slid (a gouge's slip hardening)
};

// A one-way record at speed_at(t) for duration_s: theta of the ageing law
// (d theta/dt = 1 - V theta/Dc) solved exactly over each constant-speed
// sample interval, from steady state at the first speed.
MeasuredSeries speed_record(const RateStateTruth& p, const std::function<double(double)>& speed_at, double duration_s,
                            unsigned seed) {
  const double rate_hz = 10, normal_pa = 20e6;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> position_noise(0.0, 0.14e-6), mu_noise(0.0, 4e-4);
  MeasuredSeries s;
  double theta = p.dc_m / speed_at(0), x = 0;
  const double dt = 1 / rate_hz;
  for (int i = 0; i * dt <= duration_s; ++i) {
    const double v = speed_at(i * dt);
    if (i > 0) {
      const double steady = p.dc_m / v;
      theta = steady + (theta - steady) * std::exp(-v * dt / p.dc_m);
      x += v * dt;
    }
    const double mu = p.mu0 + p.a * std::log(v / p.v_ref_m_per_s) + p.b * std::log(p.v_ref_m_per_s * theta / p.dc_m) +
                      p.trend_per_m * x;
    s.time_s.push_back(i * dt);
    s.position_m.push_back(x + position_noise(rng));
    s.normal_force_n.push_back(normal_pa);
    s.force_n.push_back((mu + mu_noise(rng)) * normal_pa);
  }
  derive_motion_smoothed(s, false, true);  // a drive that steps its speed: velocity jumps
  return s;
}

// Speeds v1 and v2 in turn, 60 s each, five segments.
MeasuredSeries velocity_steps(const RateStateTruth& p, double v1, double v2, unsigned seed) {
  const double segment_s = 60;
  return speed_record(p, [=](double t) { return static_cast<int>(t / segment_s) % 2 == 0 ? v1 : v2; }, 5 * segment_s, seed);
}

// The steps 3 <-> 10 um/s diagnosed with the contact chosen (options: the
// rest of the diagnosis's options, filled in here).
Diagnosis diagnose_steps(const RateStateTruth& truth, unsigned seed, DiagnosisOptions& options) {
  options.base.load_scaled = true;
  options.choose_base_contact = true;
  return diagnose(velocity_steps(truth, 3e-6, 10e-6, seed), options);
}

double value_of(const std::vector<ParamEstimate>& estimates, const std::string& name) {
  for (const auto& p : estimates) {
    if (p.name == name) return p.value;
  }
  return std::nan("");
}

// Steps up and down (3 <-> 10 um/s, about the basalt record's), so that
// fitted and held-out chunks both hold steps: the rate-and-state contact is
// kept over plain LuGre and over LuGre with a rate-and-state term, and its fit
// (in place of the Stribeck curve) finds a, b and Dc. With the steps
// smoothed over, LuGre with the term was kept on seeds 3 and 41 (4 % lower
// held-out RMS), its Stribeck curve and damping taking up the motion estimate's error at steps
// the smoother rounded off; with the steps found as velocity jumps
// (--motion-estimator rts_jumps), and contacts with fewer parameters tried
// first, the two predict alike, and the simpler is kept
// (docs/identification.md).
TEST(RateStateContact, SpeedStepsKeepARateAndStateContactAndFindItsParameters) {
  const RateStateTruth truth;
  for (unsigned seed : {3u, 17u, 41u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    DiagnosisOptions options;
    const Diagnosis d = diagnose_steps(truth, seed, options);
    ASSERT_TRUE(d.base_contact);
    const BaseContactChoice::Option* contact = nullptr;
    for (const auto& o : d.base_contact->options) {
      std::cout << "    contact " << o.name << ": held-out RMS " << o.heldout_rms << " " << o.note << "\n";
      if (o.name == "rate_state_contact") contact = &o;
    }
    EXPECT_EQ(d.base_contact->chosen, "rate_state_contact");
    EXPECT_LT(d.after.heldout.rms, (1 - options.min_heldout_gain) * d.before.heldout.rms);
    ASSERT_NE(contact, nullptr);
    EXPECT_TRUE(contact->note.empty()) << contact->note;
    const double a = value_of(contact->parameters, "rs_a"), b = value_of(contact->parameters, "rs_b");
    const double dc = value_of(contact->parameters, "rs_dc");
    std::cout << "[rate-state contact] seed " << seed << ": a " << a << " b " << b << " Dc " << dc << " m, kept "
              << d.base_contact->chosen << "\n";
    // Found within 1.4 % (a), 2.8 % (b) and 1.5 % (Dc) on the three seeds;
    // within 4.5, 5.6 and 5.5 % with the steps smoothed over.
    EXPECT_NEAR(a, truth.a, 0.03 * truth.a);
    EXPECT_NEAR(b, truth.b, 0.05 * truth.b);
    EXPECT_GT(dc, truth.dc_m / 1.05);
    EXPECT_LT(dc, truth.dc_m * 1.05);
  }
}

// A friction level that rises with the distance slid (10 per metre: +0.02 in
// mu over the record's 2 mm, beside a direct effect of a ln(10/3) = 0.012),
// which velocity-step analyses remove before reading a and b (Marone 1998):
// the contact kept carries the trend, and the trend, a, b and Dc are found.
TEST(RateStateContact, ATrendInTheDistanceSlidIsKeptApartFromTheEvolution) {
  RateStateTruth truth;
  truth.trend_per_m = 10;
  for (unsigned seed : {3u, 17u, 41u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    DiagnosisOptions options;
    const Diagnosis d = diagnose_steps(truth, seed, options);
    ASSERT_TRUE(d.base_contact);
    const BaseContactChoice::Option *with_trend = nullptr, *without = nullptr;
    for (const auto& o : d.base_contact->options) {
      if (o.name == "rate_state_contact+slip_trend") with_trend = &o;
      if (o.name == "rate_state_contact") without = &o;
    }
    ASSERT_NE(with_trend, nullptr);
    ASSERT_NE(without, nullptr);
    std::cout << "[slip trend] seed " << seed << ": kept " << d.base_contact->chosen << "; without the trend a "
              << value_of(without->parameters, "rs_a") << " b " << value_of(without->parameters, "rs_b") << " Dc "
              << value_of(without->parameters, "rs_dc") << " held-out " << without->heldout_rms << "; with it a "
              << value_of(with_trend->parameters, "rs_a") << " b " << value_of(with_trend->parameters, "rs_b") << " Dc "
              << value_of(with_trend->parameters, "rs_dc") << " trend " << value_of(with_trend->parameters, "slip_trend")
              << " /m held-out " << with_trend->heldout_rms << "; without it " << without->heldout_excess_se
              << " standard errors above the kept\n";
    // The evidence beside each option: its held-out error above the kept
    // one's in standard errors over the four held-out time chunks. Three
    // times the RMS is 2.8-3.0 of them (seeds 3, 17, 41): four chunks are
    // little to judge by, and the report says so in numbers.
    EXPECT_GT(without->heldout_excess_se, 2.0);
    for (const auto& o : d.base_contact->options) {
      if (o.name == d.base_contact->chosen) {
        EXPECT_EQ(o.heldout_excess_se, 0.0);
      }
      if (o.heldout_rms > 1.01 * with_trend->heldout_rms) {
        EXPECT_GT(o.heldout_excess_se, 0.0) << o.name;
      }
    }
    EXPECT_NE(d.base_contact->chosen.find("slip_trend"), std::string::npos);
    EXPECT_NE(d.base_contact->chosen.find("rate_state"), std::string::npos);
    EXPECT_TRUE(with_trend->note.empty()) << with_trend->note;
    EXPECT_LT(with_trend->heldout_rms, (1 - options.min_heldout_gain) * without->heldout_rms);
    EXPECT_NEAR(value_of(with_trend->parameters, "slip_trend"), truth.trend_per_m, 0.2 * truth.trend_per_m);
    EXPECT_NEAR(value_of(with_trend->parameters, "rs_a"), truth.a, 0.2 * truth.a);
    EXPECT_NEAR(value_of(with_trend->parameters, "rs_b"), truth.b, 0.2 * truth.b);
    EXPECT_GT(value_of(with_trend->parameters, "rs_dc"), truth.dc_m / 1.5);
    EXPECT_LT(value_of(with_trend->parameters, "rs_dc"), truth.dc_m * 1.5);
  }
}

// A trend that moves the level by more than half of it over the record
// (300 per metre: +0.6 in mu over 2 mm, on mu0 = 0.6) is no trend on a
// contact: each contact with it is past its bound, and none is kept.
TEST(RateStateContact, ATrendOfHalfTheLevelIsPastItsBound) {
  RateStateTruth truth;
  truth.trend_per_m = 300;
  DiagnosisOptions options;
  const Diagnosis d = diagnose_steps(truth, 3, options);
  ASSERT_TRUE(d.base_contact);
  int with_trend = 0;
  for (const auto& o : d.base_contact->options) {
    if (o.name.find("slip_trend") == std::string::npos) continue;
    ++with_trend;
    EXPECT_NE(o.note.find("slip_trend moves the friction level"), std::string::npos) << o.name << ": " << o.note;
  }
  EXPECT_GE(with_trend, 2);
  EXPECT_EQ(d.base_contact->chosen.find("slip_trend"), std::string::npos) << d.base_contact->chosen;
}

// A record that is already sliding when it begins and steps from 10 to
// 3 um/s 14 s into its 600 s, near the end of the first of the forty chunks
// the step search compares (sepiolite velstep2 steps 235 s into 10 200 s, its
// first chunk ending at 255 s). The search skipped the first two chunks as a
// pass's onset, so it never compared the first with the second, and the
// rate-and-state contact was not tried there.
TEST(RateStateContact, AStepEarlyInARecordThatOpensSlidingIsSeen) {
  const RateStateTruth truth;
  DiagnosisOptions options;
  options.base.load_scaled = true;
  options.choose_base_contact = true;
  const Diagnosis d = diagnose(speed_record(truth, [](double t) { return t < 14 ? 10e-6 : 3e-6; }, 600, 3), options);
  ASSERT_TRUE(d.base_contact);
  bool contact_tried = false;
  for (const auto& o : d.base_contact->options) contact_tried |= o.name == "rate_state_contact";
  EXPECT_TRUE(contact_tried) << d.base_contact->not_tried;
}

}  // namespace
}  // namespace tribo::analysis
