"""tribo in-process: the daemon's validator, the simulated instrument and the
analyses of tribo-fit, through the native module tribo_native (pybind11, built
by CMake with the rest of tribo). Configs and protocols are accepted as a file
path, protobuf text, a dict (the JSON form, proto field names) or a message.

    from tribo_client import sim
    config = sim.load_config("config/tribod.textproto")
    run = sim.simulate(config, "config/protocols/standard_scratch.textproto", seed=3)
    run.samples["lateral_force"]      # numpy, N: tribod's recording bit for bit
    sim.metrics(run)                  # == tribo-fit metrics RUN --json
    sim.diagnose(run)                 # == tribo-fit diagnose RUN --json
"""

import json
import os

from google.protobuf import json_format, text_format

from .channels import NAMES
from .friction_models import read_friction_reports, set_friction_model
from .runs import RunData

try:
    import tribo_native as _native
except ImportError as e:  # pragma: no cover - a setup problem, said plainly
    raise ImportError(
        "tribo_native not found: build it (scripts/build tribo_native, needs pybind11-dev) and put "
        "build/python on PYTHONPATH, or pip install client/python after building") from e

from tribo.v1 import daemon_config_pb2, protocol_pb2  # noqa: E402

software_version = _native.software_version


class ValidationError(ValueError):
    """A config or protocol the daemon refuses: .field names the field (e.g.
    "segments[2].normal.end_uN"), .message says the value and the limit."""

    def __init__(self, message, field=""):
        super().__init__(f"{field}: {message}" if field and not message.startswith(field) else message)
        self.message = message
        self.field = field


def _native_call(function, *args, **kwargs):
    try:
        return function(*args, **kwargs)
    except _native.ValidationError as e:
        message, field = (e.args + ("", ""))[:2]
        raise ValidationError(message, field) from None


def _message(source, message_type):
    if isinstance(source, message_type):
        return source
    if isinstance(source, dict):
        return json_format.ParseDict(source, message_type())
    if isinstance(source, bytes):  # wire format
        return message_type.FromString(source)
    if isinstance(source, (str, os.PathLike)) and os.path.exists(source):
        with open(source, encoding="utf-8") as f:
            source = f.read()
    if isinstance(source, str):
        message = message_type()
        try:
            text_format.Parse(source, message)
        except text_format.ParseError as e:
            raise ValidationError(str(e)) from None
        return message
    raise TypeError(f"expected a path, text, dict or {message_type.__name__}, got {type(source).__name__}")


def load_config(source="config/tribod.textproto"):
    """A validated tribo.v1.DaemonConfig (ValidationError names the field).
    source: a path, protobuf text, wire-format bytes, a dict or a message."""
    config = _message(source, daemon_config_pb2.DaemonConfig)
    _native_call(_native.validate_config, config.SerializeToString())
    return config


def load_protocol(source, friction_model=None):
    """A tribo.v1.Protocol (parsed only; check() validates it against a
    config). From a path, the friction model reports it names are read in
    (relative to its directory); friction_model: a `tribo-fit diagnose --json`
    report that compensates every displacement segment instead (as `tribo run
    --friction-model`, docs/friction_compensation.md)."""
    protocol = _message(source, protocol_pb2.Protocol)
    if isinstance(source, (str, os.PathLike)) and os.path.exists(source):
        protocol = read_friction_reports(protocol, os.path.dirname(os.path.abspath(source)))
    if friction_model is not None:
        copy = protocol_pb2.Protocol()
        copy.CopyFrom(protocol)
        protocol = set_friction_model(copy, friction_model)
    return protocol


def check(config, protocol):
    """The daemon's dry run: {duration_s, expected_samples, warnings,
    segment_names, friction_models} (friction_models: the models the run would
    compensate with, as its start document records them)."""
    return _native_call(_native.validate_protocol, load_protocol(protocol).SerializeToString(),
                        _message(config, daemon_config_pb2.DaemonConfig).SerializeToString())


