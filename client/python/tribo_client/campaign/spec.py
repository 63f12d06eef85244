"""A campaign spec (TOML, docs/campaigns.md): which runs, and what to compute
on each. Expanded into a list of RunTask before anything runs; every config
override path is resolved against the tribo.v1.DaemonConfig schema and every
resulting config and protocol is validated by the daemon's validator, so a
bad path or value is refused up front, naming the field.

    name = "friction-vs-load"
    config = "../tribod.textproto"          # relative to the spec file
    seeds = [1, 2, 3]                        # or {first = 1, count = 3}
    compute = ["metrics", "diagnosis"]
    [overrides]                              # applied to every run
    "controller.lateral_displacement.setpoint_weight_p" = 1
    [[protocols]]
    path = "../protocols/standard_scratch.textproto"
    [grid]                                   # every combination
    "sim.sensors.lateral_force_noise_n" = [5e-6, 10e-6]
    [[variants]]                             # crossed with grid, protocols, seeds
    label = "asymmetry 5%"
    tags = {effect = "direction_asymmetry", strength = 0.05}
    overrides = {"sim.friction.direction_asymmetry.enabled" = true}

friction_model = "report.json" (a `tribo-fit diagnose --json` report, relative
to the spec file) compensates friction in every run (as `tribo run
--friction-model`, docs/friction_compensation.md); a [[protocols]] entry or a
[[variants]] entry may set its own (a variant's "" runs without), and the
model's file is a row label (friction_model).

compute = ["scorecard"] alone runs the reproduction scorecard (tribo-scorecard)
on each config and seed and takes no [[protocols]] (its experiments are its
own); [scorecard] groups = [...] and quick = true choose its experiments.
"""

import copy
import hashlib
import itertools
import json
import os
import tomllib

from google.protobuf import text_format
from google.protobuf.descriptor import FieldDescriptor

from tribo.v1 import daemon_config_pb2, protocol_pb2

from ..friction_models import read_friction_reports, set_friction_model

COMPUTATIONS = ("metrics", "diagnosis", "scorecard")
SCORECARD_OPTIONS = ("groups", "quick")


class SpecError(ValueError):
    """A spec the campaign refuses before any run starts; .field names the
    config field path or spec key at fault."""

    def __init__(self, message, field=""):
        super().__init__(message)
        self.field = field


class RunTask:
    """One run of a campaign: everything a worker needs, and the row keys."""

    def __init__(self, key, index, protocol_name, protocol_bytes, config_bytes, seed, labels, compute, diagnosis,
                 scorecard=None):
        self.key = key
        self.index = index
        self.protocol_name = protocol_name
        self.protocol_bytes = protocol_bytes
        self.config_bytes = config_bytes
        self.seed = seed
        self.labels = labels          # column -> value: variant, tags, overrides
        self.compute = compute
        self.diagnosis = diagnosis    # {"effects": [...], "begin_s": ..., "end_s": ...}
        self.scorecard = scorecard or {}  # {"groups": [...], "quick": bool}; protocol_bytes b"" if none


class Campaign:
    def __init__(self, name, tasks, spec_path, report, base_config_path, grid_paths=()):
        self.name = name
        self.grid_paths = list(grid_paths)
        self.tasks = tasks
        self.spec_path = spec_path
        self.report = report
        self.base_config_path = base_config_path


def set_field(message, path, value):
    """Sets message.<path> = value, the path resolved against the schema;
    SpecError names the path and what is wrong with it."""
    parts = path.split(".")
    target = message
    for depth, part in enumerate(parts):
        descriptor = target.DESCRIPTOR
        field = descriptor.fields_by_name.get(part)
        where = ".".join(parts[:depth + 1])
        if field is None:
            known = ", ".join(sorted(descriptor.fields_by_name))
            raise SpecError(f"config override '{path}': {descriptor.full_name} has no field '{part}' "
                            f"(its fields: {known})", path)
        last = depth == len(parts) - 1
        if field.type == FieldDescriptor.TYPE_MESSAGE and field.label != FieldDescriptor.LABEL_REPEATED:
            if last:
                raise SpecError(f"config override '{path}' names a message ({field.message_type.full_name}); "
                                f"override its fields, e.g. '{path}.{field.message_type.fields[0].name}'", path)
            target = getattr(target, part)
            continue
        if not last:
            raise SpecError(f"config override '{path}': '{where}' is not a message, it has no field "
                            f"'{parts[depth + 1]}'", path)
        try:
            if field.label == FieldDescriptor.LABEL_REPEATED:
                if field.type == FieldDescriptor.TYPE_MESSAGE:
                    raise SpecError(f"config override '{path}': repeated messages cannot be overridden", path)
                del getattr(target, part)[:]
                getattr(target, part).extend(_convert(field, v) for v in value)
            else:
                setattr(target, part, _convert(field, value))
        except (TypeError, ValueError) as e:
            if isinstance(e, SpecError):
                raise
            raise SpecError(f"config override '{path}' = {value!r}: {e}", path) from None


