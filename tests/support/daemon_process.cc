#include "tests/support/daemon_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace tribo::testing {

TempDir::TempDir() {
  std::string pattern = (std::filesystem::temp_directory_path() / "tribo-test-XXXXXX").string();
  if (mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
  path_ = pattern;
}

TempDir::~TempDir() {
  std::error_code ignored;
  std::filesystem::remove_all(path_, ignored);
}

std::string DaemonProcess::default_config_path() {
  return std::string(TRIBO_SOURCE_DIR) + "/config/tribod.textproto";
}
std::string DaemonProcess::tribod_path() { return TRIBOD_PATH; }
std::string DaemonProcess::tribo_cli_path() { return TRIBO_CLI_PATH; }

namespace {

std::vector<char*> c_args(std::vector<std::string>& args) {
  std::vector<char*> out;
  for (auto& a : args) out.push_back(a.data());
  out.push_back(nullptr);
  return out;
}

}  // namespace

DaemonProcess::DaemonProcess(const std::filesystem::path& data_dir, const std::string& config_path,
                             const std::vector<std::string>& extra_args) {
  int out[2];
  if (pipe(out) != 0) throw std::runtime_error("pipe failed");
  std::vector<std::string> args{tribod_path(), "--config", config_path, "--port", "0",
                                "--data-dir", data_dir.string()};
  args.insert(args.end(), extra_args.begin(), extra_args.end());
  pid_ = fork();
  if (pid_ == 0) {
    dup2(out[1], STDOUT_FILENO);
    const int devnull = open("/dev/null", O_WRONLY);
    dup2(devnull, STDERR_FILENO);
    close(out[0]);
    auto argv = c_args(args);
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(out[1]);
  // The first line says where it listens: "tribod listening on 127.0.0.1:PORT".
  FILE* stream = fdopen(out[0], "r");
  char line[256] = {0};
  const bool got = std::fgets(line, sizeof line, stream) != nullptr;
  std::fclose(stream);
  unsigned port = 0;
  const char* colon = got ? std::strrchr(line, ':') : nullptr;
  if (colon == nullptr || std::sscanf(colon + 1, "%u", &port) != 1 || port == 0) {
    terminate();
    throw std::runtime_error("tribod did not start: '" + std::string(line) + "'");
  }
  port_ = static_cast<std::uint16_t>(port);
}

int DaemonProcess::terminate() {
  if (pid_ <= 0) return 0;
  kill(pid_, SIGTERM);
  int status = 0;
  waitpid(pid_, &status, 0);
  pid_ = -1;
  return status;
}

void DaemonProcess::kill_hard() {
  if (pid_ <= 0) return;
  kill(pid_, SIGKILL);
  int status = 0;
  waitpid(pid_, &status, 0);
  pid_ = -1;
}

DaemonProcess::~DaemonProcess() { terminate(); }

CommandResult run_command(const std::vector<std::string>& argv_in) {
  std::vector<std::string> args = argv_in;
  int out[2], err[2];
  if (pipe(out) != 0 || pipe(err) != 0) throw std::runtime_error("pipe failed");
  const pid_t pid = fork();
  if (pid == 0) {
    dup2(out[1], STDOUT_FILENO);
    dup2(err[1], STDERR_FILENO);
    close(out[0]);
    close(err[0]);
    auto argv = c_args(args);
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(out[1]);
  close(err[1]);
  CommandResult result;
  // Read both pipes to the end; poll-free is fine for the small outputs here,
  // as long as stderr is drained after stdout closes.
  char buf[4096];
  ssize_t n;
  while ((n = read(out[0], buf, sizeof buf)) > 0) result.out.append(buf, static_cast<std::size_t>(n));
  while ((n = read(err[0], buf, sizeof buf)) > 0) result.err.append(buf, static_cast<std::size_t>(n));
  close(out[0]);
  close(err[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

}  // namespace tribo::testing
