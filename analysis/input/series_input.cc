#include "analysis/input/series_input.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <vector>

#include <fmt/format.h>

#include "proto/run_files.h"
#include "proto/sample_record.h"

namespace tribo::analysis {

namespace {

// The comma-separated fields of a line into fields (reused from line to
// line: no allocation per row), trimmed of spaces, quotes and a carriage return.
void split_fields(std::string_view line, std::vector<std::string_view>& fields) {
  fields.clear();
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
}

std::vector<std::string_view> split_fields(std::string_view line) {
  std::vector<std::string_view> fields;
  split_fields(line, fields);
  return fields;
}

// Lines after the header (an upper bound on the data rows): the columns are
// sized once, not grown by doubling as they are read (up to twice the
// record's size while a column moves).
std::size_t count_data_lines(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<char> chunk(1 << 16);
  std::size_t lines = 0;
  char last = '\n';
  while (in.read(chunk.data(), static_cast<std::streamsize>(chunk.size())) || in.gcount() > 0) {
    const auto got = static_cast<std::size_t>(in.gcount());
    lines += static_cast<std::size_t>(std::count(chunk.data(), chunk.data() + got, '\n'));
    last = chunk[got - 1];
  }
  if (last != '\n') ++lines;  // a last line without its newline
  return lines > 0 ? lines - 1 : 0;
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
  const std::size_t rows = count_data_lines(path);
  for (std::size_t k = 0; k < names.size(); ++k) {
    if (index[k] >= 0) columns[k].reserve(rows);
  }
  std::string line;
  std::vector<std::string_view> fields;
  std::size_t row = 1;
  while (std::getline(in, line)) {
    ++row;
    if (line.empty() || line == "\r") continue;
    split_fields(line, fields);
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

namespace {

struct NamedColumn {
  const char* role;         // "force", "position", ...
  const std::string* name;  // the CSV header's
  const std::vector<double>* values;
};

bool all_finite(const std::vector<double>& v) {
  return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  const auto middle = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), middle, v.end());
  return *middle;
}

// A factor between two quantities as the power of ten nearest to it.
std::string order_of(double ratio) { return fmt::format("1e{:.0f}", std::round(std::log10(ratio))); }

std::string constant_column(const NamedColumn& c) {
  const auto& v = *c.values;
  if (v.empty() || std::any_of(v.begin(), v.end(), [&](double x) { return x != v.front(); })) return {};
  return fmt::format("{} column '{}' has the same value, {:g}, in every row: an empty channel, or the wrong column",
                     c.role, *c.name, v.front());
}

std::string identical_columns(const NamedColumn& a, const NamedColumn& b) {
  if (a.values->empty() || *a.values != *b.values) return {};
  return fmt::format("{} column '{}' holds the same values as {} column '{}' in every row: the same column given twice?",
                     a.role, *a.name, b.role, *b.name);
}

std::string friction_over_load(const MeasuredSeries& s, const ColumnMapping& c) {
  double largest = 0;
  for (double n : s.normal_force_n) largest = std::max(largest, std::abs(n));
  std::vector<double> force, load;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (std::abs(s.normal_force_n[i]) > 0.1 * largest) {
      force.push_back(std::abs(s.force_n[i]));
      load.push_back(std::abs(s.normal_force_n[i]));
    }
  }
  const double mu = median_of(force) / median_of(load);
  if (mu >= kMinFrictionCoefficient && mu <= kMaxFrictionCoefficient) return {};
  return fmt::format("the force column '{}' is typically {:.3g} times the normal column '{}' (medians over the "
                     "loaded rows: {:.3g} against {:.3g}), not a friction coefficient ({:g} to {:g}): the two "
                     "columns in different units (e.g. one in µN, the other in N), or the wrong column",
                     c.force, mu, c.normal, median_of(force), median_of(load), kMinFrictionCoefficient,
                     kMaxFrictionCoefficient);
}

std::string velocity_against_position(const MeasuredSeries& s, const ColumnMapping& c) {
  double distance = 0, lowest = 0, highest = 0;
  for (std::size_t i = 1; i < s.size(); ++i) {
    distance += 0.5 * (s.velocity_m_per_s[i] + s.velocity_m_per_s[i - 1]) * (s.time_s[i] - s.time_s[i - 1]);
    lowest = std::min(lowest, distance);
    highest = std::max(highest, distance);
  }
  const auto [xmin, xmax] = std::minmax_element(s.position_m.begin(), s.position_m.end());
  const double integrated = highest - lowest, span = *xmax - *xmin;
  if (!(span > 0) || !(integrated > 0)) return {};
  const double ratio = integrated / span;
  if (ratio <= kMaxVelocitySpanRatio && ratio >= 1 / kMaxVelocitySpanRatio) return {};
  return fmt::format("the velocity column '{}' integrates to a span of {:.3g} m where the position column '{}' spans "
                     "{:.3g} m ({:.3g} times): a unit (about {}: e.g. a position in µm given as m, or a velocity in "
                     "mm/s), or the wrong column",
                     c.velocity, integrated, c.position, span, ratio, order_of(ratio));
}

// One recorded sample into the series' columns, unless it was taken while
// unloading after a stop or trip.
void append_to_series(const Sample& sample, MeasuredSeries& s) {
  if (sample.status_flags & v1::SAFE_UNLOAD) return;
  s.time_s.push_back(sample.time_s);
  s.position_m.push_back(sample.lateral_position_m);
  s.force_n.push_back(sample.lateral_force_n);
  s.normal_force_n.push_back(sample.normal_force_n);
  s.reference_m.push_back(sample.lateral_setpoint_m);
  s.segment.push_back(sample.segment_index);
}

void reserve_columns(MeasuredSeries& s, std::size_t n) {
  s.time_s.reserve(n);
  s.position_m.reserve(n);
  s.force_n.reserve(n);
  s.normal_force_n.reserve(n);
  s.reference_m.reserve(n);
  s.segment.reserve(n);
}

}  // namespace

std::string implausible_csv_series(const MeasuredSeries& s, const ColumnMapping& c) {
  const std::vector<const std::vector<double>*> all = {&s.time_s, &s.position_m, &s.force_n, &s.normal_force_n,
                                                       &s.velocity_m_per_s};
  for (const auto* v : all) {
    if (!v->empty() && (v->size() != s.size() || !all_finite(*v))) return {};  // check_series says what is wrong
  }
  for (std::size_t i = 1; i < s.size(); ++i) {
    if (!(s.time_s[i] > s.time_s[i - 1])) {
      return fmt::format("the time column '{}' does not increase at sample {} ({:g} after {:g}): the wrong column, "
                         "or rows out of order",
                         c.time, i + 1, s.time_s[i], s.time_s[i - 1]);
    }
  }
  const NamedColumn time{"time", &c.time, &s.time_s}, position{"position", &c.position, &s.position_m},
      force{"force", &c.force, &s.force_n}, normal{"normal", &c.normal, &s.normal_force_n},
      velocity{"velocity", &c.velocity, &s.velocity_m_per_s};
  for (const auto& column : {force, position, normal}) {
    if (auto why = constant_column(column); !why.empty()) return why;
  }
  for (const auto& other : {time, position, normal, velocity}) {
    if (auto why = identical_columns(force, other); !why.empty()) return why;
  }
  if (auto why = identical_columns(position, time); !why.empty()) return why;
  if (s.has_normal()) {
    if (auto why = friction_over_load(s, c); !why.empty()) return why;
  }
  if (!s.velocity_m_per_s.empty()) return velocity_against_position(s, c);
  return {};
}

MeasuredSeries series_from_samples(const std::vector<Sample>& samples, const std::string& source) {
  MeasuredSeries s;
  s.source = source;
  reserve_columns(s, samples.size());
  for (const Sample& sample : samples) append_to_series(sample, s);
  return s;
}

std::optional<MeasuredSeries> read_run_series(const std::filesystem::path& run_dir, std::string& error) {
  if (!wire::read_run_metadata(run_dir, error)) return std::nullopt;
  // Page by page into columns sized once: the whole record as a SampleBlock,
  // then as samples, then as the series took three copies of it at once.
  constexpr std::uint64_t kPage = 1 << 16;
  MeasuredSeries s;
  s.source = run_dir.string();
  reserve_columns(s, static_cast<std::size_t>(wire::count_recorded_samples(run_dir)));
  wire::RowIndex index;  // each page starts where the last one ended
  v1::SampleBlock page;
  for (std::uint64_t from = 0;; from += kPage) {
    page.Clear();
    wire::RowsRead read;
    if (!wire::read_sample_rows(run_dir, wire::SampleRange{from, kPage}, page, read, error, &index)) return std::nullopt;
    const int n = sample_count(page);
    for (int i = 0; i < n; ++i) append_to_series(sample_at(page, i), s);
    if (read.end_of_file) break;
  }
  return s;
}

}  // namespace tribo::analysis
