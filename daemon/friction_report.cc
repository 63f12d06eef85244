#include "daemon/friction_report.h"

#include <openssl/evp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>

namespace tribo::daemon {

namespace {

using Json = nlohmann::json;

constexpr std::array<std::string_view, 7> kEvaluated = {
    "presliding_hysteresis", "dwell_stiction", "direction_asymmetry", "tilt_offset",
    "rate_state",            "velocity_strengthening", "load_dependence"};

// Why an effect of the vocabulary cannot be compensated.
std::optional<std::string> refusal(std::string_view effect) {
  if (effect == "frictional_lag") return std::string(effect) + ": the compensation does not delay the velocity";
  if (effect == "position_periodic" || effect == "drift" || effect == "backlash") {
    return std::string(effect) + ": a function of where or when the identified record slid, not of the contact";
  }
  return std::nullopt;
}

std::string evaluated_list() {
  std::string list;
  for (std::string_view e : kEvaluated) list += (list.empty() ? "" : ", ") + std::string(e);
  return list;
}

struct Parameters {
  std::map<std::string, double, std::less<>> values;
  std::optional<double> get(std::string_view name) const {
    const auto it = values.find(name);
    return it == values.end() ? std::nullopt : std::optional<double>(it->second);
  }
};

std::string number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// A required parameter, finite and within (lo, hi) (open bounds) or [lo, hi].
struct Bound {
  double lo, hi;
  bool open_lo, open_hi;
};

std::optional<std::string> take(const Parameters& p, std::string_view name, Bound b, double& out) {
  const auto v = p.get(name);
  if (!v) return "final_model.parameters has no " + std::string(name);
  if (!std::isfinite(*v) || (b.open_lo ? !(*v > b.lo) : !(*v >= b.lo)) || (b.open_hi ? !(*v < b.hi) : !(*v <= b.hi))) {
    return "final_model.parameters " + std::string(name) + " = " + number(*v) + " is outside " +
           (b.open_lo ? "(" : "[") + number(b.lo) + ", " + number(b.hi) + (b.open_hi ? ")" : "]");
  }
  out = *v;
  return std::nullopt;
}

// A reference of the model's terms the report states beside its parameters
// (final_model.reference_speed_m_per_s, final_model.reference_load): finite
// and positive.
std::optional<std::string> reference(const Json& final_model, const char* field, const char* what, double& out) {
  const Json* v = final_model.contains(field) ? &final_model.at(field) : nullptr;
  if (!v || !v->is_number()) {
    return std::string("final_model has no ") + field + " (" + what +
           "; an older tribo-fit's report does not state it: diagnose the record again)";
  }
  const double value = v->get<double>();
  if (!std::isfinite(value) || !(value > 0)) {
    return std::string("final_model.") + field + " = " + number(value) + " must be positive";
  }
  out = value;
  return std::nullopt;
}

constexpr double kInf = HUGE_VAL;
constexpr Bound kPositive{0, kInf, true, true};
constexpr Bound kNonNegative{0, kInf, false, true};
constexpr Bound kAny{-kInf, kInf, true, true};
constexpr Bound kFraction{0, 1, true, true};
constexpr Bound kRatio{-1, 1, true, true};

std::variant<FrictionReport, std::string> read(const Json& j) {
  FrictionReport r;
  IdentifiedFriction& m = r.model;
  if (!j.is_object()) return std::string("the report is not a JSON object");
  const Json* fm = j.contains("final_model") ? &j.at("final_model") : nullptr;
  if (!fm || !fm->is_object()) return std::string("the report has no final_model (is it tribo-fit diagnose --json?)");
  if (j.contains("input") && j.at("input").contains("force_unit")) {
    const auto unit = j.at("input").at("force_unit").get<std::string>();
    if (unit != "N") return "input.force_unit is " + unit + ": the compensation needs forces in N";
  }
  const Json base = j.value("base_model", Json::object());
  // tribo-fit still writes a final model when it judges the record not
  // described (a bound passed); in the loop that model would push the tip
  // with a friction the record never showed. Hand-written reports carry no
  // judgement and are taken as they are.
  if (base.contains("describes_record") && base.at("describes_record").is_boolean() &&
      !base.at("describes_record").get<bool>()) {
    std::string why = "base_model.describes_record is false: tribo-fit says its model does not describe the record";
    for (const Json& reason : base.value("not_describing_reasons", Json::array())) {
      if (reason.is_string()) why += "; " + reason.get<std::string>();
    }
    return why;
  }
  m.load_scaled = base.value("load_scaled", false);
  m.stribeck_exponent = base.value("stribeck_exponent", 1.0);
  if (!(m.stribeck_exponent > 0) || !std::isfinite(m.stribeck_exponent)) {
    return "base_model.stribeck_exponent = " + number(m.stribeck_exponent) + " must be positive";
  }

  r.contact = "lugre";
  for (const Json& e : fm->value("effects", Json::array())) {
    const std::string name = e.get<std::string>();
    if (auto why = refusal(name)) return "final_model.effects has " + *why + " (the compensation evaluates " +
                                         evaluated_list() + ")";
    if (std::find(kEvaluated.begin(), kEvaluated.end(), name) == kEvaluated.end()) {
      return "final_model.effects has " + name + ", which the compensation does not know (it evaluates " +
             evaluated_list() + ")";
    }
    r.contact += " + " + name;
    if (name == "presliding_hysteresis") m.elasto_plastic = true;
    if (name == "dwell_stiction") m.dwell = true;
    if (name == "direction_asymmetry") m.direction_asymmetry = true;
    if (name == "rate_state") m.rate_state = true;
    if (name == "velocity_strengthening") m.velocity_strengthening = true;
    if (name == "load_dependence") m.load_dependence = m.load_scaled;  // tribo-fit scales load-scaled levels only
  }

  Parameters p;
  for (const Json& q : fm->value("parameters", Json::array())) {
    const std::string name = q.at("name").get<std::string>();
    const double value = q.at("value").is_number() ? q.at("value").get<double>() : std::nan("");
    p.values[name] = value;
    r.parameters.push_back({name, value, q.value("unit", "")});
  }
  if (p.get("slip_trend")) {
    return std::string("final_model.parameters has slip_trend: a friction level linear in the distance the "
                       "identified record slid, not a property of the contact");
  }
  const char* fc = m.load_scaled ? "mu_c" : "Fc";
  const char* fs = m.load_scaled ? "mu_s" : "Fs";
  for (auto why : {take(p, fc, kNonNegative, m.coulomb), take(p, fs, kNonNegative, m.static_level),
                   take(p, "vs", kPositive, m.stribeck_velocity_m_per_s), take(p, "sigma0", kPositive, m.sigma0_n_per_m),
                   take(p, "sigma1", kNonNegative, m.sigma1_n_s_per_m), take(p, "Fv", kAny, m.viscous_n_s_per_m)}) {
    if (why) return *why;
  }
  if (!(m.coulomb > 0 || m.static_level > 0)) {
    return std::string("final_model.parameters: ") + fc + " and " + fs + " are both 0: no friction to compensate";
  }
  if (p.get("tilt_tan")) {
    if (auto why = take(p, "tilt_tan", kRatio, m.tilt_tan)) return *why;
  }
  if (m.elasto_plastic) {
    if (auto why = take(p, "breakaway_ratio", kFraction, m.breakaway_ratio)) return *why;
  }
  if (m.dwell) {
    for (auto why : {take(p, "dwell_dFs", kAny, m.dwell_gain), take(p, "dwell_time", kPositive, m.dwell_time_s),
                     take(p, "dwell_memory", kPositive, m.dwell_memory_m)}) {
      if (why) return *why;
    }
  }
  if (m.direction_asymmetry) {
    for (auto why : {take(p, "asym_levels", kRatio, m.asymmetry_levels),
                     take(p, "asym_viscous", kAny, m.asymmetry_viscous)}) {
      if (why) return *why;
    }
  }
  if (m.rate_state) {
    for (auto why : {take(p, "rs_a", kAny, m.rate_state_a), take(p, "rs_b", kAny, m.rate_state_b),
                     take(p, "rs_dc", kPositive, m.rate_state_memory_m)}) {
      if (why) return *why;
    }
    const std::string law = fm->value("rate_state_law", "");
    if (law != "slip (Ruina)" && law != "ageing (Dieterich)") {
      return "final_model.rate_state_law = \"" + law + "\": expected \"ageing (Dieterich)\" or \"slip (Ruina)\"";
    }
    m.rate_state_slip_law = law == "slip (Ruina)";
  }
  if (m.velocity_strengthening) {
    if (auto why = take(p, "log_velocity_coeff", kAny, m.log_velocity_coeff)) return *why;
  }
  if (m.rate_state || m.velocity_strengthening) {
    if (auto why = reference(*fm, "reference_speed_m_per_s", "the speed its log-velocity terms are referred to",
                             m.reference_speed_m_per_s)) {
      return *why;
    }
  }
  if (m.load_dependence) {
    if (auto why = take(p, "load_exponent", kRatio, m.load_exponent)) return *why;
    if (auto why = reference(*fm, "reference_load", "the load load_dependence is referred to", m.reference_load_n)) {
      return *why;
    }
  }
  return r;
}

}  // namespace

std::variant<FrictionReport, std::string> read_friction_report(std::string_view report_json) {
  Json j;
  try {
    j = Json::parse(report_json);
  } catch (const Json::exception& e) {
    return std::string("the report is not JSON: ") + e.what();
  }
  std::variant<FrictionReport, std::string> out;
  try {
    out = read(j);
  } catch (const Json::exception& e) {  // a field of the wrong type
    return std::string("the report does not have the shape of tribo-fit diagnose --json: ") + e.what();
  }
  if (auto* r = std::get_if<FrictionReport>(&out)) r->sha256 = sha256_hex(report_json);
  return out;
}

std::string sha256_hex(std::string_view bytes) {
  std::array<unsigned char, EVP_MAX_MD_SIZE> digest{};
  unsigned int size = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), digest.data(), &size, EVP_sha256(), nullptr) != 1) return "";
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  for (unsigned int i = 0; i < size; ++i) {
    out += kHex[digest[i] >> 4];
    out += kHex[digest[i] & 15];
  }
  return out;
}

}  // namespace tribo::daemon
