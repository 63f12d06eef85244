// Starts the real tribod binary for a test: on 127.0.0.1, an ephemeral port,
// a private data directory; stops it (SIGTERM, then wait) when destroyed.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace tribo::testing {

// A fresh empty directory under the system temp dir, removed on destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

class DaemonProcess {
 public:
  // Starts tribod with the given config file (default: the repository's) and
  // waits for its "listening" line.
  explicit DaemonProcess(const std::filesystem::path& data_dir,
                         const std::string& config_path = default_config_path(),
                         const std::vector<std::string>& extra_args = {});
  ~DaemonProcess();

  std::uint16_t port() const { return port_; }
  // Sends SIGTERM and waits; returns the exit status (as from waitpid).
  int terminate();
  // SIGKILL: a crash, as far as the recording can tell.
  void kill_hard();

  static std::string default_config_path();
  static std::string tribod_path();
  static std::string tribo_cli_path();

 private:
  pid_t pid_ = -1;
  std::uint16_t port_ = 0;
};

// Runs a command, returns its exit code and captures stdout and stderr.
struct CommandResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};
CommandResult run_command(const std::vector<std::string>& argv);

}  // namespace tribo::testing
