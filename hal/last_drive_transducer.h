// A backend that remembers the last drive it accepted. The daemon's one
// backend is wrapped in it, so an emergency stop while no activity runs can
// unload from the drive the instrument holds now (whatever activity wrote
// it last: a run that ended loaded, the autotune experiment) through the
// safe stop sequence (daemon/idle_stop.h).
//
// Only a write that the backend acknowledged (kOk) is remembered: after a
// failed write the instrument holds the previous drive, and unloading from a
// larger drive than it holds would first load it. Read and written on the
// loop thread only (activities run one at a time there).
#pragma once

#include <memory>
#include <utility>

#include "hal/transducer.h"

namespace tribo::hal {

class LastDriveTransducer final : public Transducer {
 public:
  explicit LastDriveTransducer(std::unique_ptr<Transducer> inner) : inner_(std::move(inner)) {}

  // The last drive the backend acknowledged; zero before any.
  const DriveCommand& last_drive() const { return last_; }

  std::string_view backend_name() const override { return inner_->backend_name(); }
  double period_s() const override { return inner_->period_s(); }
  IoResult read(SensorFrame& frame) override { return inner_->read(frame); }
  IoResult write(const DriveCommand& command) override {
    const IoResult result = inner_->write(command);
    if (result == IoResult::kOk) last_ = command;
    return result;
  }
  void wait_next_tick() override { inner_->wait_next_tick(); }
  void interrupt_wait() override { inner_->interrupt_wait(); }
  std::uint64_t overruns() const override { return inner_->overruns(); }
  BackendHealth health() const override { return inner_->health(); }
  void begin_session(std::uint64_t seed) override { inner_->begin_session(seed); }

 private:
  std::unique_ptr<Transducer> inner_;
  DriveCommand last_;
};

}  // namespace tribo::hal
