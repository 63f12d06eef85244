#include "daemon/field_bounds.h"

#include <cmath>
#include <sstream>

namespace tribo::daemon {

namespace pb = google::protobuf;

namespace {

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

class Walker {
 public:
  explicit Walker(std::size_t max_issues) : max_issues_(max_issues) {}

  void walk(const pb::Message& m, const std::string& path) {
    const pb::Reflection* r = m.GetReflection();
    std::vector<const pb::FieldDescriptor*> fields;
    r->ListFields(m, &fields);  // set fields only: an unset one is its default
    for (const pb::FieldDescriptor* f : fields) {
      if (full()) return;
      const std::string name = path.empty() ? f->name() : path + "." + f->name();
      if (f->is_map()) {
        walk_map(m, f, name);
      } else if (f->is_repeated()) {
        const int n = r->FieldSize(m, f);
        for (int i = 0; i < n && !full(); ++i) value(m, f, name + "[" + std::to_string(i) + "]", i);
      } else {
        value(m, f, name, -1);
      }
    }
  }

  std::vector<FieldBoundsIssue> issues;

 private:
  bool full() const { return issues.size() >= max_issues_; }
  void issue(std::string field, std::string message) {
    if (!full()) issues.push_back({std::move(field), std::move(message)});
  }

  void number(const std::string& field, double v) {
    if (!std::isfinite(v)) issue(field, field + " = " + fmt(v) + " is not a finite number");
  }

  void text(const std::string& field, const pb::FieldDescriptor* f, const std::string& v) {
    if (f->type() == pb::FieldDescriptor::TYPE_BYTES) return;
    const std::size_t limit = max_string_bytes(f->name());
    if (v.size() > limit) {
      issue(field, field + " is " + std::to_string(v.size()) + " bytes long; the maximum is " +
                       std::to_string(limit) + " bytes");
    }
  }

  void value(const pb::Message& m, const pb::FieldDescriptor* f, const std::string& field, int i) {
    const pb::Reflection* r = m.GetReflection();
    const bool rep = i >= 0;
    switch (f->cpp_type()) {
      case pb::FieldDescriptor::CPPTYPE_DOUBLE:
        number(field, rep ? r->GetRepeatedDouble(m, f, i) : r->GetDouble(m, f));
        break;
      case pb::FieldDescriptor::CPPTYPE_FLOAT:
        number(field, rep ? r->GetRepeatedFloat(m, f, i) : r->GetFloat(m, f));
        break;
      case pb::FieldDescriptor::CPPTYPE_STRING:
        text(field, f, rep ? r->GetRepeatedString(m, f, i) : r->GetString(m, f));
        break;
      case pb::FieldDescriptor::CPPTYPE_MESSAGE:
        walk(rep ? r->GetRepeatedMessage(m, f, i) : r->GetMessage(m, f), field);
        break;
      default:
        break;
    }
  }

  void walk_map(const pb::Message& m, const pb::FieldDescriptor* f, const std::string& field) {
    const pb::Reflection* r = m.GetReflection();
    const int n = r->FieldSize(m, f);
    if (static_cast<std::size_t>(n) > kMaxMapEntries) {
      issue(field, field + " has " + std::to_string(n) + " entries; the maximum is " +
                       std::to_string(kMaxMapEntries));
      return;
    }
    const pb::FieldDescriptor* key = f->message_type()->map_key();
    const pb::FieldDescriptor* val = f->message_type()->map_value();
    for (int i = 0; i < n && !full(); ++i) {
      const pb::Message& entry = r->GetRepeatedMessage(m, f, i);
      const pb::Reflection* er = entry.GetReflection();
      if (key->cpp_type() == pb::FieldDescriptor::CPPTYPE_STRING) {
        const std::string k = er->GetString(entry, key);
        if (k.size() > kMaxNameBytes) {
          issue(field, field + " has a key of " + std::to_string(k.size()) + " bytes; the maximum is " +
                           std::to_string(kMaxNameBytes) + " bytes");
          continue;
        }
        const std::string item = field + "[\"" + k + "\"]";
        if (val->cpp_type() == pb::FieldDescriptor::CPPTYPE_STRING) {
          const std::string v = er->GetString(entry, val);
          if (v.size() > kMaxNameBytes) {
            issue(item, item + " is " + std::to_string(v.size()) + " bytes long; the maximum is " +
                            std::to_string(kMaxNameBytes) + " bytes");
          }
        } else if (val->cpp_type() == pb::FieldDescriptor::CPPTYPE_MESSAGE) {
          walk(er->GetMessage(entry, val), item);
        }
      }
    }
  }

  std::size_t max_issues_;
};

}  // namespace

std::size_t max_string_bytes(std::string_view name) {
  if (name == "report_json") return kMaxReportBytes;
  for (std::string_view free_text : {"description", "note", "reason", "message", "detail", "report_file"}) {
    if (name == free_text) return kMaxTextBytes;
  }
  return kMaxNameBytes;
}

std::vector<FieldBoundsIssue> check_field_bounds(const pb::Message& message, const std::string& prefix,
                                                 std::size_t max_issues) {
  Walker w(max_issues);
  w.walk(message, prefix);
  return std::move(w.issues);
}

std::string printable_prefix(std::string_view text, std::size_t max_bytes) {
  std::string out;
  std::size_t n = std::min(text.size(), max_bytes);
  // Do not cut inside a UTF-8 sequence: back up over continuation bytes.
  if (n < text.size()) {
    while (n > 0 && (static_cast<unsigned char>(text[n]) & 0xC0) == 0x80) --n;
  }
  out.reserve(n + 3);
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    out.push_back(c < 0x20 || c == 0x7F ? '?' : static_cast<char>(c));
  }
  if (n < text.size()) out += "...";
  return out;
}

}  // namespace tribo::daemon
