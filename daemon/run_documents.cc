#include "daemon/run_documents.h"

#include "proto/sample_record.h"

namespace tribo::daemon {

v1::RunStart make_run_start(const v1::Protocol& protocol, const v1::DaemonConfig& config,
                            const LoadFunction& load_function, const v1::PidGains (&gains)[4],
                            std::uint64_t seed, const std::string& software_version,
                            const v1::RunAnnotations& annotations) {
  v1::RunStart start;
  *start.mutable_protocol() = protocol;
  *start.mutable_config() = config;
  start.mutable_config()->mutable_server()->clear_control_token();  // the run documents are public
  *start.mutable_lateral_gains() = gains[v1::LOOP_LATERAL_DISPLACEMENT - 1];
  // The gains in force (SetGains) go into the recorded config too.
  auto& recorded = *start.mutable_config()->mutable_controller();
  *recorded.mutable_lateral_displacement() = gains[v1::LOOP_LATERAL_DISPLACEMENT - 1];
  *recorded.mutable_lateral_force() = gains[v1::LOOP_LATERAL_FORCE - 1];
  *recorded.mutable_normal_force() = gains[v1::LOOP_NORMAL_FORCE - 1];
  *recorded.mutable_normal_displacement() = gains[v1::LOOP_NORMAL_DISPLACEMENT - 1];
  start.set_seed(seed);
  start.set_software_version(software_version);
  start.set_loop_rate_hz(config.controller().loop_rate_hz());
  if (annotations.ByteSizeLong() > 0) *start.mutable_annotations() = annotations;
  for (const SegmentPlan& plan : load_function.segments()) {
    v1::RunSegment* seg = start.add_segments();
    seg->set_name(plan.name);
    seg->set_start_s(static_cast<double>(plan.start_tick) / load_function.loop_rate_hz());
    seg->set_duration_s(static_cast<double>(plan.tick_count) / load_function.loop_rate_hz());
    seg->set_normal_mode(plan.normal_mode == NormalMode::kClosedLoopForce ? v1::NORMAL_CLOSED_LOOP_FORCE
                         : plan.normal_mode == NormalMode::kDisplacement  ? v1::NORMAL_DISPLACEMENT
                                                                          : v1::NORMAL_OPEN_LOOP_FORCE);
    seg->set_lateral_mode(plan.lateral_mode == LateralMode::kForce ? v1::LATERAL_FORCE : v1::LATERAL_DISPLACEMENT);
  }
  // Which model compensated which segments: the reports' hashes and
  // parameters, so the run says what it was compensated with.
  for (const FrictionReport& r : load_function.friction_models()) {
    v1::FrictionModelUse* use = start.add_friction_models();
    use->set_report_file(r.report_file);
    use->set_report_sha256(r.sha256);
    use->set_contact(r.contact);
    for (const ReportParameter& p : r.parameters) {
      v1::ModelParameter* q = use->add_parameters();
      q->set_name(p.name);
      q->set_value(p.value);
      q->set_unit(p.unit);
    }
  }
  const auto& plans = load_function.segments();
  for (std::size_t i = 0; i < plans.size(); ++i) {
    if (plans[i].friction_model >= 0) start.mutable_friction_models(plans[i].friction_model)->add_segments(static_cast<std::uint32_t>(i));
  }
  return start;
}

v1::RunDescriptor make_descriptor(const LoadFunction& load_function) {
  v1::RunDescriptor d;
  describe_channels(d);
  d.set_expected_samples(load_function.expected_samples());
  d.set_duration_s(static_cast<double>(load_function.total_ticks()) / load_function.loop_rate_hz());
  // segment_index counts the unrolled segments (repeat blocks expanded).
  for (const SegmentPlan& plan : load_function.segments()) d.add_segment_names(plan.name);
  return d;
}

v1::SegmentEvent make_segment_event(const std::string& run_id, const LoadFunction& load_function,
                                    v1::SegmentEventKind kind, std::uint32_t segment_index,
                                    std::uint64_t sequence, double time_s) {
  v1::SegmentEvent event;
  event.set_run_id(run_id);
  event.set_sequence(sequence);
  event.set_time_s(time_s);
  event.set_kind(kind);
  event.set_segment_index(segment_index);
  const auto& plans = load_function.segments();
  if (segment_index < plans.size()) event.set_segment_name(plans[segment_index].name);
  return event;
}

v1::BackendHealth health_message(std::string_view backend, const hal::BackendHealth& h) {
  v1::BackendHealth m;
  m.set_backend(std::string(backend));
  m.set_connected(h.connected);
  m.set_transactions(h.transactions);
  m.set_timeouts(h.timeouts);
  m.set_exceptions(h.exceptions);
  m.set_bad_frames(h.bad_frames);
  m.set_link_losses(h.link_losses);
  m.set_reconnect_attempts(h.reconnect_attempts);
  m.set_last_io_s(h.last_io_s);
  m.set_max_io_s(h.max_io_s);
  m.set_last_error(h.last_error);
  m.set_first_error(h.first_error);
  return m;
}

}  // namespace tribo::daemon
