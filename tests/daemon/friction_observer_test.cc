// The friction compensation's parts: the identified model read from a
// tribo-fit report (daemon/friction_report.h) and the observer that
// evaluates it on line (daemon/friction_observer.h).
#include "daemon/friction_observer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <variant>

#include <nlohmann/json.hpp>

#include "daemon/friction_report.h"
#include "proto/text_format_file.h"

namespace tribo::daemon {
namespace {

using Json = nlohmann::ordered_json;

// A report of `tribo-fit diagnose --base-model choose --json` on the
// identification protocol run on the default instrument
// (tests/data/friction_reports/README.md).
std::string identification_report() {
  auto text = wire::read_file(std::string(TRIBO_SOURCE_DIR) + "/tests/data/friction_reports/identification.json");
  if (!text) throw std::runtime_error("fixture missing");
  return *text;
}

double value_of(const Json& report, const std::string& name) {
  for (const Json& p : report.at("final_model").at("parameters")) {
    if (p.at("name") == name) return p.at("value").get<double>();
  }
  throw std::runtime_error("no parameter " + name);
}

std::string error_of(const std::string& text) {
  const auto r = read_friction_report(text);
  return std::holds_alternative<std::string>(r) ? std::get<std::string>(r) : std::string("accepted");
}

// The report with an effect added to its final model and parameters.
std::string with_effect(const std::string& text, const std::string& effect, const Json& parameters) {
  Json j = Json::parse(text);
  j["final_model"]["effects"].push_back(effect);
  for (const auto& [name, value] : parameters.items()) {
    j["final_model"]["parameters"].push_back({{"name", name}, {"value", value}, {"unit", "1"}});
  }
  return j.dump();
}

TEST(FrictionReport, LoadsTheIdentifiedModelAsTheReportGivesIt) {
  const std::string text = identification_report();
  const auto read = read_friction_report(text);
  ASSERT_TRUE(std::holds_alternative<FrictionReport>(read)) << std::get<std::string>(read);
  const FrictionReport& r = std::get<FrictionReport>(read);
  const Json j = Json::parse(text);
  EXPECT_EQ(r.model.load_scaled, j["base_model"]["load_scaled"].get<bool>());
  EXPECT_EQ(r.model.coulomb, value_of(j, "mu_c"));
  EXPECT_EQ(r.model.static_level, value_of(j, "mu_s"));
  EXPECT_EQ(r.model.stribeck_velocity_m_per_s, value_of(j, "vs"));
  EXPECT_EQ(r.model.sigma0_n_per_m, value_of(j, "sigma0"));
  EXPECT_EQ(r.model.sigma1_n_s_per_m, value_of(j, "sigma1"));
  EXPECT_EQ(r.model.viscous_n_s_per_m, value_of(j, "Fv"));
  EXPECT_EQ(r.model.tilt_tan, value_of(j, "tilt_tan"));
  EXPECT_EQ(r.contact, "lugre + tilt_offset");
  ASSERT_EQ(r.parameters.size(), j["final_model"]["parameters"].size());
  EXPECT_EQ(r.parameters[3].name, "sigma0");
  EXPECT_EQ(r.parameters[3].unit, "N/m");
  // `sha256sum tests/data/friction_reports/identification.json`
  EXPECT_EQ(r.sha256, "8e97474e04076d74d1d9601fbd005e21276ec9f28ec6427ff41f64d99bba46bf");
}

TEST(FrictionReport, Sha256OfAKnownAnswer) {
  // FIPS 180-2, appendix B.1.
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(FrictionReport, ReadsTheExtensionsItEvaluates) {
  std::string text = with_effect(identification_report(), "presliding_hysteresis", {{"breakaway_ratio", 0.9}});
  text = with_effect(text, "dwell_stiction", {{"dwell_dFs", 0.01}, {"dwell_time", 200.0}, {"dwell_memory", 1e-5}});
  text = with_effect(text, "direction_asymmetry", {{"asym_levels", 0.05}, {"asym_viscous", 0.1}});
  const auto read = read_friction_report(text);
  ASSERT_TRUE(std::holds_alternative<FrictionReport>(read)) << std::get<std::string>(read);
  const IdentifiedFriction& m = std::get<FrictionReport>(read).model;
  EXPECT_TRUE(m.elasto_plastic);
  EXPECT_EQ(m.breakaway_ratio, 0.9);
  EXPECT_TRUE(m.dwell);
  EXPECT_EQ(m.dwell_time_s, 200.0);
  EXPECT_TRUE(m.direction_asymmetry);
  EXPECT_EQ(m.asymmetry_levels, 0.05);
}

TEST(FrictionReport, RefusesWhatTheCompensationCannotRepresentNamingIt) {
  const std::string text = identification_report();
  EXPECT_NE(error_of(with_effect(text, "backlash", {{"backlash_gap", 1e-8}})).find("final_model.effects has backlash"),
            std::string::npos);
  EXPECT_NE(error_of(with_effect(text, "frictional_lag", {{"lag_time", 1e-3}})).find("does not delay the velocity"),
            std::string::npos);
  Json j = Json::parse(text);
  j["input"]["force_unit"] = "Pa";
  EXPECT_NE(error_of(j.dump()).find("input.force_unit is Pa"), std::string::npos);
  j = Json::parse(text);
  j["final_model"]["parameters"][3]["value"] = -1.0;
  EXPECT_NE(error_of(j.dump()).find("final_model.parameters sigma0 = -1"), std::string::npos) << error_of(j.dump());
  j = Json::parse(text);
  j["final_model"]["parameters"][3]["value"] = nullptr;  // tribo-fit writes null for what it could not compute
  EXPECT_NE(error_of(j.dump()).find("sigma0"), std::string::npos);
  j = Json::parse(text);
  j["base_model"]["describes_record"] = false;
  j["base_model"]["not_describing_reasons"] = Json::array({"base model out of bounds: mu_s 2.22e+16"});
  EXPECT_NE(error_of(j.dump()).find("base_model.describes_record is false"), std::string::npos) << error_of(j.dump());
  EXPECT_NE(error_of(j.dump()).find("mu_s 2.22e+16"), std::string::npos);
  j = Json::parse(text);
  j.erase("final_model");
  EXPECT_NE(error_of(j.dump()).find("no final_model"), std::string::npos);
  EXPECT_NE(error_of("{\"final_model\": ").find("not JSON"), std::string::npos);
  EXPECT_NE(error_of("[1, 2]").find("not a JSON object"), std::string::npos);
}

// The report with the references tribo-fit states beside its final model.
std::string with_references(const std::string& text, double speed_m_per_s, double load_n) {
  Json j = Json::parse(text);
  j["final_model"]["reference_speed_m_per_s"] = speed_m_per_s;
  j["final_model"]["reference_load"] = load_n;
  return j.dump();
}

std::string with_rate_state(const std::string& text, const std::string& law) {
  Json j = Json::parse(with_effect(text, "rate_state", {{"rs_a", 0.012}, {"rs_b", 0.010}, {"rs_dc", 2e-7}}));
  j["final_model"]["rate_state_law"] = law;
  return j.dump();
}

TEST(FrictionReport, ReadsTheLogVelocityAndLoadTermsWithTheReferencesTheReportStates) {
  std::string text = with_rate_state(identification_report(), "slip (Ruina)");
  text = with_effect(text, "velocity_strengthening", {{"log_velocity_coeff", 0.002}});
  text = with_effect(text, "load_dependence", {{"load_exponent", -0.15}});
  const auto read = read_friction_report(with_references(text, 3.5e-6, 4.9e-3));
  ASSERT_TRUE(std::holds_alternative<FrictionReport>(read)) << std::get<std::string>(read);
  const IdentifiedFriction& m = std::get<FrictionReport>(read).model;
  EXPECT_TRUE(m.rate_state);
  EXPECT_TRUE(m.rate_state_slip_law);
  EXPECT_EQ(m.rate_state_a, 0.012);
  EXPECT_EQ(m.rate_state_b, 0.010);
  EXPECT_EQ(m.rate_state_memory_m, 2e-7);
  EXPECT_TRUE(m.velocity_strengthening);
  EXPECT_EQ(m.log_velocity_coeff, 0.002);
  EXPECT_TRUE(m.load_dependence);
  EXPECT_EQ(m.load_exponent, -0.15);
  EXPECT_EQ(m.reference_speed_m_per_s, 3.5e-6);
  EXPECT_EQ(m.reference_load_n, 4.9e-3);
  EXPECT_EQ(std::get<FrictionReport>(read).contact,
            "lugre + tilt_offset + rate_state + velocity_strengthening + load_dependence");
  EXPECT_FALSE(std::get<FrictionReport>(read_friction_report(
                                            with_references(with_rate_state(identification_report(), "ageing (Dieterich)"),
                                                            3.5e-6, 4.9e-3)))
                   .model.rate_state_slip_law);
}

// A report tribo-fit wrote with rate-and-state in its final model (the
// break-away record's, tests/data/friction_reports/README.md) loads as it is.
TEST(FrictionReport, LoadsARateAndStateModelTriboFitChose) {
  auto text = wire::read_file(std::string(TRIBO_SOURCE_DIR) + "/tests/data/friction_reports/breakaway.json");
  ASSERT_TRUE(text);
  const auto read = read_friction_report(*text);
  ASSERT_TRUE(std::holds_alternative<FrictionReport>(read)) << std::get<std::string>(read);
  const IdentifiedFriction& m = std::get<FrictionReport>(read).model;
  const Json j = Json::parse(*text);
  EXPECT_EQ(std::get<FrictionReport>(read).contact, "lugre + rate_state + tilt_offset + presliding_hysteresis");
  EXPECT_TRUE(m.rate_state);
  EXPECT_FALSE(m.rate_state_slip_law);  // "ageing (Dieterich)"
  EXPECT_EQ(m.rate_state_a, value_of(j, "rs_a"));
  EXPECT_EQ(m.rate_state_b, value_of(j, "rs_b"));
  EXPECT_EQ(m.rate_state_memory_m, value_of(j, "rs_dc"));
  EXPECT_EQ(m.reference_speed_m_per_s, j["final_model"]["reference_speed_m_per_s"].get<double>());
  EXPECT_NEAR(m.reference_speed_m_per_s, 4e-6, 0.1e-6);  // the record's slides at 4, 18 and 36 µm/s: the median, 4
  EXPECT_FALSE(m.load_dependence);
}

// Without the reference a term is referred to, the term means nothing: a
// report of a tribo-fit that did not state it is refused, naming the field.
TEST(FrictionReport, RefusesALogVelocityOrLoadTermWithoutItsReference) {
  const std::string text = identification_report();  // written before the references were stated
  const std::string rate_state = with_rate_state(text, "ageing (Dieterich)");
  EXPECT_NE(error_of(rate_state).find("final_model has no reference_speed_m_per_s"), std::string::npos)
      << error_of(rate_state);
  EXPECT_NE(error_of(with_effect(text, "velocity_strengthening", {{"log_velocity_coeff", 0.002}}))
                .find("no reference_speed_m_per_s"),
            std::string::npos);
  EXPECT_NE(error_of(with_effect(text, "load_dependence", {{"load_exponent", 0.3}})).find("no reference_load"),
            std::string::npos);
  EXPECT_NE(error_of(with_references(rate_state, 0.0, 1e-3)).find("final_model.reference_speed_m_per_s = 0 must be positive"),
            std::string::npos)
      << error_of(with_references(rate_state, 0.0, 1e-3));
  EXPECT_EQ(error_of(with_references(rate_state, 2e-6, 1e-3)), "accepted");
  // A law the observer does not know.
  const std::string unknown_law = with_references(with_rate_state(text, "Perrin"), 2e-6, 1e-3);
  EXPECT_NE(error_of(unknown_law).find("final_model.rate_state_law = \"Perrin\""), std::string::npos)
      << error_of(unknown_law);
}

// A plain load-scaled LuGre with a tilted tip, the form the fixture has.
IdentifiedFriction plain_model() {
  IdentifiedFriction m;
  m.load_scaled = true;
  m.coulomb = 0.09;
  m.static_level = 0.12;
  m.stribeck_velocity_m_per_s = 2e-6;
  m.sigma0_n_per_m = 3000;
  m.sigma1_n_s_per_m = 0.1;
  m.viscous_n_s_per_m = 0.8;
  m.tilt_tan = -0.026;
  return m;
}

// F^ after sliding 20 µm at v (many times the bristle's deflection scale),
// stepped with period dt.
double steady_force(const IdentifiedFriction& m, double v, double normal, double dt) {
  ObserverState s = observer_at_rest(m);
  ObserverOutput o;
  for (int k = 0; k < static_cast<int>(std::lround(20e-6 / std::fabs(v) / dt)); ++k) {
    ObserverInput in;
    in.commanded_velocity_m_per_s = v;
    in.normal_force_n = normal;
    in.period_s = dt;
    o = observer_step(m, ObserverSettings{}, in, s);
  }
  return o.force_n;
}

TEST(FrictionObserver, SteadySlidingGivesTheModelsSteadyFrictionAtAnyLoopRate) {
  const IdentifiedFriction m = plain_model();
  for (const double v : {0.5e-6, 4e-6, -18e-6}) {
    const double n = 9.81e-3;
    const double level = (m.coulomb + (m.static_level - m.coulomb) * std::exp(-std::fabs(v) / 2e-6)) * n;
    const double expected = (v > 0 ? level : -level) + m.viscous_n_s_per_m * v + m.tilt_tan * n;
    EXPECT_NEAR(steady_force(m, v, n, 1e-4), expected, 1e-9 * level) << v;
    // Each tick is integrated exactly: a 10 Hz loop reaches the same state.
    EXPECT_NEAR(steady_force(m, v, n, 0.1), expected, 1e-9 * level) << v;
  }
}

TEST(FrictionObserver, PreslidingIsElasticWithElastoPlasticity) {
  IdentifiedFriction m = plain_model();
  m.elasto_plastic = true;
  m.breakaway_ratio = 0.9;
  ObserverState s = observer_at_rest(m);
  ObserverInput in;
  in.commanded_velocity_m_per_s = 1e-6;
  in.normal_force_n = 5e-3;
  in.period_s = 1e-4;
  ObserverOutput o;
  for (int k = 0; k < 500; ++k) o = observer_step(m, ObserverSettings{}, in, s);  // 50 nm, within r g = 135 nm
  EXPECT_NEAR(s.bristle_m, 50e-9, 1e-15);
  EXPECT_NEAR(o.friction_n, m.sigma0_n_per_m * 50e-9 + m.sigma1_n_s_per_m * 1e-6 + m.viscous_n_s_per_m * 1e-6, 1e-12);
  // Without it LuGre already slips within the elastic range.
  m.elasto_plastic = false;
  ObserverState plain = observer_at_rest(m);
  for (int k = 0; k < 500; ++k) observer_step(m, ObserverSettings{}, in, plain);
  EXPECT_LT(plain.bristle_m, 0.9 * 50e-9);
}

TEST(FrictionObserver, TheCorrectionCannotPushBeyondTheStaticFriction) {
  const IdentifiedFriction m = plain_model();
  ObserverSettings settings;
  settings.observer_gain_per_s = 1e4;
  ObserverState s = observer_at_rest(m);
  ObserverInput in;
  in.position_error_m = -5e-6;  // far behind: the correction wants ever more
  in.normal_force_n = 5e-3;
  in.period_s = 1e-4;
  for (int k = 0; k < 1000; ++k) observer_step(m, settings, in, s);
  EXPECT_NEAR(m.sigma0_n_per_m * s.bristle_m, m.static_level * in.normal_force_n, 1e-12);
  // The correction works on the error's sign: behind, it pushes forward.
  in.position_error_m = 5e-6;
  for (int k = 0; k < 1000; ++k) observer_step(m, settings, in, s);
  EXPECT_NEAR(m.sigma0_n_per_m * s.bristle_m, -m.static_level * in.normal_force_n, 1e-12);
}

// The bound on the bristle is a projection, not a motion: when the level
// falls in one tick (a log-velocity term as the command stops) the bristle is
// held to the lower bound, and the damping takes only the bristle's own rate,
// here none (at rest, no correction), not sigma1 times the jump over the tick.
TEST(FrictionObserver, TheDampingDoesNotDifferenceTheBristlesBound) {
  IdentifiedFriction m = plain_model();
  m.sigma1_n_s_per_m = 5.0;  // of the order of the default contact's 5.54
  m.velocity_strengthening = true;
  m.log_velocity_coeff = 0.01;  // the level falls by 0.01 ln 401 as 4 µm/s stops
  m.reference_speed_m_per_s = 1e-6;
  ObserverState s = observer_at_rest(m);
  ObserverInput in;
  in.commanded_velocity_m_per_s = 4e-6;
  in.normal_force_n = 5e-3;
  in.period_s = 1e-4;
  for (int k = 0; k < 5000; ++k) observer_step(m, ObserverSettings{}, in, s);  // 2 µm: steady
  const double sliding_bristle = s.bristle_m;
  const double z_max_at_rest = identified_friction_level(m, 0, 1, in.normal_force_n, 0, 0) / m.sigma0_n_per_m;
  ASSERT_GT(sliding_bristle, 1.2 * z_max_at_rest) << "the stop must clamp the bristle";
  in.commanded_velocity_m_per_s = 0;
  const ObserverOutput o = observer_step(m, ObserverSettings{}, in, s);
  EXPECT_EQ(s.bristle_m, z_max_at_rest);
  // At rest without correction the bristle's own rate is 0: no damping at all.
  // Differencing the clamp would add sigma1 (z - z_max) / h, 2.8 mN here.
  EXPECT_NEAR(o.friction_n, m.sigma0_n_per_m * z_max_at_rest, 1e-12);
  // A command that still moves: the damping is at most sigma1 times the
  // bristle's rate (at most |v|, it relaxes towards its steady deflection).
  for (int k = 0; k < 5000; ++k) {
    in.commanded_velocity_m_per_s = 4e-6;
    observer_step(m, ObserverSettings{}, in, s);
  }
  in.commanded_velocity_m_per_s = 0.05e-6;
  const double z_max_slow = std::max(identified_friction_level(m, 0.05e-6, 1, in.normal_force_n, 0, 0),
                                     identified_friction_level(m, 0, 1, in.normal_force_n, 0, 0)) /
                            m.sigma0_n_per_m;
  ASSERT_GT(s.bristle_m, 1.1 * z_max_slow);
  const ObserverOutput slow = observer_step(m, ObserverSettings{}, in, s);
  const double damping = slow.friction_n - m.sigma0_n_per_m * s.bristle_m - m.viscous_n_s_per_m * 0.05e-6;
  EXPECT_LE(std::fabs(damping), m.sigma1_n_s_per_m * 0.05e-6 + 1e-15);
}

// Held at the bound by the correction, the bristle does not move: the
// observer's friction stays the model's static friction, with no damping of
// the rate the correction asks beyond the bound.
TEST(FrictionObserver, ABristleHeldAtItsBoundAddsNoDamping) {
  IdentifiedFriction m = plain_model();
  m.sigma1_n_s_per_m = 5.0;
  ObserverSettings settings;
  settings.observer_gain_per_s = 1e4;
  ObserverState s = observer_at_rest(m);
  ObserverInput in;
  in.position_error_m = -5e-6;  // far behind: the correction asks 0.05 m/s
  in.normal_force_n = 5e-3;
  in.period_s = 1e-4;
  ObserverOutput o;
  for (int k = 0; k < 1000; ++k) o = observer_step(m, settings, in, s);
  EXPECT_NEAR(o.friction_n, m.static_level * in.normal_force_n, 1e-12);
}

TEST(FrictionObserver, AReadingThatIsNotFiniteLeavesTheStateAlone) {
  const IdentifiedFriction m = plain_model();
  ObserverState s = observer_at_rest(m);
  ObserverInput in;
  in.commanded_velocity_m_per_s = 1e-6;
  in.normal_force_n = 5e-3;
  in.period_s = 1e-4;
  for (int k = 0; k < 100; ++k) observer_step(m, ObserverSettings{}, in, s);
  const double z = s.bristle_m;
  in.normal_force_n = std::nan("");
  EXPECT_FALSE(observer_step(m, ObserverSettings{}, in, s).advanced);
  EXPECT_EQ(s.bristle_m, z);
}

TEST(FrictionObserver, DwellStrengthensTheStaticLevelWithTheContactsAge) {
  IdentifiedFriction m = plain_model();
  m.dwell = true;
  m.dwell_gain = 0.03;
  m.dwell_time_s = 10;
  m.dwell_memory_m = 1e-6;
  ObserverState s = observer_at_rest(m);
  ObserverInput in;
  in.normal_force_n = 1e-3;
  in.period_s = 0.1;
  for (int k = 0; k < 100; ++k) observer_step(m, ObserverSettings{}, in, s);  // 10 s at rest
  EXPECT_NEAR(s.contact_age_s, 10.0, 1e-9);
  EXPECT_NEAR(identified_friction_level(m, 0, 1, 1e-3, 0, s.contact_age_s), (0.12 + 0.03 * 0.5) * 1e-3, 1e-15);
  // Sliding ages it to D / |v|: 1 µm at 10 µm/s, 0.1 s.
  in.commanded_velocity_m_per_s = 10e-6;
  for (int k = 0; k < 100; ++k) observer_step(m, ObserverSettings{}, in, s);
  EXPECT_NEAR(s.contact_age_s, 0.1, 1e-6);
}

TEST(FrictionObserver, RateAndStateSteadyFrictionFollowsItsVelocityDependence) {
  IdentifiedFriction m = plain_model();
  m.static_level = m.coulomb;  // no Stribeck drop: the log terms alone
  m.rate_state = true;
  m.rate_state_a = 0.012;
  m.rate_state_b = 0.010;
  m.rate_state_memory_m = 0.2e-6;
  m.reference_speed_m_per_s = 2e-6;
  for (const bool slip : {false, true}) {
    m.rate_state_slip_law = slip;
    const double n = 1e-3, v = 8e-6;
    const double floor = 0.01 * m.reference_speed_m_per_s;
    // Steady state theta = Dc / v: a ln((v + v_f)/v_ref) + b ln(v_ref / v).
    const double level = (m.coulomb + m.rate_state_a * std::log((v + floor) / m.reference_speed_m_per_s) +
                          m.rate_state_b * std::log(m.reference_speed_m_per_s / v)) *
                         n;
    EXPECT_NEAR(steady_force(m, v, n, 1e-4), level + m.viscous_n_s_per_m * v + m.tilt_tan * n, 1e-6 * level) << slip;
  }
}

// contact_state_from_measured: the rate-and-state variable and the contact
// age evolve at the speed read from the position, not at the commanded one:
// while the reading stands still the contact keeps its state, however fast
// the command moves; once the reading moves, the state follows it.
TEST(FrictionObserver, TheContactsStateFollowsTheMeasuredSpeedWhenAsked) {
  IdentifiedFriction m = plain_model();
  m.rate_state = true;
  m.rate_state_slip_law = true;
  m.rate_state_a = 0.012;
  m.rate_state_b = 0.010;
  m.rate_state_memory_m = 0.2e-6;
  m.reference_speed_m_per_s = 2e-6;
  m.dwell = true;
  m.dwell_gain = 0.03;
  m.dwell_time_s = 10;
  m.dwell_memory_m = 1e-6;
  const double h = 1e-4;
  ObserverSettings measured;
  measured.contact_state_from_measured = true;
  measured.velocity_filter_hz = 50;
  ObserverState commanded_state = observer_at_rest(m), measured_state = observer_at_rest(m);
  const double at_rest = measured_state.rate_state_s;  // Dc / v_ref
  ObserverInput in;
  in.normal_force_n = 1e-3;
  in.period_s = h;
  in.commanded_velocity_m_per_s = 4e-6;
  for (int k = 0; k < 1000; ++k) {  // 0.1 s of command, the reading still
    observer_step(m, ObserverSettings{}, in, commanded_state);
    observer_step(m, measured, in, measured_state);
  }
  EXPECT_EQ(measured_state.rate_state_s, at_rest) << "the slip law holds theta at rest";
  EXPECT_NEAR(measured_state.contact_age_s, 0.1, 1e-9) << "ages as at rest";
  EXPECT_EQ(measured_state.driving_velocity_m_per_s, 4e-6) << "the bristle still follows the command";
  // Commanded: 2 Dc of motion take theta most of the way to Dc / v.
  EXPECT_LT(commanded_state.rate_state_s, 0.6 * at_rest);
  // ... and the age follows Dieterich's law towards D / v = 0.25 s.
  EXPECT_NEAR(commanded_state.contact_age_s, 0.25 * (1 - std::exp(-0.4)), 1e-6);
  // The reading moves at 4 µm/s: the state follows it towards Dc / v.
  for (int k = 0; k < 2000; ++k) {
    in.position_m += 4e-6 * h;
    observer_step(m, measured, in, measured_state);
  }
  EXPECT_NEAR(measured_state.rate_state_s, m.rate_state_memory_m / 4e-6, 0.05 * m.rate_state_memory_m / 4e-6);
}

TEST(FrictionObserver, LoadDependenceScalesTheLevelsAboutTheReferenceLoad) {
  IdentifiedFriction m = plain_model();
  m.load_dependence = true;
  m.load_exponent = -0.2;
  m.reference_load_n = 2e-3;
  const double at_reference = identified_friction_level(m, 1e-6, 1, 2e-3, 0, 0);
  EXPECT_NEAR(at_reference, (m.coulomb + (m.static_level - m.coulomb) * std::exp(-0.5)) * 2e-3, 1e-15);
  // mu (N / N_ref)^e: at eight times the load, the coefficient falls by 8^-0.2.
  EXPECT_NEAR(identified_friction_level(m, 1e-6, 1, 16e-3, 0, 0), at_reference * 8 * std::pow(8.0, -0.2), 1e-15);
}

// A model with every term that varies along a motion: rate-and-state
// (healing at rest), a negative log-velocity term (strongest at rest), load
// dependence, dwell and asymmetry.
IdentifiedFriction varying_model(bool slip_law) {
  IdentifiedFriction m = plain_model();
  m.rate_state = true;
  m.rate_state_slip_law = slip_law;
  m.rate_state_a = 0.008;
  m.rate_state_b = 0.012;
  m.rate_state_memory_m = 0.3e-6;
  m.velocity_strengthening = true;
  m.log_velocity_coeff = -0.002;
  m.reference_speed_m_per_s = 3e-6;
  m.load_dependence = true;
  m.load_exponent = 0.1;
  m.reference_load_n = 2e-3;
  m.dwell = true;
  m.dwell_gain = 0.02;
  m.dwell_time_s = 1;
  m.dwell_memory_m = 0.5e-6;
  m.direction_asymmetry = true;
  m.asymmetry_levels = -0.05;
  return m;
}

// The validator's bound on S holds along any motion within the segment's
// speed and load, for as long as the segment lasts: here 20 s of rests,
// slides and reversals at speeds up to 20 µm/s and loads up to 5 mN, then
// 10 s at rest (the ageing law heals) or sliding slowly (the slip law's state
// grows), at the highest load. With the ageing law the contact's friction
// passes the static level with dwell (as the validator bounded it before the
// log-velocity terms were accepted), and the bound stays within a third of
// what it reached.
TEST(FrictionObserver, TheFrictionBoundHoldsAlongAnyMotionWithinItsLimits) {
  for (const bool slip : {false, true}) {
    const IdentifiedFriction m = varying_model(slip);
    const double max_speed = 20e-6, max_load = 5e-3, duration = 30, dt = 1e-3;
    const double bound = identified_friction_bound(m, max_speed, max_load, duration);
    ObserverState s = observer_at_rest(m);
    std::uint32_t lcg = 12345;
    const auto uniform = [&] {
      lcg = lcg * 1664525u + 1013904223u;
      return static_cast<double>(lcg >> 8) / 16777216.0;
    };
    double highest = 0, v = 0, load = max_load;
    for (int k = 0; k < static_cast<int>(duration / dt); ++k) {
      if (k % 500 == 0) {  // a new speed and load every 0.5 s; at rest one time in three
        v = uniform() < 1.0 / 3 ? 0.0 : (uniform() < 0.5 ? -1 : 1) * max_speed * uniform();
        load = max_load * (0.2 + 0.8 * uniform());
      }
      if (k >= 20000) {
        v = slip ? 0.03e-6 : 0.0;
        load = max_load;
      }
      ObserverInput in;
      in.commanded_velocity_m_per_s = v;
      in.normal_force_n = load;
      in.period_s = dt;
      observer_step(m, ObserverSettings{}, in, s);
      for (const double speed : {std::fabs(v), 0.0, max_speed}) {
        for (const double direction : {-1.0, 1.0}) {
          const double level = identified_friction_level(m, speed, direction, load, s.rate_state_s, s.contact_age_s);
          EXPECT_LE(level, bound) << slip << " at " << k * dt << " s";
          highest = std::max(highest, level);
        }
      }
    }
    if (!slip) {
      const double static_with_dwell = (std::max(m.static_level, m.coulomb) + m.dwell_gain) * max_load *
                                       std::pow(max_load / m.reference_load_n, m.load_exponent) *
                                       (1 + std::fabs(m.asymmetry_levels));
      EXPECT_GT(highest, 1.1 * static_with_dwell);
      EXPECT_LT(bound, 1.35 * highest);
    }
  }
}

}  // namespace
}  // namespace tribo::daemon
