// The scorecard's splits (scorecard/splits.json): for each configuration
// fitted to the dissertation's measurements, the rows it was fitted (or set)
// on. Every other row is a prediction. scorecard/fit_contact.py fits a
// split's parameters on its fit rows only and writes the split's config;
// tribo-scorecard --split NAME scores that config with each row's role.
#pragma once

#include <limits>
#include <string>
#include <variant>
#include <vector>

#include "scorecard/scorecard.h"

namespace tribo::scorecard {

// Selects rows by the fields it states: source (Row::group), quantity, load
// and velocity (µN, µm/s). A row without a load (or velocity) is not selected
// by a selector that states one.
struct RowSelector {
  std::string source, quantity;
  double load_uN = std::numeric_limits<double>::quiet_NaN();
  double velocity_um_per_s = std::numeric_limits<double>::quiet_NaN();
};

bool selects(const RowSelector& selector, const Row& row);

struct Split {
  std::string name;
  std::string config;  // the split's fitted config, relative to the repository root
  std::vector<RowSelector> fit_rows;  // the file's calibration rows, then the split's own
};

// The file's splits, or an error that names the field, the value and what
// was expected.
std::variant<std::vector<Split>, std::string> load_splits(const std::string& path);

// The split named `name`, or nullptr.
const Split* find_split(const std::vector<Split>& splits, const std::string& name);

// Marks every row fit (selected by one of the split's fit selectors) or predicted.
void assign_roles(std::vector<Row>& rows, const Split& split);

}  // namespace tribo::scorecard
