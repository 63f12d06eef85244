// The tribo-fit command: usage, exit codes and the JSON contract.
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

#include "tests/analysis/analysis_test_support.h"

namespace tribo::analysis {
namespace {

struct Output {
  int exit_code = -1;
  std::string text;
};

// The command's stdout and stderr together, unless redirect says otherwise.
Output run(const std::string& args, const std::string& redirect = "2>&1") {
  Output out;
  const std::string command = std::string(TRIBO_FIT_PATH) + " " + args + " " + redirect;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return out;
  std::array<char, 4096> buf;
  std::size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), pipe)) > 0) out.text.append(buf.data(), n);
  const int status = pclose(pipe);
  out.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return out;
}

TEST(TriboFitCli, HelpSaysColumnsAreSi) {
  const Output o = run("--help");
  EXPECT_EQ(o.exit_code, 0);
  EXPECT_NE(o.text.find("SI units"), std::string::npos);
  EXPECT_NE(o.text.find("tribo-fit diagnose INPUT"), std::string::npos);
}

TEST(TriboFitCli, EveryCommandHasItsOwnHelpAndTheToolAVersion) {
  const Output diagnose = run("diagnose --help");
  EXPECT_EQ(diagnose.exit_code, 0);
  EXPECT_NE(diagnose.text.find("--motion-estimator"), std::string::npos);
  EXPECT_NE(diagnose.text.find("Rauch-Tung-Striebel"), std::string::npos);
  const Output stribeck = run("stribeck --help");
  EXPECT_EQ(stribeck.exit_code, 0);
  EXPECT_NE(stribeck.text.find("--model"), std::string::npos);
  const Output metrics = run("metrics --help");
  EXPECT_EQ(metrics.exit_code, 0);
  EXPECT_NE(metrics.text.find("RUN_DIR"), std::string::npos);
  const Output version = run("--version");
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_NE(version.text.find("tribo-fit "), std::string::npos);
}

TEST(TriboFitCli, BadUsageExitsWithTwo) {
  EXPECT_EQ(run("diagnose").exit_code, 2);
  EXPECT_EQ(run("frobnicate").exit_code, 2);
  EXPECT_EQ(run("diagnose " + testing::measured_data("emps_train_DATA_EMPS.csv") + " --time t_s").exit_code, 2);
  EXPECT_EQ(run("diagnose x.csv --time t --position x --force f --effects not_an_effect").exit_code, 2);
}

TEST(TriboFitCli, UnreadableInputExitsWithOne) {
  EXPECT_EQ(run("diagnose /nonexistent.csv --time t --position x --force f").exit_code, 1);
}

TEST(TriboFitCli, DiagnoseJsonCarriesTheContractFields) {
  const Output o = run("diagnose " + testing::measured_data("emps_train_DATA_EMPS.csv") +
                       " --time t_s --position x_m --motor-force force_motor_N --velocity v_derived_m_s"
                       " --acceleration a_derived_m_s2 --effects direction_asymmetry,backlash --json");
  ASSERT_EQ(o.exit_code, 0) << o.text;
  for (const char* key : {"\"accepted_effects\"", "\"rejected_effects\"", "\"error_before\"", "\"error_after\"",
                          "\"unexplained\"", "\"fit\"", "\"heldout\"", "\"rms\"", "\"nrmse\"", "\"max\"", "\"relative\"",
                          "\"std_error\"", "\"reason\"", "\"heldout_by_condition\"", "\"minimum_detectable\"",
                          "\"searched_up_to\""}) {
    EXPECT_NE(o.text.find(key), std::string::npos) << key;
  }
  EXPECT_NE(o.text.find("\"name\": \"direction_asymmetry\""), std::string::npos);
  EXPECT_NE(o.text.find("\"name\": \"backlash\""), std::string::npos);  // rejected, with its reason
  EXPECT_EQ(o.text.front(), '{');
}

