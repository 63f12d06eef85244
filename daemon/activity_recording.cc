#include "daemon/activity_recording.h"

#include <chrono>

namespace tribo::daemon {

std::unique_ptr<ActivityRecording> ActivityRecording::create(const std::filesystem::path& data_dir,
                                                             v1::RunStart& start, v1::RunDescriptor descriptor,
                                                             std::string& error) {
  auto recorder = RunRecorder::create(data_dir, start, error);
  if (!recorder) return nullptr;
  descriptor.set_run_id(start.run_id());
  recorder->describe(std::move(descriptor));
  return std::unique_ptr<ActivityRecording>(new ActivityRecording(std::move(recorder), start.run_id()));
}

ActivityRecording::ActivityRecording(std::unique_ptr<RunRecorder> recorder, std::string run_id)
    : recorder_(std::move(recorder)), run_id_(std::move(run_id)) {}

ActivityRecording::~ActivityRecording() {
  finished_.store(true, std::memory_order_release);
  if (drain_.joinable()) drain_.join();
}

void ActivityRecording::start() {
  drain_ = std::thread([this] { drain(); });
}

void ActivityRecording::drain() {
  auto last_flush = std::chrono::steady_clock::now();
  for (;;) {
    const bool finished = finished_.load(std::memory_order_acquire);
    Sample s;
    bool any = false;
    while (queue_.try_pop(s)) {
      recorder_->append(s);
      any = true;
    }
    if (finished) break;  // everything pushed before the flag was set is drained
    // A crash loses at most this much of the experiment.
    if (std::chrono::steady_clock::now() - last_flush >= std::chrono::milliseconds(200)) {
      recorder_->flush();
      last_flush = std::chrono::steady_clock::now();
    }
    if (!any) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

v1::RunStop ActivityRecording::finish(v1::RunStop stop, const v1::Fault* fault) {
  finished_.store(true, std::memory_order_release);
  if (drain_.joinable()) drain_.join();
  stop.set_run_id(run_id_);
  stop.set_sample_count(recorder_->appended());
  stop.set_stop_time_utc(utc_timestamp_iso8601());
  const auto append_reason = [&](const std::string& text) {
    stop.set_reason(stop.reason() + (stop.reason().empty() ? "" : "; ") + text);
  };
  if (const auto dropped = dropped_.load(); dropped > 0) {
    append_reason(std::to_string(dropped) + " samples dropped: the recorder fell behind");
  }
  if (fault != nullptr) {
    v1::Fault f = *fault;
    f.set_run_id(run_id_);
    f.set_sequence(recorder_->appended());  // the experiment stops at once: the recording's end
    recorder_->record(f);
  }
  recorder_->flush();
  const auto name_lost = [&] {
    if (!recorder_->write_failed() || stop.recording_failed()) return;
    stop.set_recording_failed(true);
    stop.set_lost_first_sequence(recorder_->written());
    stop.set_lost_end_sequence(recorder_->appended());
    append_reason("recording failed (" + recorder_->error() + ")");
  };
  name_lost();
  if (!recorder_->finish(stop)) {
    if (stop.exit_status() == v1::SUCCESS) stop.set_exit_status(v1::FAULT);
    name_lost();
  }
  return stop;
}

}  // namespace tribo::daemon
