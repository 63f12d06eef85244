#include "client/friction_model_files.h"

#include "proto/text_format_file.h"

namespace tribo::client {

namespace {

std::optional<std::string> read_report(v1::FrictionCompensation& c, const std::filesystem::path& dir,
                                       const std::string& field) {
  if (c.report_file().empty() || !c.report_json().empty()) return std::nullopt;
  const std::filesystem::path file(c.report_file());
  const std::filesystem::path path = file.is_absolute() ? file : dir / file;
  auto text = wire::read_file(path.string());
  if (!text) return field + ".report_file: cannot read the friction model report " + path.string();
  c.set_report_json(std::move(*text));
  return std::nullopt;
}

std::optional<std::string> read_segments(google::protobuf::RepeatedPtrField<v1::Segment>& segments,
                                         const std::filesystem::path& dir, const std::string& prefix) {
  for (int i = 0; i < segments.size(); ++i) {
    const std::string at = prefix + "segments[" + std::to_string(i) + "]";
    v1::Segment& s = segments[i];
    if (s.has_friction_compensation()) {
      if (auto e = read_report(*s.mutable_friction_compensation(), dir, at + ".friction_compensation")) return e;
    }
    if (s.has_repeat()) {
      if (auto e = read_segments(*s.mutable_repeat()->mutable_segments(), dir, at + ".repeat.")) return e;
    }
  }
  return std::nullopt;
}

}  // namespace

std::optional<std::string> read_friction_reports(v1::Protocol& protocol, const std::filesystem::path& protocol_dir) {
  if (protocol.has_friction_compensation()) {
    if (auto e = read_report(*protocol.mutable_friction_compensation(), protocol_dir, "friction_compensation")) return e;
  }
  return read_segments(*protocol.mutable_segments(), protocol_dir, "");
}

std::optional<std::string> set_friction_model(v1::Protocol& protocol, const std::string& report_path) {
  auto text = wire::read_file(report_path);
  if (!text) return "--friction-model: cannot read " + report_path;
  v1::FrictionCompensation& c = *protocol.mutable_friction_compensation();
  c.Clear();
  c.set_report_file(report_path);
  c.set_report_json(std::move(*text));
  return std::nullopt;
}

}  // namespace tribo::client