// --timings: one line per phase on stderr, in the order the diagnosis runs
// them, the rounds' fits counted as model work; stdout stays the report alone.
TEST(TriboFitCli, TimingsGoToStderrPhaseByPhase) {
  const std::string args = "diagnose " + testing::measured_data("emps_train_DATA_EMPS.csv") +
                           " --time t_s --position x_m --motor-force force_motor_N --velocity v_derived_m_s"
                           " --acceleration a_derived_m_s2 --effects direction_asymmetry --json --timings";
  const Output errors = run(args, "2>&1 >/dev/null");
  ASSERT_EQ(errors.exit_code, 0) << errors.text;
  std::vector<std::string> phases;
  double round_work = 0;
  std::istringstream lines(errors.text);
  for (std::string line; std::getline(lines, line);) {
    ASSERT_EQ(line.rfind("timings: ", 0), 0u) << line;
    const std::size_t wall = line.find(" wall ");
    ASSERT_NE(wall, std::string::npos) << line;
    std::string phase = line.substr(9, wall - 9);
    phase.erase(phase.find_last_not_of(' ') + 1);
    if (phase == "round 1") round_work = std::stod(line.substr(line.find("model work") + 10));
    phases.push_back(phase);
  }
  const std::vector<std::string> in_order = {"record read", "motion estimates", "base fit", "round 1",
                                             "minimum detectable strengths", "report written"};
  std::size_t at = 0;
  for (const std::string& phase : phases) {
    if (at < in_order.size() && phase == in_order[at]) ++at;
  }
  EXPECT_EQ(at, in_order.size()) << errors.text;
  EXPECT_GT(round_work, 0.0) << errors.text;
  const Output report = run(args, "2>/dev/null");
  ASSERT_EQ(report.exit_code, 0);
  EXPECT_EQ(report.text.front(), '{');
  EXPECT_EQ(report.text.find("timings:"), std::string::npos);
}

// --motion-estimator rts_jumps reaches the smoother: the basalt step is found
// as a velocity jump and the report names the estimator and the count.
TEST(TriboFitCli, VelocityJumpsAreAskedForAndReported) {
  const std::string args = "diagnose " + testing::measured_data("velstep7_BRAVA_expb819_basalt_Giacomel_et_al_2021.csv") +
                           " --time t_s --position x_m --force shear_stress_Pa --normal normal_stress_eff_Pa"
                           " --force-unit Pa --effects drift --json";
  const Output with = run(args + " --motion-estimator rts_jumps");
  ASSERT_EQ(with.exit_code, 0) << with.text;
  EXPECT_NE(with.text.find("\"motion_estimator\": \"rts_constant_acceleration_with_velocity_jumps\""), std::string::npos);
  EXPECT_EQ(with.text.find("\"velocity_jumps\": 0,"), std::string::npos);
  const Output without = run(args);
  ASSERT_EQ(without.exit_code, 0) << without.text;
  EXPECT_NE(without.text.find("\"motion_estimator\": \"rts_constant_acceleration\""), std::string::npos);
  EXPECT_NE(without.text.find("\"velocity_jumps\": 0,"), std::string::npos);
}

TEST(TriboFitCli, StribeckDiagnoseJsonCarriesTheContractFields) {
  const Output o = run("stribeck " + testing::measured_data("emps_plateaus.csv") + " --x v_m_s --y friction_n --diagnose --json");
  ASSERT_EQ(o.exit_code, 0) << o.text;
  for (const char* key : {"\"mode\": \"steady_state\"", "\"held_out\": \"leave-one-out\"", "\"base_evidence\"",
                          "\"base_model\"", "\"rounds\"", "\"held_out_change\"", "\"final_model\"",
                          "\"held_out_rms_n\"", "\"Fv_neg\"", "\"warnings\""}) {
    EXPECT_NE(o.text.find(key), std::string::npos) << key;
  }
  EXPECT_NE(o.text.find("\"accepted\": [\n    \"direction_asymmetry\""), std::string::npos) << o.text;
  EXPECT_EQ(run("stribeck " + testing::measured_data("emps_plateaus.csv") + " --x v_m_s --y friction_n --load v_m_s")
                .exit_code, 2);
  EXPECT_EQ(run("stribeck " + testing::measured_data("emps_plateaus.csv") + " --x v_m_s --y nope --diagnose").exit_code, 1);
}

