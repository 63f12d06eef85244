#include "client/control_loops.h"

#include <algorithm>
#include <array>
#include <cctype>

#include <fmt/format.h>

namespace tribo::client {

namespace {

struct LoopName {
  v1::ControlLoop loop;
  const char* name;
  bool displacement;  // error in m (else in N)
};

constexpr std::array<LoopName, 4> kLoops{{
    {v1::LOOP_LATERAL_DISPLACEMENT, "lateral-displacement", true},
    {v1::LOOP_LATERAL_FORCE, "lateral-force", false},
    {v1::LOOP_NORMAL_FORCE, "normal-force", false},
    {v1::LOOP_NORMAL_DISPLACEMENT, "normal-displacement", true},
}};

std::string upper(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::toupper(c); });
  return s;
}

const google::protobuf::FieldDescriptor* numeric_field(const std::string& name) {
  const auto* field = v1::PidGains::descriptor()->FindFieldByName(name);
  return field != nullptr && field->cpp_type() == google::protobuf::FieldDescriptor::CPPTYPE_DOUBLE ? field
                                                                                                      : nullptr;
}

}  // namespace

std::string loop_name(v1::ControlLoop loop) {
  for (const auto& l : kLoops) {
    if (l.loop == loop) return l.name;
  }
  return v1::ControlLoop_Name(loop);
}

std::optional<v1::ControlLoop> parse_loop(const std::string& text) {
  for (const auto& l : kLoops) {
    if (text == l.name || upper(text) == v1::ControlLoop_Name(l.loop)) return l.loop;
  }
  return std::nullopt;
}

std::string loop_names() {
  std::string names;
  for (const auto& l : kLoops) names += (names.empty() ? "" : ", ") + std::string(l.name);
  return names;
}

std::vector<std::string> gain_fields() {
  std::vector<std::string> names;
  const auto* d = v1::PidGains::descriptor();
  for (int i = 0; i < d->field_count(); ++i) {
    if (numeric_field(d->field(i)->name())) names.push_back(d->field(i)->name());
  }
  return names;
}

std::string gain_unit(v1::ControlLoop loop, const std::string& field) {
  const bool displacement = loop == v1::LOOP_LATERAL_DISPLACEMENT || loop == v1::LOOP_NORMAL_DISPLACEMENT;
  if (field == "kp") return displacement ? "N/m" : "N/N";
  if (field == "ki") return displacement ? "N/(m s)" : "1/s";
  if (field == "kd") return displacement ? "N s/m" : "s";
  if (field == "derivative_filter_hz") return "Hz";
  if (field == "output_min" || field == "output_max") return "N";
  if (field == "tracking_time_s") return "s";
  return "";  // set-point weights and the feed-forward gain are ratios
}

bool set_gain_field(v1::PidGains& gains, const std::string& field, double value) {
  const auto* f = numeric_field(field);
  if (f == nullptr) return false;
  gains.GetReflection()->SetDouble(&gains, f, value);
  return true;
}

std::string gains_text(v1::ControlLoop loop, const v1::PidGains& gains, const std::string& indent) {
  std::string text;
  for (const auto& field : gain_fields()) {
    const double value = gains.GetReflection()->GetDouble(gains, numeric_field(field));
    const std::string unit = gain_unit(loop, field);
    text += fmt::format("{}{:<21} {:g}{}\n", indent, field, value, unit.empty() ? "" : " " + unit);
  }
  return text + fmt::format("{}{:<21} {}\n", indent, "anti_windup", v1::AntiWindup_Name(gains.anti_windup()));
}

}  // namespace tribo::client
