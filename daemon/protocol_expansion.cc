#include "daemon/protocol_expansion.h"

namespace tribo::daemon {

namespace {

constexpr std::uint32_t kMaxRepeatCount = 100000;

struct Pass {
  bool inside_repeat = false;
  std::uint32_t index = 0;
  std::uint32_t count = 1;
  bool mirrored = false;     // lateral motion negated on this pass
  bool first = true;         // first pass of every enclosing block: report errors once
  std::string suffix;        // " (pass 2/6)", nested: " (pass 1/5, 2/6)"
  std::string passes;        // "2/6", nested: "1/5, 2/6"
};

std::string quoted_name(const v1::Segment& s) {
  return s.name().empty() ? "" : " \"" + s.name() + "\"";
}

class Expander {
 public:
  explicit Expander(std::size_t max_segments) : max_segments_(max_segments) {}

  void expand_list(const google::protobuf::RepeatedPtrField<v1::Segment>& list,
                   const std::string& prefix, const Pass& pass) {
    for (int i = 0; i < list.size() && !too_many_; ++i) {
      const std::string path = prefix + "segments[" + std::to_string(i) + "]";
      if (list[i].has_repeat()) {
        expand_repeat(list[i], path, pass);
      } else {
        add_segment(list[i], path, pass);
      }
    }
  }

  Expansion result;

 private:
  void error(const Pass& pass, std::string field, std::string message) {
    if (pass.first) result.errors.push_back({std::move(field), std::move(message), "", ""});
  }
  void expand_repeat(const v1::Segment& block, const std::string& path, const Pass& outer);
  void add_segment(const v1::Segment& seg, const std::string& path, const Pass& pass);
  void apply_pass_values(v1::Segment& seg, const std::string& path, const std::string& label,
                         const Pass& pass);

