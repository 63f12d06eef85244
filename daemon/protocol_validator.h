// The dry run: checks a protocol against the instrument before anything
// moves, and compiles it into a LoadFunction. Every issue names the segment
// (path in the file, name and repeat pass), the field, the value and the
// limit, in the units of the protocol file (µm, µN, s, Hz).
//
// Checked per segment after unrolling repeat blocks (daemon/protocol_expansion.h):
// - duration: positive, at most limits.max_segment_duration_s, whole loop and
//   sample periods; the protocol at most limits.max_protocol_duration_s;
// - acquisition rate: divides the loop rate;
// - fields: the unit matches the axis mode (_um for displacement, _uN for
//   force), shapes have their parameters (sine frequency, whole cycles, at
//   least 20 ticks per cycle; velocity profile rates), no end and delta at once;
// - continuity: a given begin equals the previous segment's end in the same
//   mode (absent: continues; first segment and mode changes: starts from the
//   measured value, which the validator bounds);
// - limits along the whole path, sine and profile extremes included: normal
//   force [0, max_normal_force], normal travel, lateral travel, lateral force;
// - velocity of loaded lateral displacement: at most max_velocity; below
//   min_velocity rejected (warning if limits.allow_velocity_outside_range),
//   below 0.2 µm/s a warning (§4.4.1); path acceleration at most the
//   supervisor's limit;
// - the breakpoint: a loaded segment's lateral path stays at least
//   limits.breakpoint_guard_m away from x = 0 (§3.2.5);
// - pull-in margin along the path: the lateral drive (spring plus the
//   planning friction at the segment's highest load) keeps k_eff / k above
//   supervisor.min_stiffness_ratio at every extreme of the path, and the
//   normal drive voltage stays below the transducer's max_drive_v;
// - LATERAL_FORCE needs max_excursion_um (the break-away hold);
// - friction compensation (the protocol's, or a segment's own; displacement
//   segments only): the report reads as a model the compensation can
//   evaluate (daemon/friction_report.h), and what it may add to the drive at
//   the segment's highest load and speed stays within
//   supervisor.max_friction_compensation_n. Each distinct report is read once
//   and compiled into LoadFunction::friction_models().
#pragma once

#include <string>
#include <vector>

#include "daemon/load_function.h"
#include "daemon/protocol_expansion.h"
#include "tribo/v1/daemon_config.pb.h"
#include "tribo/v1/protocol.pb.h"

namespace tribo::daemon {

struct ProtocolCheck {
  std::vector<ValidationIssue> errors;  // empty: the protocol may run
  std::vector<std::string> warnings;
  LoadFunction load_function;           // meaningful only without errors
  double duration_s = 0;

  bool ok() const { return errors.empty(); }
};

ProtocolCheck validate_protocol(const v1::Protocol& protocol, const v1::DaemonConfig& config);

}  // namespace tribo::daemon
