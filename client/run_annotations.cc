#include "client/run_annotations.h"

namespace tribo::client {

std::string add_annotation(v1::RunAnnotations& annotations, const std::string& key_value) {
  const auto eq = key_value.find('=');
  if (eq == std::string::npos || eq == 0) return "--meta " + key_value + " is not KEY=VALUE";
  (*annotations.mutable_extra())[key_value.substr(0, eq)] = key_value.substr(eq + 1);
  return "";
}

}  // namespace tribo::client
