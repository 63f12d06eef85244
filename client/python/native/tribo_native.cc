// tribo_native: the C++ libraries in-process for Python (pybind11). Config
// and protocol arrive as protobuf text format (str) or wire format (bytes);
// the validator's errors are raised with the field they name; a run on the
// simulated instrument goes through the daemon's own real-time loop
// (daemon/run_loop.h) with the transducer tribod builds for the same config
// and seed, unpaced, so its samples are tribod's recording bit for bit. The
// analyses are the ones tribo-fit runs, reported with the same JSON. The GIL
// is released while C++ runs. Python-facing wrapper: tribo_client/sim.py.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "analysis/effects/effect.h"
#include "analysis/fit_commands.h"
#include "analysis/input/series_input.h"
#include "daemon/daemon_config.h"
#include "daemon/protocol_validator.h"
#include "daemon/validation_messages.h"
#include "daemon/run_loop.h"
#include "daemon/unpaced_run.h"
#include "proto/run_files.h"
#include "proto/sample_record.h"
#include "proto/text_format_file.h"
#include "scorecard/scorecard.h"
#include "tribo/version.h"

namespace py = pybind11;

namespace tribo::python {
namespace {

// Raised for config and protocol errors: args (message, field).
PyObject* g_validation_error = nullptr;
struct ValidationErrorTag {};

[[noreturn]] void raise_validation(const std::string& field, const std::string& message) {
  py::object error = py::reinterpret_borrow<py::object>(g_validation_error);
  py::object instance = error(message, field);
  PyErr_SetObject(g_validation_error, instance.ptr());
  throw py::error_already_set();
}

// The leading field path of a "field: ..." or "field = ..." message.
std::string field_of(const std::string& message) {
  const std::size_t end = message.find_first_of(" :=");
  return end == std::string::npos ? message : message.substr(0, end);
}

template <typename Message>
Message parse_message(const py::handle& source, const char* what) {
  Message message;
  if (py::isinstance<py::bytes>(source)) {
    const std::string wire = source.cast<std::string>();
    if (!message.ParseFromString(wire)) raise_validation("", std::string("cannot parse the ") + what + " (wire format)");
  } else if (py::isinstance<py::str>(source)) {
    const std::string text = source.cast<std::string>();
    if (auto error = wire::parse_text_proto(text, what, message)) raise_validation("", *error);
  } else {
    throw py::type_error(std::string("the ") + what + " must be text format (str) or wire format (bytes)");
  }
  return message;
}

v1::DaemonConfig checked_config(const py::handle& source) {
  v1::DaemonConfig config = parse_message<v1::DaemonConfig>(source, "config");
  if (auto error = daemon::validate_daemon_config(config)) raise_validation(field_of(*error), *error);
  return config;
}

daemon::ProtocolCheck checked_protocol(const v1::Protocol& protocol, const v1::DaemonConfig& config) {
  daemon::ProtocolCheck check = daemon::validate_protocol(protocol, config);
  if (!check.ok()) raise_validation(check.errors.front().field, daemon::describe_issues(check.errors));
  return check;
}

py::dict protocol_summary(const daemon::ProtocolCheck& check) {
  py::dict out;
  out["duration_s"] = check.duration_s;
  out["expected_samples"] = check.load_function.expected_samples();
  out["warnings"] = check.warnings;
  py::list names;
  for (const daemon::SegmentPlan& plan : check.load_function.segments()) names.append(plan.name);
  out["segment_names"] = names;
  // The friction models the run compensates with, as its start document records them.
  py::list models;
  for (std::size_t i = 0; i < check.load_function.friction_models().size(); ++i) {
    const daemon::FrictionReport& r = check.load_function.friction_models()[i];
    py::dict model;
    model["report_file"] = r.report_file;
    model["report_sha256"] = r.sha256;
    model["contact"] = r.contact;
    py::list parameters;
    for (const daemon::ReportParameter& p : r.parameters) {
      py::dict q;
      q["name"] = p.name;
      q["value"] = p.value;
      q["unit"] = p.unit;
      parameters.append(q);
    }
    model["parameters"] = parameters;
    py::list segments;
    const auto& plans = check.load_function.segments();
    for (std::size_t k = 0; k < plans.size(); ++k) {
      if (plans[k].friction_model == static_cast<int>(i)) segments.append(k);
    }
    model["segments"] = segments;
    models.append(model);
  }
  out["friction_models"] = models;
  return out;
}

template <typename T>
py::array_t<T> column(const std::vector<Sample>& samples, T Sample::*field) {
  py::array_t<T> out(static_cast<py::ssize_t>(samples.size()));
  T* data = out.mutable_data();
  for (std::size_t i = 0; i < samples.size(); ++i) data[i] = samples[i].*field;
  return out;
}

// Channels under the descriptor's names (proto/sample_record.h kSampleChannels).
py::dict sample_columns(const std::vector<Sample>& samples) {
  py::dict out;
  out["t"] = column(samples, &Sample::time_s);
  out["segment"] = column(samples, &Sample::segment_index);
  out["normal_setpoint"] = column(samples, &Sample::normal_setpoint_n);
  out["normal_force"] = column(samples, &Sample::normal_force_n);
  out["normal_displacement"] = column(samples, &Sample::normal_displacement_m);
  out["lateral_setpoint"] = column(samples, &Sample::lateral_setpoint_m);
  out["lateral_position"] = column(samples, &Sample::lateral_position_m);
  out["lateral_force"] = column(samples, &Sample::lateral_force_n);
  out["flags"] = column(samples, &Sample::status_flags);
  return out;
}

template <typename T>
std::vector<T> vector_of(const py::dict& columns, const char* name, std::size_t n) {
  if (!columns.contains(name)) throw py::key_error(std::string("missing channel '") + name + "'");
  auto array = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(columns[name]);
  if (!array || array.ndim() != 1) throw py::value_error(std::string("channel '") + name + "' must be a 1-D array");
  if (n != static_cast<std::size_t>(-1) && static_cast<std::size_t>(array.size()) != n) {
    throw py::value_error(std::string("channel '") + name + "' has a different length from 't'");
  }
  return std::vector<T>(array.data(), array.data() + array.size());
}

std::vector<Sample> samples_from_columns(const py::dict& columns) {
  const auto t = vector_of<double>(columns, "t", static_cast<std::size_t>(-1));
  const std::size_t n = t.size();
  const auto segment = vector_of<std::uint32_t>(columns, "segment", n);
  const auto normal_setpoint = vector_of<double>(columns, "normal_setpoint", n);
  const auto normal_force = vector_of<double>(columns, "normal_force", n);
  const auto normal_displacement = vector_of<double>(columns, "normal_displacement", n);
  const auto lateral_setpoint = vector_of<double>(columns, "lateral_setpoint", n);
  const auto lateral_position = vector_of<double>(columns, "lateral_position", n);
  const auto lateral_force = vector_of<double>(columns, "lateral_force", n);
  const auto flags = vector_of<std::uint32_t>(columns, "flags", n);
  std::vector<Sample> samples(n);
  for (std::size_t i = 0; i < n; ++i) {
    samples[i] = Sample{t[i], segment[i], normal_setpoint[i], normal_force[i], normal_displacement[i],
                        lateral_setpoint[i], lateral_position[i], lateral_force[i], flags[i]};
  }
  return samples;
}

v1::SampleBlock block_of(const std::vector<Sample>& samples) {
  v1::SampleBlock block;
  for (const Sample& s : samples) append_sample(s, block);
  return block;
}

std::vector<analysis::Effect> effects_from(const std::optional<std::vector<std::string>>& names) {
  std::vector<analysis::Effect> effects(analysis::kAllEffects.begin(), analysis::kAllEffects.end());
  if (!names) return effects;
  effects.clear();
  for (const std::string& name : *names) {
    const auto e = analysis::effect_from_name(name);
    if (!e) throw py::value_error("unknown effect '" + name + "'");
    effects.push_back(*e);
  }
  return effects;
}

// tribo-fit's --base-model: "lugre" or "choose".
bool choose_base_contact(const std::string& base_model) {
  if (base_model == "lugre") return false;
  if (base_model == "choose") return true;
  throw py::value_error("base_model must be 'lugre' or 'choose', not '" + base_model + "'");
}

// `tribo-fit diagnose RUN --json` on a tribo run's samples (a run directory's
// options: analysis/fit_commands.h).
std::string diagnose_run_series(analysis::MeasuredSeries series, const std::vector<analysis::Effect>& effects,
                                double begin_s, double end_s, bool choose_base_contact) {
  analysis::DiagnoseRequest request;
  request.candidates = effects;
  request.choose_base_contact = choose_base_contact;
  request.begin_s = begin_s;
  request.end_s = end_s;
  request.tribo_run = true;
  request.command_line = "tribo_native.diagnose";
  analysis::DiagnoseOutcome outcome = analysis::diagnose_series(std::move(series), request);
  if (!outcome.error.empty()) throw std::runtime_error(outcome.error);
  return outcome.json;
}

const char* exit_status_of(daemon::RunEnd end) {
  switch (end) {
    case daemon::RunEnd::kCompleted: return "SUCCESS";
    case daemon::RunEnd::kAborted: return "ABORT";
    case daemon::RunEnd::kTripped: return "FAULT";
  }
  return "UNKNOWN";
}

}  // namespace
}  // namespace tribo::python

