// The diagnosis as the tribo-fit command reports it: one JSON object (its
// field names are a contract for scripts, see docs/tribo_fit.md), a short
// human-readable text, and the CSV files the plotting script reads
// (analysis/plot_diagnosis.py).
#pragma once

#include <filesystem>
#include <string>

#include "analysis/diagnosis.h"
#include "analysis/input/measured_series.h"

namespace tribo::analysis {

struct ReportInfo {
  std::string command_line;
  double elapsed_s = 0;
};

std::string diagnosis_json(const MeasuredSeries& series, const Diagnosis& d, const ReportInfo& info);
std::string diagnosis_text(const MeasuredSeries& series, const Diagnosis& d);
// The text report's line for an effect's minimum detectable strength.
std::string minimum_detectable_text(const DetectableStrength& m);

// An accepted effect against its nearest rival, in words ("distinguishable
// from its nearest rival rate_state at z = 5.2 ...").
std::string confusion_text(const EffectConfusion& c);

// dir/traces.csv: t_s, position_m, velocity_m_per_s, force, model_before, model_after, heldout, direction,
//                 distance_since_start_m
// dir/signatures.csv: effect, stage (accepted | rejected), x_label, y_label, x, y, y_error
bool write_diagnosis_files(const std::filesystem::path& dir, const MeasuredSeries& series, const Diagnosis& d,
                           const std::string& json, std::string& error);

}  // namespace tribo::analysis
