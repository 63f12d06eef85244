"""Reading a recorded run folder (RUN/metadata.json + RUN/samples.csv, the
layout of proto/run_files.h that tribod, `tribo run --out` and `tribo fetch`
write) into numpy arrays or a pandas DataFrame, with units.

    from tribo_client import read_run
    run = read_run("runs/20261123T101500Z")
    run.samples["lateral_force"]        # numpy array, N
    run.units["lateral_force"]          # "N"
    run.exit_status                     # "SUCCESS"
    df = run.to_dataframe()             # columns by channel name, df.attrs["units"]
"""

import json
import os

import numpy as np

from .channels import CHANNELS, INTEGER_CHANNELS, NAMES, UNITS

METADATA_FILE = "metadata.json"
SAMPLES_FILE = "samples.csv"


class RunData:
    """A recorded (or in-process simulated) run: samples by channel name in SI
    units, the run documents as dicts (proto field names, enums by name)."""

    def __init__(self, samples, metadata=None, path=None):
        self.samples = samples
        self.metadata = metadata or {}
        self.path = path
        self.units = dict(UNITS)

    @property
    def start(self):
        return self.metadata.get("start", {})

    @property
    def stop(self):
        return self.metadata.get("stop")

    @property
    def run_id(self):
        return self.start.get("run_id", "")

    @property
    def exit_status(self):
        """SUCCESS, ABORT or FAULT; None while the run is still recording."""
        stop = self.stop
        return stop.get("exit_status", "EXIT_STATUS_UNSPECIFIED") if stop is not None else None

    @property
    def seed(self):
        return int(self.start.get("seed", 0))

    @property
    def protocol_name(self):
        return self.start.get("protocol", {}).get("name", "")

    @property
    def segment_names(self):
        """Names by segment index, repeat blocks unrolled (the descriptor's)."""
        names = self.metadata.get("run_descriptor", {}).get("segment_names")
        if names:
            return list(names)
        return [s.get("name", "") for s in self.start.get("segments", [])]

    def __len__(self):
        return len(self.samples["t"])

    def to_dataframe(self):
        return samples_dataframe(self.samples, self.segment_names)


def samples_dataframe(samples, segment_names=()):
    """Samples as a DataFrame: one column per channel (channel names), plus
    segment_name when the names are known; units in df.attrs["units"]."""
    import pandas as pd
    df = pd.DataFrame({name: samples[name] for name in NAMES})
    if len(segment_names):
        names = np.asarray(list(segment_names) + [""], dtype=object)
        index = np.minimum(df["segment"].to_numpy(), len(segment_names))
        df["segment_name"] = pd.Categorical(names[index])
    df.attrs["units"] = dict(UNITS)
    return df


def _channel_of_column(column, units):
    """lateral_force_N -> lateral_force, by the descriptor's (or the built-in) units."""
    for name, unit in units.items():
        if column == f"{name}_{unit}":
            return name
    raise ValueError(f"{column!r} is not a tribo channel column (name_unit, e.g. lateral_force_N)")


def read_samples_csv(path, units=None):
    """samples.csv into {channel name: numpy array}; every double read back
    exactly (the recorder writes round-trip text). Only complete rows count: a
    torn last line (a crash mid-write) is dropped, as the C++ reader does."""
    units = units or UNITS
    with open(path, "rb") as f:
        data = f.read()
    end = data.rfind(b"\n")
    header_end = data.find(b"\n")
    if header_end < 0:
        raise ValueError(f"{path}: no header line")
    header = data[:header_end].decode("ascii").strip().split(",")
    names = [_channel_of_column(c, units) for c in header]
    body = data[header_end + 1:end + 1]
    if not body:
        return {name: np.zeros(0, dtype=np.uint32 if name in INTEGER_CHANNELS else float) for name in names}
    import io
    import pandas as pd
    frame = pd.read_csv(io.BytesIO(body), header=None, names=names, float_precision="round_trip",
                        dtype={n: (np.uint32 if n in INTEGER_CHANNELS else np.float64) for n in names})
    return {name: frame[name].to_numpy() for name in names}


def read_run(path):
    """A run folder as RunData. metadata.json is optional (samples alone read)."""
    metadata = {}
    meta_path = os.path.join(path, METADATA_FILE)
    if os.path.exists(meta_path):
        with open(meta_path, encoding="utf-8") as f:
            metadata = json.load(f)
    units = dict(UNITS)
    for channel in metadata.get("run_descriptor", {}).get("channels", []):
        if "name" in channel and "unit" in channel:
            units[channel["name"]] = channel["unit"]
    samples = read_samples_csv(os.path.join(path, SAMPLES_FILE), units)
    missing = [c.name for c in CHANNELS if c.name not in samples]
    if missing:
        raise ValueError(f"{path}: samples.csv lacks the channels {', '.join(missing)}")
    return RunData(samples, metadata, path)
