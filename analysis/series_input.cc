#include "analysis/series_input.h"

#include <charconv>
#include <fstream>
#include <vector>

#include "proto/run_files.h"
#include "proto/sample_record.h"

namespace tribo::analysis {

namespace {

std::vector<std::string_view> split_fields(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    fields.push_back(line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  for (auto& f : fields) {
    while (!f.empty() && (f.front() == ' ' || f.front() == '"')) f.remove_prefix(1);
    while (!f.empty() && (f.back() == ' ' || f.back() == '"' || f.back() == '\r')) f.remove_suffix(1);
  }
  return fields;
}

bool parse_double(std::string_view text, double& value) {
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  return ec == std::errc() && end == text.data() + text.size();
}

}  // namespace

std::optional<std::vector<std::vector<double>>> read_csv_columns(const std::filesystem::path& path,
                                                                 const std::vector<std::string>& names,
                                                                 std::string& error) {
  std::ifstream in(path);
  if (!in) {
    error = "cannot read " + path.string();
    return std::nullopt;
  }
  std::string header;
  if (!std::getline(in, header)) {
    error = path.string() + " is empty";
    return std::nullopt;
  }
  const auto fields_of_header = split_fields(header);
  std::vector<int> index(names.size(), -1);
  for (std::size_t k = 0; k < names.size(); ++k) {
    if (names[k].empty()) continue;
    for (std::size_t i = 0; i < fields_of_header.size(); ++i) {
      if (fields_of_header[i] == names[k]) index[k] = static_cast<int>(i);
    }
    if (index[k] < 0) {
      error = "column '" + names[k] + "' not in the header of " + path.string() + " (" + header + ")";
      return std::nullopt;
    }
  }
  std::vector<std::vector<double>> columns(names.size());
  std::string line;
  std::size_t row = 1;
  while (std::getline(in, line)) {
    ++row;
    if (line.empty() || line == "\r") continue;
    const auto fields = split_fields(line);
    for (std::size_t k = 0; k < names.size(); ++k) {
      if (index[k] < 0) continue;
      double value = 0;
      const auto col = static_cast<std::size_t>(index[k]);
      if (col >= fields.size() || !parse_double(fields[col], value)) {
        error = path.string() + ":" + std::to_string(row) + ": column '" + names[k] + "' is not a number";
        return std::nullopt;
      }
      columns[k].push_back(value);
    }
  }
  return columns;
}

std::optional<MeasuredSeries> read_csv_series(const std::filesystem::path& path,
                                              const ColumnMapping& c, std::string& error) {
  if (c.time.empty() || c.position.empty() || c.force.empty()) {
    error = "a time, position and force column must be given";
    return std::nullopt;
  }
  auto columns = read_csv_columns(path, {c.time, c.position, c.force, c.normal, c.velocity, c.acceleration, c.reference}, error);
  if (!columns) return std::nullopt;
  MeasuredSeries s;
  s.source = path.string();
  s.force_unit = c.force_unit;
  s.time_s = std::move((*columns)[0]);
  s.position_m = std::move((*columns)[1]);
  s.force_n = std::move((*columns)[2]);
  s.normal_force_n = std::move((*columns)[3]);
  s.velocity_m_per_s = std::move((*columns)[4]);
  s.acceleration_m_per_s2 = std::move((*columns)[5]);
  s.reference_m = std::move((*columns)[6]);
  for (double& f : s.force_n) f *= c.force_scale;
  s.velocity_measured = !s.velocity_m_per_s.empty();
  s.acceleration_measured = !s.acceleration_m_per_s2.empty();
  return s;
}

MeasuredSeries series_from_samples(const std::vector<Sample>& samples, const std::string& source) {
  MeasuredSeries s;
  s.source = source;
  for (const Sample& sample : samples) {
    if (sample.status_flags & v1::SAFE_UNLOAD) continue;
    s.time_s.push_back(sample.time_s);
    s.position_m.push_back(sample.lateral_position_m);
    s.force_n.push_back(sample.lateral_force_n);
    s.normal_force_n.push_back(sample.normal_force_n);
    s.reference_m.push_back(sample.lateral_setpoint_m);
    s.segment.push_back(sample.segment_index);
  }
  return s;
}

std::optional<MeasuredSeries> read_run_series(const std::filesystem::path& run_dir, std::string& error) {
  const auto run = wire::read_run_directory(run_dir, error);
  if (!run) return std::nullopt;
  const int n = sample_count(run->samples);
  std::vector<Sample> samples;
  samples.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) samples.push_back(sample_at(run->samples, i));
  return series_from_samples(samples, run_dir.string());
}

}  // namespace tribo::analysis
