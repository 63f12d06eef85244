// Modbus RTU end to end without hardware: tribo-bench serves RTU on one
// pseudo-terminal, the backend talks RTU on another, and a relay in the test
// joins the two masters like a null-modem cable (socat's job, done here so
// that no package is needed).
#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <stdlib.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <stdexcept>
#include <thread>

#include "daemon/controller.h"
#include "hal/backend_factory.h"
#include "hal/sim_transducer.h"
#include "sim/instrument_params.h"
#include "tests/modbus/modbus_support.h"
#include "tests/support/daemon_process.h"

namespace tribo {
namespace {

class Pty {
 public:
  Pty() {
    master_ = posix_openpt(O_RDWR | O_NOCTTY);
    if (master_ < 0 || grantpt(master_) != 0 || unlockpt(master_) != 0) throw std::runtime_error("openpt failed");
    device_ = ptsname(master_);
    // Held open so that the master never sees a hang-up while a side reopens it.
    keep_open_ = open(device_.c_str(), O_RDWR | O_NOCTTY);
  }
  ~Pty() {
    close(keep_open_);
    close(master_);
  }
  Pty(const Pty&) = delete;
  Pty& operator=(const Pty&) = delete;
  int master() const { return master_; }
  const std::string& device() const { return device_; }

 private:
  int master_ = -1;
  int keep_open_ = -1;
  std::string device_;
};

// Copies bytes between two pty masters until destroyed.
class NullModem {
 public:
  NullModem(int a, int b) : thread_([this, a, b] { relay(a, b); }) {}
  ~NullModem() {
    stop_.store(true);
    thread_.join();
  }

 private:
  void relay(int a, int b) {
    char buf[512];
    while (!stop_.load()) {
      pollfd fds[2] = {{a, POLLIN, 0}, {b, POLLIN, 0}};
      if (poll(fds, 2, 20) <= 0) continue;
      for (int i = 0; i < 2; ++i) {
        if (!(fds[i].revents & POLLIN)) continue;
        const ssize_t n = read(fds[i].fd, buf, sizeof buf);
        if (n > 0 && write(i == 0 ? b : a, buf, static_cast<std::size_t>(n)) != n) return;
      }
    }
  }
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

v1::ModbusRtuLink rtu_link(const std::string& device) {
  v1::ModbusRtuLink rtu;
  rtu.set_device(device);
  rtu.set_baud(115200);
  rtu.set_parity("E");
  rtu.set_data_bits(8);
  rtu.set_stop_bits(1);
  return rtu;
}

TEST(ModbusRtu, LockStepLoopOverAPseudoTerminalMatchesTheSimulatedBackend) {
  Pty bench_side, backend_side;
  NullModem cable(bench_side.master(), backend_side.master());
  testing::TempDir dir;
  v1::DaemonConfig config = testing::modbus_daemon_config();
  config.mutable_modbus()->set_response_timeout_s(1.0);
  config.mutable_modbus()->set_byte_timeout_s(0.1);
  const v1::ModbusRtuLink bench_rtu = rtu_link(bench_side.device());
  testing::BenchProcess bench(testing::write_bench_config(dir.path(), config, {}, &bench_rtu));

  *config.mutable_modbus()->mutable_rtu() = rtu_link(backend_side.device());
  auto modbus = hal::make_transducer(config, 21);
  const v1::DaemonConfig sim_config = testing::sim_daemon_config();
  hal::SimTransducer sim(sim::instrument_params_from_config(sim_config.sim()), 21,
                         sim_config.controller().loop_rate_hz(), false);
  daemon::Controller a_controller(daemon::controller_params_from_config(config.controller()));
  daemon::Controller b_controller(daemon::controller_params_from_config(sim_config.controller()));
  for (int k = 0; k < 300; ++k) {
    daemon::Setpoints sp;
    sp.lateral_position_m = k * 1e-9;
    hal::SensorFrame a, b;
    ASSERT_EQ(modbus->read(a), hal::IoResult::kOk) << k << ": " << modbus->health().last_error;
    sim.read(b);
    ASSERT_NEAR(a.lateral_position_m, b.lateral_position_m,
                testing::lateral_position_step_m(sim_config, b.lateral_position_m) + 1e-14)
        << k;
    ASSERT_EQ(modbus->write(a_controller.step(sp, a).drive), hal::IoResult::kOk) << k;
    sim.write(b_controller.step(sp, b).drive);
    sim.wait_next_tick();
  }
  EXPECT_EQ(modbus->health().errors(), 0u);
  EXPECT_EQ(modbus->health().transactions, 602u);
}

}  // namespace
}  // namespace tribo
