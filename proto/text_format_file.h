// Reading and writing protobuf text format files (config, protocols): one
// schema for files and wire. Parse errors say file, line, column and field.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include <google/protobuf/message.h>

namespace tribo::wire {

// Parses text into msg. Returns an error "source:line:col: message", or nullopt.
std::optional<std::string> parse_text_proto(std::string_view text, std::string_view source,
                                            google::protobuf::Message& msg);

// Reads path and parses it into msg; errors as above, or "cannot read path".
std::optional<std::string> load_text_proto_file(const std::string& path,
                                                google::protobuf::Message& msg);

std::string to_text_proto(const google::protobuf::Message& msg);

// Reads a whole file; nullopt if it cannot be opened.
std::optional<std::string> read_file(const std::string& path);

}  // namespace tribo::wire
