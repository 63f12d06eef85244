#include "scorecard/split.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

namespace tribo::scorecard {

namespace {

using nlohmann::json;

// A field that is absent or of the wrong type: the error names it.
struct Invalid {
  std::string message;
};

void only_keys(const json& object, const std::string& where, const std::set<std::string>& allowed) {
  if (!object.is_object()) throw Invalid{where + ": expected an object, got " + object.dump()};
  for (const auto& [key, value] : object.items()) {
    if (!allowed.contains(key)) {
      std::string names;
      for (const std::string& a : allowed) names += (names.empty() ? "" : ", ") + a;
      throw Invalid{where + "." + key + ": unknown field (expected one of " + names + ")"};
    }
  }
}

std::string text(const json& object, const std::string& where, const std::string& key, bool required) {
  if (!object.contains(key)) {
    if (required) throw Invalid{where + "." + key + ": missing (a string is required)"};
    return "";
  }
  const json& v = object.at(key);
  if (!v.is_string() || v.get<std::string>().empty()) {
    throw Invalid{where + "." + key + ": expected a non-empty string, got " + v.dump()};
  }
  return v.get<std::string>();
}

double positive(const json& object, const std::string& where, const std::string& key) {
  if (!object.contains(key)) return std::numeric_limits<double>::quiet_NaN();
  const json& v = object.at(key);
  if (!v.is_number() || !(v.get<double>() > 0)) throw Invalid{where + "." + key + ": expected a number > 0, got " + v.dump()};
  return v.get<double>();
}

const json& array(const json& object, const std::string& where, const std::string& key, bool non_empty) {
  static const json kEmpty = json::array();
  if (!object.contains(key)) {
    if (non_empty) throw Invalid{where + "." + key + ": missing (a non-empty array is required)"};
    return kEmpty;
  }
  const json& v = object.at(key);
  if (!v.is_array() || (non_empty && v.empty())) {
    throw Invalid{where + "." + key + ": expected a" + std::string(non_empty ? " non-empty" : "n") + " array, got " +
                  v.dump()};
  }
  return v;
}

std::vector<RowSelector> selectors(const json& list, const std::string& where) {
  std::vector<RowSelector> out;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string at = where + "[" + std::to_string(i) + "]";
    only_keys(list[i], at, {"source", "quantity", "load_uN", "velocity_um_per_s"});
    RowSelector s;
    s.source = text(list[i], at, "source", true);  // without it a selector would take every row
    s.quantity = text(list[i], at, "quantity", false);
    s.load_uN = positive(list[i], at, "load_uN");
    s.velocity_um_per_s = positive(list[i], at, "velocity_um_per_s");
    out.push_back(s);
  }
  return out;
}

bool same(double stated, double value) { return std::abs(stated - value) <= 1e-9 * std::abs(stated); }

std::vector<Split> parse(const json& doc) {
  only_keys(doc, "splits file", {"about", "calibration", "splits"});
  std::vector<RowSelector> calibration;
  if (doc.contains("calibration")) {
    only_keys(doc["calibration"], "calibration", {"about", "rows"});
    calibration = selectors(array(doc["calibration"], "calibration", "rows", true), "calibration.rows");
  }
  const json& list = array(doc, "splits file", "splits", true);
  std::vector<Split> out;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string at = "splits[" + std::to_string(i) + "]";
    only_keys(list[i], at, {"name", "about", "config", "refit", "fitted", "fixed", "fit_rows"});
    Split s;
    s.name = text(list[i], at, "name", true);
    if (find_split(out, s.name)) throw Invalid{at + ".name: \"" + s.name + "\" is declared twice"};
    s.config = text(list[i], at, "config", true);
    if (list[i].contains("refit") && !list[i]["refit"].is_boolean()) {
      throw Invalid{at + ".refit: expected true or false, got " + list[i]["refit"].dump()};
    }
    for (const json& f : array(list[i], at, "fitted", false)) {
      if (!f.is_string()) throw Invalid{at + ".fitted: expected parameter group names, got " + f.dump()};
    }
    const json& fixed = array(list[i], at, "fixed", false);
    for (std::size_t k = 0; k < fixed.size(); ++k) {
      const std::string fat = at + ".fixed[" + std::to_string(k) + "]";
      only_keys(fixed[k], fat, {"field", "value", "why"});
      text(fixed[k], fat, "field", true);
      text(fixed[k], fat, "value", true);
      text(fixed[k], fat, "why", true);
    }
    s.fit_rows = calibration;
    for (const RowSelector& r : selectors(array(list[i], at, "fit_rows", true), at + ".fit_rows")) s.fit_rows.push_back(r);
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace

bool selects(const RowSelector& s, const Row& row) {
  if (s.source != row.group) return false;
  if (!s.quantity.empty() && s.quantity != row.quantity) return false;
  if (std::isfinite(s.load_uN) && !same(s.load_uN, row.load_n * 1e6)) return false;
  if (std::isfinite(s.velocity_um_per_s) && !same(s.velocity_um_per_s, row.velocity_m_per_s * 1e6)) return false;
  return true;
}

std::variant<std::vector<Split>, std::string> load_splits(const std::string& path) {
  std::ifstream in(path);
  if (!in) return path + ": cannot be read";
  std::stringstream buffer;
  buffer << in.rdbuf();
  try {
    return parse(json::parse(buffer.str()));
  } catch (const json::parse_error& e) {
    return path + ": not JSON: " + e.what();
  } catch (const Invalid& e) {
    return path + ": " + e.message;
  }
}

const Split* find_split(const std::vector<Split>& splits, const std::string& name) {
  const auto it = std::find_if(splits.begin(), splits.end(), [&](const Split& s) { return s.name == name; });
  return it == splits.end() ? nullptr : &*it;
}

void assign_roles(std::vector<Row>& rows, const Split& split) {
  for (Row& row : rows) {
    const bool fit = std::any_of(split.fit_rows.begin(), split.fit_rows.end(),
                                 [&](const RowSelector& s) { return selects(s, row); });
    row.role = fit ? Role::fit : Role::predicted;
  }
}

}  // namespace tribo::scorecard
