// Records an activity of the supervised loop other than a protocol run (the
// autotune relay experiment) as a run: its own run directory with the start
// document, the descriptor, samples.csv, the events and a stop document with
// the exit status, so `tribo list` shows it and its samples can be fetched
// like any run's (proto/run_files.h).
//
// The loop thread only pushes finished samples into a bounded queue (no
// allocation, no lock, no I/O on the tick path; a full queue drops and
// counts); a drain thread of this class appends them to the recorder.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>

#include "daemon/run_recorder.h"
#include "daemon/sample_queue.h"
#include "proto/sample_record.h"
#include "tribo/v1/api.pb.h"

namespace tribo::daemon {

class ActivityRecording {
 public:
  // Creates the run directory (start gets its run id) and writes the start
  // document and the descriptor. nullptr and error set on failure.
  static std::unique_ptr<ActivityRecording> create(const std::filesystem::path& data_dir, v1::RunStart& start,
                                                   v1::RunDescriptor descriptor, std::string& error);
  ~ActivityRecording();

  // The loop thread's end of the queue.
  SpscQueue<Sample>& queue() { return queue_; }
  std::atomic<std::uint64_t>& dropped() { return dropped_; }
  // Starts the drain thread.
  void start();
  // After the activity's last push: drains what is left, appends the fault
  // (if any) and writes the stop document (sample count filled in here).
  // Returns the stop as written; its reason names a failed recording.
  v1::RunStop finish(v1::RunStop stop, const v1::Fault* fault);

  const std::string& run_id() const { return run_id_; }

 private:
  ActivityRecording(std::unique_ptr<RunRecorder> recorder, std::string run_id);
  void drain();

  static constexpr std::size_t kQueueCapacity = 1 << 14;
  std::unique_ptr<RunRecorder> recorder_;
  std::string run_id_;
  SpscQueue<Sample> queue_{kQueueCapacity};
  std::atomic<std::uint64_t> dropped_{0};
  std::atomic<bool> finished_{false};
  std::thread drain_;
};

}  // namespace tribo::daemon