// A copy of a measured-data file with one column rewritten, in a temporary
// directory that goes with it.
class AlteredCopy {
 public:
  AlteredCopy(const std::string& file, const std::string& column, const std::function<double(double)>& change)
      : path_(std::filesystem::temp_directory_path() /
              ("tribo_fit_cli_" + std::to_string(::getpid()) + "_" + column + "_" + file)) {
    std::ifstream in(testing::measured_data(file));
    std::ofstream out(path_);
    std::string line;
    std::getline(in, line);
    out << line << "\n";
    std::vector<std::string> header = split(line);
    std::size_t index = 0;
    while (index < header.size() && header[index] != column) ++index;
    while (std::getline(in, line)) {
      std::vector<std::string> fields = split(line);
      char text[32];
      std::snprintf(text, sizeof text, "%.17g", change(std::stod(fields.at(index))));
      fields[index] = text;
      for (std::size_t i = 0; i < fields.size(); ++i) out << (i ? "," : "") << fields[i];
      out << "\n";
    }
  }
  ~AlteredCopy() { std::filesystem::remove(path_); }
  std::string path() const { return path_.string(); }

 private:
  static std::vector<std::string> split(const std::string& line) {
    std::vector<std::string> fields;
    std::stringstream in(line);
    for (std::string field; std::getline(in, field, ',');) fields.push_back(field);
    return fields;
  }
  std::filesystem::path path_;
};

constexpr const char* kBasalt = "velstep7_BRAVA_expb819_basalt_Giacomel_et_al_2021.csv";
constexpr const char* kBasaltColumns =
    " --time t_s --position x_m --force shear_stress_Pa --normal normal_stress_eff_Pa --force-unit Pa --json";

void expect_refused(const Output& o, const std::vector<std::string>& said) {
  EXPECT_EQ(o.exit_code, 1) << o.text;
  EXPECT_NE(o.text.find("refused before fitting"), std::string::npos) << o.text;
  EXPECT_EQ(o.text.find("accepted_effects"), std::string::npos) << "a report was printed";
  for (const auto& s : said) EXPECT_NE(o.text.find(s), std::string::npos) << s << " not in: " << o.text;
}

// The shear stress 1e12 times too large: µ would be 6e11 (the fit goes on to report it).
TEST(TriboFitCliRefusesImplausibleInput, ForceFarBeyondAnyFrictionCoefficient) {
  const AlteredCopy copy(kBasalt, "shear_stress_Pa", [](double f) { return f * 1e12; });
  expect_refused(run("diagnose " + copy.path() + kBasaltColumns),
                 {"force column 'shear_stress_Pa'", "normal column 'normal_stress_eff_Pa'", "6.08e+11 times",
                  "not a friction coefficient (0.0001 to 10)", "different units"});
}

TEST(TriboFitCliRefusesImplausibleInput, ForceZeroInEveryRow) {
  const AlteredCopy copy(kBasalt, "shear_stress_Pa", [](double) { return 0.0; });
  expect_refused(run("diagnose " + copy.path() + kBasaltColumns),
                 {"force column 'shear_stress_Pa' has the same value, 0, in every row", "the wrong column"});
}

TEST(TriboFitCliRefusesImplausibleInput, ForceGivenTheSameColumnAsThePosition) {
  expect_refused(run("diagnose " + testing::measured_data(kBasalt) +
                     " --time t_s --position x_m --force x_m --normal normal_stress_eff_Pa --json"),
                 {"force column 'x_m' holds the same values as position column 'x_m'"});
}

TEST(TriboFitCliRefusesImplausibleInput, TimeThatDoesNotIncrease) {
  expect_refused(run("diagnose " + testing::measured_data(kBasalt) +
                     " --time x_m --position t_s --force shear_stress_Pa --json"),
                 {"the time column 'x_m' does not increase at sample"});
}

// The EMPS position in µm read as m: its velocity column integrates to a
// span a million times shorter.
TEST(TriboFitCliRefusesImplausibleInput, PositionUnitAgainstTheVelocity) {
  const AlteredCopy copy("emps_train_DATA_EMPS.csv", "x_m", [](double x) { return x * 1e6; });
  expect_refused(run("diagnose " + copy.path() +
                     " --time t_s --position x_m --motor-force force_motor_N --velocity v_derived_m_s --json"),
                 {"velocity column 'v_derived_m_s'", "position column 'x_m'", "(1e-06 times)",
                  "a position in µm given as m"});
}

}  // namespace
}  // namespace tribo::analysis
