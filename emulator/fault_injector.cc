#include "emulator/fault_injector.h"

#include <cmath>

#include <spdlog/spdlog.h>

namespace tribo::bench {

namespace {

bool applies_to(v1::BenchFault::Kind kind, RequestKind request) {
  switch (kind) {
    case v1::BenchFault::CORRUPT_VALUES: return request == RequestKind::kSensorRead;
    case v1::BenchFault::FREEZE_PLANT: return request == RequestKind::kDriveWrite;
    default: return true;
  }
}

FaultAction action_of(v1::BenchFault::Kind kind) {
  switch (kind) {
    case v1::BenchFault::STOP_ANSWERING: return FaultAction::kIgnore;
    case v1::BenchFault::SLOW_ANSWERS: return FaultAction::kDelay;
    case v1::BenchFault::EXCEPTION: return FaultAction::kException;
    case v1::BenchFault::DROP_CONNECTION: return FaultAction::kDrop;
    case v1::BenchFault::CORRUPT_VALUES: return FaultAction::kCorrupt;
    case v1::BenchFault::FREEZE_PLANT: return FaultAction::kFreeze;
    default: return FaultAction::kAnswer;
  }
}

}  // namespace

FaultInjector::FaultInjector(std::vector<v1::BenchFault> faults) {
  for (auto& f : faults) faults_.push_back(Armed{std::move(f)});
}

void FaultInjector::rearm() {
  for (Armed& a : faults_) {
    a.used = 0;
    a.announced = false;
  }
}

FaultDecision FaultInjector::on_request(std::uint64_t plant_steps, RequestKind kind) {
  for (Armed& a : faults_) {
    const v1::BenchFault& f = a.fault;
    if (plant_steps < f.at_step() || !applies_to(f.kind(), kind)) continue;
    // A dropped connection happens once; the others last request_count requests (0: for good).
    const std::uint64_t limit = f.kind() == v1::BenchFault::DROP_CONNECTION ? 1 : f.request_count();
    if (limit != 0 && a.used >= limit) continue;
    ++a.used;
    if (!a.announced) {
      a.announced = true;
      spdlog::warn("fault injected at plant step {}: {} ({} requests)", plant_steps,
                   v1::BenchFault::Kind_Name(f.kind()), limit == 0 ? std::string("all") : std::to_string(limit));
    }
    return FaultDecision{action_of(f.kind()), f.delay_s(), static_cast<int>(f.exception_code())};
  }
  return {};
}

std::optional<std::string> validate_faults(const google::protobuf::RepeatedPtrField<v1::BenchFault>& faults) {
  for (int i = 0; i < faults.size(); ++i) {
    const v1::BenchFault& f = faults[i];
    const std::string at = "faults[" + std::to_string(i) + "]";
    if (f.kind() == v1::BenchFault::KIND_UNSPECIFIED || !v1::BenchFault::Kind_IsValid(f.kind())) {
      return at + ".kind: not set (STOP_ANSWERING, SLOW_ANSWERS, EXCEPTION, DROP_CONNECTION, CORRUPT_VALUES, "
                  "FREEZE_PLANT)";
    }
    if (f.kind() == v1::BenchFault::SLOW_ANSWERS && !(std::isfinite(f.delay_s()) && f.delay_s() > 0 && f.delay_s() <= 60)) {
      return at + ".delay_s = " + std::to_string(f.delay_s()) + ": must be in (0, 60] for SLOW_ANSWERS";
    }
    if (f.kind() == v1::BenchFault::EXCEPTION && (f.exception_code() < 1 || f.exception_code() > 11)) {
      return at + ".exception_code = " + std::to_string(f.exception_code()) + ": must be a Modbus exception code, 1-11";
    }
  }
  return std::nullopt;
}

}  // namespace tribo::bench
