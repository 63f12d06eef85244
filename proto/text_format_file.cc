#include "proto/text_format_file.h"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <sstream>

#include <google/protobuf/io/tokenizer.h>
#include <google/protobuf/text_format.h>

namespace tribo::wire {

namespace {

// The field whose value starts before `column` on `line` of text: the last
// "name:" ahead of it. Empty if there is none.
std::string field_before(std::string_view text, int line, int column) {
  for (int i = 0; i < line; ++i) {
    const auto newline = text.find('\n');
    if (newline == std::string_view::npos) return {};
    text.remove_prefix(newline + 1);
  }
  text = text.substr(0, std::min<std::size_t>(static_cast<std::size_t>(column), text.find('\n')));
  const auto colon = text.rfind(':');
  if (colon == std::string_view::npos) return {};
  std::size_t end = colon;
  while (end > 0 && text[end - 1] == ' ') --end;
  std::size_t begin = end;
  while (begin > 0 && (std::isalnum(static_cast<unsigned char>(text[begin - 1])) || text[begin - 1] == '_')) --begin;
  return std::string(text.substr(begin, end - begin));
}

class FirstErrorCollector : public google::protobuf::io::ErrorCollector {
 public:
  FirstErrorCollector(std::string_view source, std::string_view text) : source_(source), text_(text) {}

  void AddError(int line, google::protobuf::io::ColumnNumber column,
                const std::string& message) override {
    if (error_) return;
    error_ = source_ + ":" + std::to_string(line + 1) + ":" + std::to_string(column + 1) + ": " + message;
    // Type errors ("Expected double, got ...") do not say which field.
    const std::string field = field_before(text_, line, column);
    if (!field.empty() && message.find(field) == std::string::npos) *error_ += " (field " + field + ")";
  }

  const std::optional<std::string>& error() const { return error_; }

 private:
  std::string source_;
  std::string_view text_;
  std::optional<std::string> error_;
};

}  // namespace

std::optional<std::string> parse_text_proto(std::string_view text, std::string_view source,
                                            google::protobuf::Message& msg) {
  FirstErrorCollector errors(source, text);
  google::protobuf::TextFormat::Parser parser;
  parser.RecordErrorsTo(&errors);
  if (parser.ParseFromString(std::string(text), &msg)) return std::nullopt;
  return errors.error().value_or(std::string(source) + ": not a valid " +
                                 msg.GetDescriptor()->full_name());
}

std::optional<std::string> read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::optional<std::string> load_text_proto_file(const std::string& path,
                                                google::protobuf::Message& msg) {
  const auto text = read_file(path);
  if (!text) return "cannot read " + path;
  return parse_text_proto(*text, path, msg);
}

std::string to_text_proto(const google::protobuf::Message& msg) {
  std::string out;
  google::protobuf::TextFormat::PrintToString(msg, &out);
  return out;
}

}  // namespace tribo::wire