class SimulatedRun(RunData):
    """A run of the simulated instrument in-process (RunData with the start
    document's essentials: seed, config, protocol, software version)."""


def simulate(config, protocol, seed=None, friction_model=None):
    """Runs the protocol on the simulated instrument unpaced, in this process,
    through the daemon's real-time loop; the GIL is released meanwhile. The
    samples are those tribod records for the same config, protocol and seed
    (seed None: the config's sim.seed, as tribod). friction_model: a
    `tribo-fit diagnose --json` report (path) whose model the lateral loop
    compensates (as `tribo run --friction-model`)."""
    config = _message(config, daemon_config_pb2.DaemonConfig)
    protocol = load_protocol(protocol, friction_model)
    if seed is None:
        seed = config.sim.seed
    result = _native_call(_native.simulate, config.SerializeToString(), protocol.SerializeToString(), int(seed))
    summary = result["protocol"]
    metadata = {
        "start": {"seed": str(seed), "software_version": software_version,
                  "protocol": json_format.MessageToDict(protocol, preserving_proto_field_name=True),
                  "config": json_format.MessageToDict(config, preserving_proto_field_name=True),
                  "friction_models": summary["friction_models"]},
        "run_descriptor": {"segment_names": summary["segment_names"]},
        "stop": {"exit_status": result["exit_status"], "reason": result["trip_reason"],
                 "sample_count": str(len(result["samples"]["t"])), "cycle_count": str(result["cycles"])},
    }
    run = SimulatedRun(result["samples"], metadata)
    run.warnings = summary["warnings"]
    return run


def _columns(run):
    samples = run.samples if hasattr(run, "samples") else run
    return {name: samples[name] for name in NAMES}


def metrics(run):
    """`tribo-fit metrics --json` as Python objects, for a run folder (path),
    a RunData/Run or a dict of channel arrays."""
    if isinstance(run, (str, os.PathLike)):
        return json.loads(_native.metrics_of_run(os.fspath(run)))
    return json.loads(_native.metrics(_columns(run)))


def diagnose(run, effects=None, begin_s=None, end_s=None, base_model="lugre"):
    """`tribo-fit diagnose --json` as Python objects (the same JSON contract,
    docs/identification.md), for a run folder (path), a RunData/Run or a dict
    of channel arrays. effects: candidate names (default all). base_model:
    "lugre" or "choose" (tribo-fit's --base-model: the contact law chosen on
    held-out data)."""
    window = {"begin_s": -float("inf") if begin_s is None else begin_s,
              "end_s": float("inf") if end_s is None else end_s}
    if isinstance(run, (str, os.PathLike)):
        text = _native.diagnose_run(os.fspath(run), effects, base_model=base_model, **window)
    else:
        text = _native.diagnose(_columns(run), effects, source=getattr(run, "path", None) or "python",
                                base_model=base_model, **window)
    return json.loads(text)


scorecard_groups = tuple(_native.scorecard_groups)


def scorecard(config, groups=None, quick=False, seed=1):
    """`tribo-scorecard --json` as Python objects: the dissertation's
    experiments run on this config's simulated instrument (its sim and
    controller sections), rows of observation, dissertation, simulated,
    error (docs/simulated_instrument.md). groups: names of scorecard_groups
    (default all); quick: without the 1000 s experiments. The GIL is released
    while it runs."""
    config = _message(config, daemon_config_pb2.DaemonConfig)
    if groups is not None:
        unknown = [g for g in groups if g not in scorecard_groups]
        if unknown:
            raise ValidationError(f"unknown scorecard group(s) {', '.join(unknown)} "
                                  f"(known: {', '.join(scorecard_groups)})", "groups")
    text = _native_call(_native.scorecard, config.SerializeToString(), None if groups is None else list(groups),
                        bool(quick), int(seed))
    return json.loads(text)