def _convert(field, value):
    if field.type == FieldDescriptor.TYPE_ENUM and isinstance(value, str):
        enum = field.enum_type.values_by_name.get(value)
        if enum is None:
            names = ", ".join(v.name for v in field.enum_type.values)
            raise ValueError(f"{value!r} is not one of {names}")
        return enum.number
    if field.type in (FieldDescriptor.TYPE_DOUBLE, FieldDescriptor.TYPE_FLOAT) and isinstance(value, int) \
            and not isinstance(value, bool):
        return float(value)
    return value


def _seeds(spec):
    seeds = spec.get("seeds", [1])
    if isinstance(seeds, dict):
        first, count = int(seeds.get("first", 1)), int(seeds["count"])
        return list(range(first, first + count))
    if isinstance(seeds, int):
        return [seeds]
    return [int(s) for s in seeds]


def _read_text(base_dir, entry, what):
    if "text" in entry:
        return entry["text"], "<inline>"
    if "path" not in entry:
        raise SpecError(f"{what} needs 'path' or 'text'", what)
    path = os.path.join(base_dir, entry["path"])
    try:
        with open(path, encoding="utf-8") as f:
            return f.read(), path
    except OSError as e:
        raise SpecError(f"{what}: cannot read {path}: {e.strerror}", what) from None


def _key(*parts):
    digest = hashlib.sha256()
    for p in parts:
        digest.update(p if isinstance(p, bytes) else json.dumps(p, sort_keys=True, default=str).encode())
        digest.update(b"\0")
    return digest.hexdigest()[:16]


def load_spec(path, validate=None):
    """Reads and expands a spec. validate(config_bytes, protocol_bytes) (the
    native validator, tribo_client.sim) checks every config and protocol
    pair; ValidationError propagates with its field."""
    try:
        with open(path, "rb") as f:
            spec = tomllib.load(f)
    except OSError as e:
        raise SpecError(f"cannot read {path}: {e.strerror}") from None
    except tomllib.TOMLDecodeError as e:
        raise SpecError(f"{path}: {e}") from None
    base_dir = os.path.dirname(os.path.abspath(path))
    known = {"name", "config", "seeds", "compute", "overrides", "protocols", "grid", "variants", "diagnosis",
             "report", "description", "scorecard", "friction_model"}
    unknown = sorted(set(spec) - known)
    if unknown:
        raise SpecError(f"{path}: unknown key(s) {', '.join(unknown)} (known: {', '.join(sorted(known))})",
                        unknown[0])
    name = spec.get("name") or os.path.splitext(os.path.basename(path))[0]
    config_text, config_path = _read_text(base_dir, {"path": spec.get("config", "../tribod.textproto")}, "config")
    base = daemon_config_pb2.DaemonConfig()
    text_format.Parse(config_text, base)
    for field_path, value in spec.get("overrides", {}).items():
        set_field(base, field_path, value)

    compute = list(spec.get("compute", ["metrics"]))
    for c in compute:
        if c not in COMPUTATIONS:
            raise SpecError(f"compute: unknown computation '{c}' (one of {', '.join(COMPUTATIONS)})", "compute")
    diagnosis = dict(spec.get("diagnosis", {}))
    if diagnosis.get("base_model", "lugre") not in ("lugre", "choose"):
        raise SpecError(f"diagnosis.base_model: '{diagnosis['base_model']}' is not 'lugre' or 'choose'",
                        "diagnosis.base_model")
    scorecard = _scorecard_options(spec, compute)

    protocols = []
    for i, entry in enumerate(spec.get("protocols", [])):
        text, source = _read_text(base_dir, entry, f"protocols[{i}]")
        message = protocol_pb2.Protocol()
        try:
            text_format.Parse(text, message)
        except text_format.ParseError as e:
            raise SpecError(f"protocols[{i}] ({source}): {e}", f"protocols[{i}]") from None
        for field_path, value in entry.get("overrides", {}).items():
            set_field(message, field_path, value)
        try:
            read_friction_reports(message, os.path.dirname(source) if "path" in entry else base_dir)
        except OSError as e:
            raise SpecError(f"protocols[{i}] ({source}): {e}", f"protocols[{i}]") from None
        protocols.append((entry.get("name", message.name), message, entry.get("friction_model", spec.get("friction_model"))))
    if compute == ["scorecard"]:
        if protocols:
            raise SpecError("a scorecard-only campaign takes no [[protocols]]: the scorecard runs its own "
                            "experiments on each config", "protocols")
        protocols = [("", None, None)]
    elif not protocols:
        raise SpecError("the spec declares no [[protocols]]", "protocols")

    grid = spec.get("grid", {})
    grid_paths = list(grid)
    grid_values = [v if isinstance(v, list) else [v] for v in grid.values()]
    variants = spec.get("variants", [{"label": ""}])
    seeds = _seeds(spec)

    # Every override path first (cheap, and names the field before anything runs).
    probe = copy.deepcopy(base)
    for field_path, values in zip(grid_paths, grid_values):
        set_field(probe, field_path, values[0])
    for v in variants:
        for field_path, value in v.get("overrides", {}).items():
            set_field(copy.deepcopy(base), field_path, value)

    _check_report(spec.get("report", {}), grid_paths)

    tasks = []
    validated = set()
    for protocol_name, message, protocol_model in protocols:
        for variant in variants:
            model = variant.get("friction_model", protocol_model)
            protocol_bytes = _with_friction_model(message, model, base_dir)
            for combination in itertools.product(*grid_values):
                config = copy.deepcopy(base)
                labels = {"protocol": protocol_name, "variant": variant.get("label", "")} if protocol_bytes \
                    else {"variant": variant.get("label", "")}
                if model:
                    labels["friction_model"] = model
                labels.update(variant.get("tags", {}))
                for field_path, value in variant.get("overrides", {}).items():
                    set_field(config, field_path, value)
                for field_path, value in zip(grid_paths, combination):
                    set_field(config, field_path, value)
                    labels[field_path] = value
                config_bytes = config.SerializeToString(deterministic=True)
                if validate and (config_bytes, protocol_bytes) not in validated:
                    validate(config_bytes, protocol_bytes)
                    validated.add((config_bytes, protocol_bytes))
                for seed in seeds:
                    # The scorecard's options join the key only when it runs (older keys stay valid).
                    key = _key(config_bytes, protocol_bytes, seed, compute, diagnosis,
                               *([scorecard] if scorecard else []))
                    tasks.append(RunTask(key, len(tasks), protocol_name, protocol_bytes, config_bytes, seed,
                                         dict(labels), compute, diagnosis, scorecard))
    return Campaign(name, tasks, os.path.abspath(path), spec.get("report", {}), config_path, grid_paths)


