#include "proto/sample_record.h"

#include <charconv>
#include <system_error>

namespace tribo {

void append_sample(const Sample& s, v1::SampleBlock& block) {
  block.add_time_s(s.time_s);
  block.add_segment_index(s.segment_index);
  block.add_normal_setpoint_n(s.normal_setpoint_n);
  block.add_normal_force_n(s.normal_force_n);
  block.add_normal_displacement_m(s.normal_displacement_m);
  block.add_lateral_setpoint_m(s.lateral_setpoint_m);
  block.add_lateral_position_m(s.lateral_position_m);
  block.add_lateral_force_n(s.lateral_force_n);
  block.add_status_flags(s.status_flags);
}

Sample sample_at(const v1::SampleBlock& b, int i) {
  return Sample{b.time_s(i),
                b.segment_index(i),
                b.normal_setpoint_n(i),
                b.normal_force_n(i),
                b.normal_displacement_m(i),
                b.lateral_setpoint_m(i),
                b.lateral_position_m(i),
                b.lateral_force_n(i),
                b.status_flags(i)};
}

int sample_count(const v1::SampleBlock& block) { return block.time_s_size(); }

void append_block(const v1::SampleBlock& src, v1::SampleBlock& dst) {
  dst.mutable_time_s()->MergeFrom(src.time_s());
  dst.mutable_segment_index()->MergeFrom(src.segment_index());
  dst.mutable_normal_setpoint_n()->MergeFrom(src.normal_setpoint_n());
  dst.mutable_normal_force_n()->MergeFrom(src.normal_force_n());
  dst.mutable_normal_displacement_m()->MergeFrom(src.normal_displacement_m());
  dst.mutable_lateral_setpoint_m()->MergeFrom(src.lateral_setpoint_m());
  dst.mutable_lateral_position_m()->MergeFrom(src.lateral_position_m());
  dst.mutable_lateral_force_n()->MergeFrom(src.lateral_force_n());
  dst.mutable_status_flags()->MergeFrom(src.status_flags());
}

void describe_channels(v1::RunDescriptor& descriptor) {
  for (const ChannelInfo& c : kSampleChannels) {
    v1::Channel* out = descriptor.add_channels();
    out->set_name(std::string(c.name));
    out->set_unit(std::string(c.unit));
    out->set_description(std::string(c.description));
    out->set_block_field(std::string(c.block_field));
  }
}

std::string csv_header() {
  std::string header;
  for (const ChannelInfo& c : kSampleChannels) {
    if (!header.empty()) header += ',';
    header.append(c.name).append("_").append(c.unit);
  }
  return header + '\n';
}

namespace {

template <typename T>
void put(T value, char sep, std::string& out) {
  char buf[32];
  const auto result = std::to_chars(buf, buf + sizeof buf, value);
  out.append(buf, result.ptr);
  out.push_back(sep);
}

template <typename T>
bool take(std::string_view& row, T& value, bool last) {
  const std::size_t end = last ? row.size() : row.find(',');
  if (end == std::string_view::npos) return false;
  const auto field = row.substr(0, end);
  const auto result = std::from_chars(field.data(), field.data() + field.size(), value);
  if (result.ec != std::errc() || result.ptr != field.data() + field.size()) return false;
  row.remove_prefix(last ? end : end + 1);
  return true;
}

}  // namespace

void append_csv_row(const Sample& s, std::string& out) {
  put(s.time_s, ',', out);
  put(s.segment_index, ',', out);
  put(s.normal_setpoint_n, ',', out);
  put(s.normal_force_n, ',', out);
  put(s.normal_displacement_m, ',', out);
  put(s.lateral_setpoint_m, ',', out);
  put(s.lateral_position_m, ',', out);
  put(s.lateral_force_n, ',', out);
  put(s.status_flags, '\n', out);
}

bool parse_csv_row(std::string_view row, Sample& s) {
  return take(row, s.time_s, false) && take(row, s.segment_index, false) &&
         take(row, s.normal_setpoint_n, false) && take(row, s.normal_force_n, false) &&
         take(row, s.normal_displacement_m, false) && take(row, s.lateral_setpoint_m, false) &&
         take(row, s.lateral_position_m, false) && take(row, s.lateral_force_n, false) &&
         take(row, s.status_flags, true) && row.empty();
}

}  // namespace tribo
