// Reading a MeasuredSeries: from any CSV with a header line and a column
// mapping (columns named by their header), or from a tribo run directory
// (proto/run_files.h). Values are taken as SI units; nothing is rescaled
// except by force_scale (e.g. -1 when the force column has the opposite sign
// convention: the analysis wants the force that drives the motion, positive
// in the direction of positive velocity).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "analysis/input/measured_series.h"
#include "proto/sample_record.h"

namespace tribo::analysis {

struct ColumnMapping {
  std::string time;          // required
  std::string position;      // required
  std::string force;         // required
  std::string normal;        // optional
  std::string velocity;      // optional (else derived from the position)
  std::string acceleration;  // optional (else derived from the velocity)
  std::string reference;     // optional (commanded position)
  double force_scale = 1.0;
  std::string force_unit = "N";
};

// The named columns of a CSV file with a header line (an empty name gives an
// empty column). Errors name the file, the row and the column.
std::optional<std::vector<std::vector<double>>> read_csv_columns(const std::filesystem::path& path,
                                                                 const std::vector<std::string>& names,
                                                                 std::string& error);

std::optional<MeasuredSeries> read_csv_series(const std::filesystem::path& path,
                                              const ColumnMapping& columns, std::string& error);

// Why a CSV record cannot be what its column mapping says, or empty when
// it may be: judged from the record itself, on the whole file, before any
// fit (docs/tribo_fit.md, "Input refused before fitting"). The reason names
// the column, the value and the likely cause (a wrong column, a unit).
//  - time that does not increase;
//  - a force, position or normal column with one value in every row;
//  - the force holding the same values as another column, or the time as
//    the position;
//  - with a normal column: the force's typical size over the normal load's
//    (medians over the loaded rows, above 10 % of the largest load) outside
//    a friction coefficient's range, kMinFrictionCoefficient to
//    kMaxFrictionCoefficient;
//  - with a velocity column: the distance it integrates to differs from the
//    position's span by more than kMaxVelocitySpanRatio either way (a unit
//    prefix is a factor 1000).
inline constexpr double kMinFrictionCoefficient = 1e-4;
inline constexpr double kMaxFrictionCoefficient = 10;
inline constexpr double kMaxVelocitySpanRatio = 100;
std::string implausible_csv_series(const MeasuredSeries& series, const ColumnMapping& columns);

// Recorded tribo samples (a run directory's, or a closed loop's in-process):
// time, lateral position, lateral force, normal force, lateral setpoint as
// reference, segment index. Samples taken while unloading after a stop or
// trip (SAFE_UNLOAD) are dropped.
MeasuredSeries series_from_samples(const std::vector<Sample>& samples, const std::string& source);

// A recorded tribo run: time, lateral position, lateral force, normal force,
// lateral setpoint as reference, segment index. Samples taken while unloading
// after a stop or trip (SAFE_UNLOAD) are dropped.
std::optional<MeasuredSeries> read_run_series(const std::filesystem::path& run_dir, std::string& error);

}  // namespace tribo::analysis