def _with_friction_model(message, model, base_dir):
    """The protocol's wire bytes, compensated with the report at model
    (relative to the spec) unless model is None or "" (b"" for no protocol)."""
    if message is None:
        return b""
    if not model:
        return message.SerializeToString()
    copy = protocol_pb2.Protocol()
    copy.CopyFrom(message)
    try:
        set_friction_model(copy, os.path.join(base_dir, model))
    except OSError as e:
        raise SpecError(f"friction_model: cannot read {os.path.join(base_dir, model)}: {e.strerror}",
                        "friction_model") from None
    return copy.SerializeToString()


def _scorecard_options(spec, compute):
    """[scorecard] groups (names of tribo-scorecard --group) and quick; {}
    when the scorecard is not computed."""
    options = dict(spec.get("scorecard", {}))
    if "scorecard" not in compute:
        if options:
            raise SpecError("[scorecard] options given but compute does not include \"scorecard\"", "scorecard")
        return {}
    unknown = sorted(set(options) - set(SCORECARD_OPTIONS))
    if unknown:
        raise SpecError(f"scorecard: unknown option(s) {', '.join(unknown)} (known: {', '.join(SCORECARD_OPTIONS)})",
                        f"scorecard.{unknown[0]}")
    from tribo_client.sim import scorecard_groups  # the native module's list: one source of the names
    groups = options.get("groups")
    if groups is not None:
        if not isinstance(groups, list) or not groups:
            raise SpecError("scorecard.groups must be a non-empty list of group names", "scorecard.groups")
        unknown = [g for g in groups if g not in scorecard_groups]
        if unknown:
            raise SpecError(f"scorecard.groups: unknown group(s) {', '.join(map(str, unknown))} "
                            f"(known: {', '.join(scorecard_groups)})", "scorecard.groups")
    if not isinstance(options.get("quick", False), bool):
        raise SpecError("scorecard.quick must be true or false", "scorecard.quick")
    return {"groups": list(groups) if groups is not None else None, "quick": options.get("quick", False)}


def _check_report(report, grid_paths):
    """A scorecard_sweep report plots against grid columns: they must exist."""
    if report.get("kind") != "scorecard_sweep":
        return
    for option in ("x", "lines"):
        value = report.get(option)
        if value is None and option == "lines":
            continue
        if value not in grid_paths:
            raise SpecError(f"report.{option} = {value!r} must be one of the [grid] paths "
                            f"({', '.join(grid_paths) or 'none'})", f"report.{option}")
