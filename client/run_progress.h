// The live line `tribo run` draws on a terminal while a run streams: a
// progress bar, the segment (counted from 1), run time of the total, and the current
// friction and normal force (means over the latest block, in µN).
#pragma once

#include <chrono>
#include <cstdio>
#include <string>

#include "tribo/v1/api.pb.h"

namespace tribo::client {

// The line never exceeds this many columns, so that an 80-column terminal
// redraws it in place instead of wrapping.
inline constexpr std::size_t kMaxColumns = 79;

// text cut to at most `columns` display columns (UTF-8 code points).
std::string fit_columns(const std::string& text, std::size_t columns);

class RunProgress {
 public:
  explicit RunProgress(std::FILE* out) : out_(out) {}

  void on_document(const v1::ServerMessage& document);
  // Clears the line (before the summary is printed).
  void finish();

  // The line for the present state (without carriage return); for tests.
  std::string line() const;

 private:
  std::FILE* out_;
  v1::RunDescriptor descriptor_;
  std::string segment_;
  std::uint32_t segment_index_ = 0;
  bool unloading_ = false;
  double time_s_ = 0;
  double friction_n_ = 0;
  double normal_n_ = 0;
  std::uint64_t gaps_ = 0;
  std::chrono::steady_clock::time_point last_draw_{};
  bool drawn_ = false;
};

}  // namespace tribo::client
