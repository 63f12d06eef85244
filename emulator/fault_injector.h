// The bench emulator's fault schedule (tribo.v1.BenchFault): decides, request
// by request, whether tribo-bench answers normally or misbehaves. Counting
// requests and plant steps, never wall time, so a test's fault lands on the
// same tick every run.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "tribo/v1/modbus_config.pb.h"

namespace tribo::bench {

// What a request touches, for faults that only affect some requests.
enum class RequestKind { kSensorRead, kDriveWrite, kOther };

enum class FaultAction {
  kAnswer,      // normally
  kIgnore,      // read it, never answer
  kDelay,       // answer after delay_s
  kException,   // answer with exception_code
  kDrop,        // close the connection
  kCorrupt,     // answer a sensor read with flipped bits
  kFreeze,      // acknowledge a drive write without stepping the plant
};

struct FaultDecision {
  FaultAction action = FaultAction::kAnswer;
  double delay_s = 0;
  int exception_code = 0;
};

class FaultInjector {
 public:
  explicit FaultInjector(std::vector<v1::BenchFault> faults);

  // A new session (run): every fault is armed again.
  void rearm();

  // plant_steps: steps of the current session so far.
  FaultDecision on_request(std::uint64_t plant_steps, RequestKind kind);

 private:
  struct Armed {
    v1::BenchFault fault;
    std::uint64_t used = 0;  // requests affected so far
    bool announced = false;
  };
  std::vector<Armed> faults_;
};

// Checks a fault list; errors name the entry (faults[i].field).
std::optional<std::string> validate_faults(const google::protobuf::RepeatedPtrField<v1::BenchFault>& faults);

}  // namespace tribo::bench
