// One recorded sample and its channels: the single definition that the
// recorder's CSV, the wire's SampleBlock and the clients share. SI units.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

#include "tribo/v1/api.pb.h"

namespace tribo {

struct Sample {
  double time_s = 0;
  std::uint32_t segment_index = 0;
  double normal_setpoint_n = 0;
  double normal_force_n = 0;
  double normal_displacement_m = 0;
  double lateral_setpoint_m = 0;
  double lateral_position_m = 0;
  double lateral_force_n = 0;
  std::uint32_t status_flags = 0;  // tribo.v1.StatusFlag bits

  bool operator==(const Sample&) const = default;
};

struct ChannelInfo {
  std::string_view name;
  std::string_view unit;
  std::string_view description;
  std::string_view block_field;  // the tribo.v1.SampleBlock field carrying it
};

// Channel order of the CSV columns (column name: name + "_" + unit).
inline constexpr std::array<ChannelInfo, 9> kSampleChannels{{
    {"t", "s", "time since run start", "time_s"},
    {"segment", "index", "protocol segment being executed (0-based)", "segment_index"},
    {"normal_setpoint", "N", "commanded normal force", "normal_setpoint_n"},
    {"normal_force", "N", "measured normal (contact) force", "normal_force_n"},
    {"normal_displacement", "m", "measured normal displacement", "normal_displacement_m"},
    {"lateral_setpoint", "m", "commanded lateral position", "lateral_setpoint_m"},
    {"lateral_position", "m", "measured lateral position", "lateral_position_m"},
    {"lateral_force", "N", "measured lateral force (drive minus spring)", "lateral_force_n"},
    {"flags", "bits", "tribo.v1.StatusFlag bits", "status_flags"},
}};

void append_sample(const Sample& s, v1::SampleBlock& block);
Sample sample_at(const v1::SampleBlock& block, int index);
int sample_count(const v1::SampleBlock& block);
// The channel table as the run descriptor carries it.
void describe_channels(v1::RunDescriptor& descriptor);
// Appends the samples of src to dst (dst keeps its first_sequence and run_id).
void append_block(const v1::SampleBlock& src, v1::SampleBlock& dst);

// CSV: a header line, then one row per sample; numbers use the shortest text
// that reads back to the identical double, so a file round-trips exactly.
std::string csv_header();
void append_csv_row(const Sample& s, std::string& out);
// Parses one data row (no newline). Returns false on any malformed field.
bool parse_csv_row(std::string_view row, Sample& s);

}  // namespace tribo
