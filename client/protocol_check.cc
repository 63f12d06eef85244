#include "client/protocol_check.h"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "daemon/load_function.h"
#include "daemon/protocol_validator.h"

namespace tribo::client {

namespace {

// Draws the CSV of planned_setpoints_csv: normal above, lateral below,
// segments shaded and named, 200 dpi.
constexpr const char* kPlotScript = R"PY(
import csv, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

rows = list(csv.DictReader(open(sys.argv[1])))
t = [float(r["time_s"]) for r in rows]
fig, (ax_n, ax_l) = plt.subplots(2, 1, sharex=True, figsize=(9, 5.5))
def series(axis):
    units = sorted({r[axis + "_unit"] for r in rows})
    for unit in units:
        ys = [float(r[axis + "_setpoint"]) if r[axis + "_unit"] == unit else float("nan") for r in rows]
        yield unit, ys
for ax, axis, title in ((ax_n, "normal", "normal setpoint"), (ax_l, "lateral", "lateral setpoint")):
    for unit, ys in series(axis):
        ax.plot(t, ys, lw=1.2, label=unit)
    units = sorted({r[axis + "_unit"] for r in rows})
    ax.set_ylabel(title + " (" + ", ".join(units) + ")")
    ax.grid(alpha=0.3)
starts = {}
for r in rows:
    starts.setdefault(int(r["segment"]), (float(r["time_s"]), r["segment_name"]))
bounds = sorted(starts.values())
for i, (t0, name) in enumerate(bounds):
    t1 = bounds[i + 1][0] if i + 1 < len(bounds) else t[-1]
    for ax in (ax_n, ax_l):
        if i % 2:
            ax.axvspan(t0, t1, color="0.92", zorder=0)
    if len(bounds) <= 24:
        ax_n.text((t0 + t1) / 2, 1.01, name, transform=ax_n.get_xaxis_transform(), rotation=45,
                  ha="left", va="bottom", fontsize=7)
ax_l.set_xlabel("time (s)")
fig.suptitle(sys.argv[3], y=0.995, fontsize=10)
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=200)
)PY";

const char* unit_of_normal(daemon::NormalMode mode) {
  return mode == daemon::NormalMode::kDisplacement ? "µm" : "µN";
}
const char* unit_of_lateral(daemon::LateralMode mode) {
  return mode == daemon::LateralMode::kDisplacement ? "µm" : "µN";
}
const char* name_of(daemon::NormalMode mode) {
  switch (mode) {
    case daemon::NormalMode::kOpenLoopForce: return "open-loop force";
    case daemon::NormalMode::kClosedLoopForce: return "force";
    default: return "displacement";
  }
}
const char* name_of(daemon::LateralMode mode) {
  switch (mode) {
    case daemon::LateralMode::kDisplacement: return "displacement";
    case daemon::LateralMode::kForce: return "force";
    default: return "drive";
  }
}

std::string quoted(std::string text) {
  std::replace(text.begin(), text.end(), '"', '\'');
  return "\"" + text + "\"";
}

}  // namespace

std::string planned_setpoints_csv(const v1::Protocol& protocol, const v1::DaemonConfig& config,
                                  std::size_t max_rows, std::string& error) {
  const daemon::ProtocolCheck check = daemon::validate_protocol(protocol, config);
  if (!check.ok()) {
    error = check.errors.front().field + ": " + check.errors.front().message;
    return "";
  }
  const daemon::LoadFunction& lf = check.load_function;
  const auto& plans = lf.segments();
  std::string csv =
      "time_s,segment,segment_name,normal_mode,normal_setpoint,normal_unit,lateral_mode,lateral_setpoint,"
      "lateral_unit\n";
  const std::uint64_t total = lf.total_ticks();
  const std::uint64_t stride = std::max<std::uint64_t>(1, total / std::max<std::size_t>(1, max_rows));
  daemon::SegmentRunner runner(lf);
  daemon::MeasuredStart measured;
  std::size_t next_segment = 0;
  for (std::uint64_t tick = 0; tick < total;) {
    const daemon::TickSetpoints sp = runner.at(tick, measured);
    // A begin from the measured value is planned from the previous setpoint.
    if (sp.normal_mode == daemon::NormalMode::kDisplacement) measured.normal_displacement_m = sp.normal;
    else measured.normal_force_n = measured.normal_drive_n = sp.normal;
    if (sp.lateral_mode == daemon::LateralMode::kDisplacement) measured.lateral_position_m = sp.lateral;
    else measured.lateral_force_n = sp.lateral;
    const auto& plan = plans[sp.segment];
    csv += fmt::format("{:.6f},{},{},{},{:.6g},{},{},{:.6g},{}\n", static_cast<double>(tick) / lf.loop_rate_hz(),
                       sp.segment, quoted(plan.name), name_of(sp.normal_mode), sp.normal * 1e6,
                       unit_of_normal(sp.normal_mode), name_of(sp.lateral_mode), sp.lateral * 1e6,
                       unit_of_lateral(sp.lateral_mode));
    // Every segment's first tick, so that no short segment is skipped.
    while (next_segment < plans.size() && plans[next_segment].start_tick <= tick) ++next_segment;
    std::uint64_t next = tick + stride;
    if (next_segment < plans.size()) next = std::min(next, plans[next_segment].start_tick);
    if (next >= total && tick + 1 < total) next = total - 1;
    tick = next;
  }
  return csv;
}

bool plot_planned_setpoints(const v1::Protocol& protocol, const v1::DaemonConfig& config, const std::string& png,
                            std::string& error) {
  const std::string csv = planned_setpoints_csv(protocol, config, 4000, error);
  if (csv.empty()) return false;
  const auto dir = std::filesystem::temp_directory_path() / fmt::format("tribo-check-{}", getpid());
  std::filesystem::create_directories(dir);
  const auto csv_path = dir / "setpoints.csv", script_path = dir / "plot.py";
  std::ofstream(csv_path) << csv;
  std::ofstream(script_path) << kPlotScript;
  const std::string title = "planned setpoints of " + protocol.name();
  const pid_t child = fork();
  if (child == 0) {
    setenv("MPLBACKEND", "Agg", 1);
    execl("/usr/bin/python3", "python3", script_path.c_str(), csv_path.c_str(), png.c_str(), title.c_str(),
          static_cast<char*>(nullptr));
    _exit(127);
  }
  int status = 0;
  if (child > 0) waitpid(child, &status, 0);
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  if (child < 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    error = "plotting with /usr/bin/python3 and matplotlib failed (exit " +
            std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ")";
    return false;
  }
  return true;
}

}  // namespace tribo::client