PYBIND11_MODULE(tribo_native, m) {
  using namespace tribo;
  using namespace tribo::python;
  m.doc() = "tribo's C++ libraries in-process: validate, simulate, metrics, diagnosis (see docs/python.md)";
  m.attr("software_version") = kSoftwareVersion;

  static py::exception<ValidationErrorTag> validation(m, "ValidationError", PyExc_ValueError);
  g_validation_error = validation.ptr();

  py::list channels;
  for (const ChannelInfo& c : kSampleChannels) {
    channels.append(py::make_tuple(std::string(c.name), std::string(c.unit), std::string(c.description)));
  }
  m.attr("channels") = channels;

  m.def("validate_config", [](const py::handle& config) {
    const v1::DaemonConfig parsed = checked_config(config);
    return py::bytes(parsed.SerializeAsString());
  }, py::arg("config"), "Parses and validates a DaemonConfig; returns it in wire format.");

  m.def("validate_protocol", [](const py::handle& protocol, const py::handle& config) {
    const v1::DaemonConfig parsed_config = checked_config(config);
    const v1::Protocol parsed = parse_message<v1::Protocol>(protocol, "protocol");
    daemon::ProtocolCheck check;
    {
      py::gil_scoped_release release;
      check = daemon::validate_protocol(parsed, parsed_config);
    }
    if (!check.ok()) checked_protocol(parsed, parsed_config);
    return protocol_summary(check);
  }, py::arg("protocol"), py::arg("config"),
     "The daemon's dry run: duration, expected samples, warnings, segment names; ValidationError names the field.");

  m.def("simulate", [](const py::handle& config, const py::handle& protocol, std::uint64_t seed) {
    const v1::DaemonConfig parsed_config = checked_config(config);
    if (parsed_config.backend_case() != v1::DaemonConfig::kSim) {
      raise_validation("backend", "simulate needs the simulated backend (config field sim)");
    }
    const v1::Protocol parsed = parse_message<v1::Protocol>(protocol, "protocol");
    const daemon::ProtocolCheck check = checked_protocol(parsed, parsed_config);
    daemon::UnpacedRun run;
    {
      py::gil_scoped_release release;
      run = daemon::run_unpaced(parsed_config, check.load_function, seed);
    }
    py::dict out;
    out["samples"] = sample_columns(run.samples);
    out["exit_status"] = exit_status_of(run.outcome.end);
    out["trip_reason"] = run.outcome.end == daemon::RunEnd::kTripped ? daemon::trip_description(run.outcome.trip) : "";
    out["cycles"] = run.outcome.cycles;
    out["seed"] = seed;
    out["protocol"] = protocol_summary(check);
    return out;
  }, py::arg("config"), py::arg("protocol"), py::arg("seed"),
     "Runs the protocol on the simulated instrument unpaced: samples as tribod records them.");

  m.def("samples_csv", [](const py::dict& columns) {
    const std::vector<Sample> samples = samples_from_columns(columns);
    std::string out = csv_header();
    for (const Sample& s : samples) append_csv_row(s, out);
    return py::bytes(out);
  }, py::arg("samples"), "The recorder's samples.csv text of sample columns (proto/sample_record.h).");

  m.def("metrics", [](const py::dict& columns) {
    const v1::SampleBlock block = block_of(samples_from_columns(columns));
    py::gil_scoped_release release;
    return analysis::metrics_json(block);
  }, py::arg("samples"), "tribo-fit metrics --json on sample columns (JSON text).");

  m.def("metrics_of_run", [](const std::string& run_dir) {
    py::gil_scoped_release release;
    std::string error;
    const auto run = wire::read_run_directory(run_dir, error);
    if (!run) throw std::runtime_error(error);
    return analysis::metrics_json(run->samples);
  }, py::arg("run_dir"), "tribo-fit metrics RUN_DIR --json (JSON text).");

  m.def("diagnose", [](const py::dict& columns, std::optional<std::vector<std::string>> effects, double begin_s,
                       double end_s, const std::string& source, const std::string& base_model) {
    const auto candidates = effects_from(effects);
    const bool choose = choose_base_contact(base_model);
    const std::vector<Sample> samples = samples_from_columns(columns);
    py::gil_scoped_release release;
    return diagnose_run_series(analysis::series_from_samples(samples, source), candidates, begin_s, end_s, choose);
  }, py::arg("samples"), py::arg("effects") = py::none(), py::arg("begin_s") = -HUGE_VAL,
     py::arg("end_s") = HUGE_VAL, py::arg("source") = "python", py::arg("base_model") = "lugre",
     "tribo-fit diagnose --json on sample columns (JSON text).");

  py::list scorecard_groups;
  for (std::string_view g : scorecard::kGroups) scorecard_groups.append(std::string(g));
  m.attr("scorecard_groups") = scorecard_groups;

  m.def("scorecard", [](const py::handle& config, std::optional<std::vector<std::string>> groups, bool quick,
                        std::uint64_t seed, const std::string& config_name) {
    const v1::DaemonConfig parsed = checked_config(config);
    if (parsed.backend_case() != v1::DaemonConfig::kSim) {
      raise_validation("backend", "the scorecard needs the simulated backend (config field sim)");
    }
    scorecard::ScorecardOptions options;
    options.quick = quick;
    options.seed = seed;
    if (groups) {
      for (const std::string& g : *groups) {
        if (std::find(scorecard::kGroups.begin(), scorecard::kGroups.end(), g) == scorecard::kGroups.end()) {
          throw py::value_error("unknown scorecard group '" + g + "'");
        }
      }
      options.groups = *groups;
    }
    py::gil_scoped_release release;
    return scorecard::format_json(scorecard::run_scorecard(parsed, options), config_name);
  }, py::arg("config"), py::arg("groups") = py::none(), py::arg("quick") = false, py::arg("seed") = 1,
     py::arg("config_name") = "python",
     "tribo-scorecard --json on a config (JSON text): the dissertation's experiments on the simulated instrument.");

  m.def("diagnose_run", [](const std::string& run_dir, std::optional<std::vector<std::string>> effects,
                           double begin_s, double end_s, const std::string& base_model) {
    const auto candidates = effects_from(effects);
    const bool choose = choose_base_contact(base_model);
    py::gil_scoped_release release;
    std::string error;
    auto series = analysis::read_run_series(run_dir, error);
    if (!series) throw std::runtime_error(error);
    return diagnose_run_series(std::move(*series), candidates, begin_s, end_s, choose);
  }, py::arg("run_dir"), py::arg("effects") = py::none(), py::arg("begin_s") = -HUGE_VAL,
     py::arg("end_s") = HUGE_VAL, py::arg("base_model") = "lugre", "tribo-fit diagnose RUN_DIR --json (JSON text).");
}