  std::size_t max_segments_;
  bool too_many_ = false;
};

void Expander::expand_repeat(const v1::Segment& block, const std::string& path,
                             const Pass& outer) {
  const std::string label = path + quoted_name(block);
  if (block.duration_s() != 0 || block.has_normal() || block.has_lateral() ||
      block.has_per_pass() || block.acquisition_rate_hz() != 0) {
    error(outer, path, label + ": a repeat block holds only a name and its repeat (put duration, "
                              "axes, rates and per_pass into its segments)");
  }
  const v1::Repeat& r = block.repeat();
  if (r.count() < 1 || r.count() > kMaxRepeatCount) {
    error(outer, path + ".repeat.count",
          label + ": repeat.count = " + std::to_string(r.count()) + " must be in [1, " +
              std::to_string(kMaxRepeatCount) + "]");
    return;
  }
  if (r.segments_size() == 0) {
    error(outer, path + ".repeat.segments", label + ": the repeat block has no segments");
    return;
  }
  for (std::uint32_t p = 0; p < r.count() && !too_many_; ++p) {
    Pass pass;
    pass.inside_repeat = true;
    pass.index = p;
    pass.count = r.count();
    pass.mirrored = outer.mirrored != (r.alternate_direction() && p % 2 == 1);
    pass.first = outer.first && p == 0;
    const std::string here = std::to_string(p + 1) + "/" + std::to_string(r.count());
    pass.passes = outer.passes.empty() ? here : outer.passes + ", " + here;
    pass.suffix = " (pass " + pass.passes + ")";
    expand_list(r.segments(), path + ".repeat.", pass);
  }
}

// Replaces the segment's fields by the pass's entries of its per_pass lists.
void Expander::apply_pass_values(v1::Segment& seg, const std::string& path,
                                 const std::string& label, const Pass& pass) {
  const v1::PassValues& v = seg.per_pass();
  struct List {
    const char* name;
    const google::protobuf::RepeatedField<double>& values;
  };
  const List lists[] = {{"duration_s", v.duration_s()},
                        {"normal_end_uN", v.normal_end_un()},
                        {"lateral_speed_um_per_s", v.lateral_speed_um_per_s()},
                        {"lateral_end_um", v.lateral_end_um()},
                        {"sine_amplitude_um", v.sine_amplitude_um()},
                        {"sine_amplitude_uN", v.sine_amplitude_un()},
                        {"lateral_delta_um", v.lateral_delta_um()}};
  bool ok = true;
  for (const List& l : lists) {
    if (l.values.empty()) continue;
    if (!pass.inside_repeat) {
      error(pass, path + ".per_pass." + l.name,
            label + ": per_pass." + l.name + " is only meaningful inside a repeat block");
      ok = false;
    } else if (static_cast<std::uint32_t>(l.values.size()) != pass.count) {
      error(pass, path + ".per_pass." + l.name,
            label + ": per_pass." + l.name + " has " + std::to_string(l.values.size()) +
                " values; the enclosing repeat has count " + std::to_string(pass.count));
      ok = false;
    }
  }
  if (!ok) return;
  const int p = static_cast<int>(pass.index);
  if (!v.duration_s().empty()) seg.set_duration_s(v.duration_s(p));
  if (!v.normal_end_un().empty()) seg.mutable_normal()->set_end_un(v.normal_end_un(p));
  if (!v.lateral_speed_um_per_s().empty())
    seg.mutable_lateral()->set_speed_um_per_s(v.lateral_speed_um_per_s(p));
  if (!v.lateral_end_um().empty()) seg.mutable_lateral()->set_end_um(v.lateral_end_um(p));
  if (!v.sine_amplitude_um().empty())
    seg.mutable_lateral()->mutable_sine()->set_amplitude_um(v.sine_amplitude_um(p));
  if (!v.sine_amplitude_un().empty())
    seg.mutable_lateral()->mutable_sine()->set_amplitude_un(v.sine_amplitude_un(p));
  if (!v.lateral_delta_um().empty()) seg.mutable_lateral()->set_delta_um(v.lateral_delta_um(p));
}

void Expander::add_segment(const v1::Segment& definition, const std::string& path,
                           const Pass& pass) {
  if (result.segments.size() >= max_segments_) {
    result.errors.push_back({"segments", "the protocol unrolls to more than " +
                                             std::to_string(max_segments_) + " segments", "", ""});
    too_many_ = true;
    return;
  }
  ExpandedSegment out;
  out.segment = definition;
  out.path = path;
  out.subject = path + quoted_name(definition);
  out.pass = pass.passes;
  out.label = out.subject + pass.suffix;
  out.name = definition.name().empty() && !pass.suffix.empty() ? pass.suffix.substr(1) : definition.name() + pass.suffix;
  v1::Segment& seg = out.segment;
  apply_pass_values(seg, path, out.label, pass);
  seg.clear_per_pass();
  if (pass.mirrored) {
    v1::LateralAxisCommand& l = *seg.mutable_lateral();
    if (l.has_delta_um()) l.set_delta_um(-l.delta_um());
    if (l.has_delta_un()) l.set_delta_un(-l.delta_un());
    if (l.has_velocity()) {
      v1::VelocityProfile& v = *l.mutable_velocity();
      v.set_begin_um_per_s(-v.begin_um_per_s());
      v.set_end_um_per_s(-v.end_um_per_s());
      v.set_begin_un_per_s(-v.begin_un_per_s());
      v.set_end_un_per_s(-v.end_un_per_s());
    }
    if (l.has_sine()) {
      v1::SineWave& s = *l.mutable_sine();
      s.set_amplitude_um(-s.amplitude_um());
      s.set_amplitude_un(-s.amplitude_un());
      if (s.has_end_amplitude_um()) s.set_end_amplitude_um(-s.end_amplitude_um());
      if (s.has_end_amplitude_un()) s.set_end_amplitude_un(-s.end_amplitude_un());
    }
  }
  result.segments.push_back(std::move(out));
}

}  // namespace

Expansion expand_protocol(const v1::Protocol& protocol, std::size_t max_segments) {
  Expander expander(max_segments);
  expander.expand_list(protocol.segments(), "", Pass{});
  return std::move(expander.result);
}

}  // namespace tribo::daemon
