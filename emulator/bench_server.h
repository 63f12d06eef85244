// tribo-bench's Modbus server (libmodbus server side, TCP or RTU): serves the
// emulated instrument's registers to any number of TCP clients, applies the
// lock-step rule to drive writes and the fault schedule to every request.
// Single-threaded: one request at a time, so a slow answer is slow for all.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "emulator/bench_config.h"
#include "emulator/emulated_instrument.h"
#include "emulator/fault_injector.h"

typedef struct _modbus modbus_t;

namespace tribo::bench {

class BenchServer {
 public:
  // Binds (TCP) or opens the device (RTU); throws std::runtime_error on failure.
  explicit BenchServer(const BenchSetup& setup);
  ~BenchServer();
  BenchServer(const BenchServer&) = delete;
  BenchServer& operator=(const BenchServer&) = delete;

  // "127.0.0.1:PORT" or the RTU device.
  std::string endpoint() const;
  std::uint16_t port() const { return port_; }

  // Serves until stop becomes true (checked at least every 100 ms).
  void run(const std::atomic<bool>& stop);

  const EmulatedInstrument& instrument() const { return instrument_; }

 private:
  void accept_client();
  // false: the client's connection is to be closed.
  bool serve_one(int socket);
  bool handle(const std::uint8_t* query, int length);
  bool reply_write(const std::uint8_t* query, int length);
  void close_client(int socket);
  void reopen_rtu();

  BenchSetup setup_;
  hal::RegisterMap map_;
  EmulatedInstrument instrument_;
  FaultInjector faults_;
  modbus_t* ctx_ = nullptr;
  bool rtu_ = false;
  int listen_socket_ = -1;
  std::uint16_t port_ = 0;
  std::vector<int> clients_;
  std::uint64_t out_of_sequence_ = 0;
};

}  // namespace tribo::bench
