"""The channel vocabulary: one name and one unit per channel, the same in the
run descriptor, the recorder's CSV header (name + "_" + unit), the C++ table
(proto/sample_record.h, kSampleChannels) and every array this package returns.
SI units throughout; user-facing figures convert at the edge (µN, µm)."""

import collections

Channel = collections.namedtuple("Channel", "name unit description block_field")

CHANNELS = (
    Channel("t", "s", "time since run start", "time_s"),
    Channel("segment", "index", "protocol segment being executed (0-based)", "segment_index"),
    Channel("normal_setpoint", "N", "commanded normal force", "normal_setpoint_n"),
    Channel("normal_force", "N", "measured normal (contact) force", "normal_force_n"),
    Channel("normal_displacement", "m", "measured normal displacement", "normal_displacement_m"),
    Channel("lateral_setpoint", "m", "commanded lateral position", "lateral_setpoint_m"),
    Channel("lateral_position", "m", "measured lateral position", "lateral_position_m"),
    Channel("lateral_force", "N", "measured lateral force (drive minus spring)", "lateral_force_n"),
    Channel("flags", "bits", "tribo.v1.StatusFlag bits", "status_flags"),
)
NAMES = tuple(c.name for c in CHANNELS)
UNITS = {c.name: c.unit for c in CHANNELS}
BY_NAME = {c.name: c for c in CHANNELS}
INTEGER_CHANNELS = frozenset({"segment", "flags"})


def csv_column(name, unit=None):
    """The recorder's CSV column of a channel: lateral_force -> lateral_force_N."""
    return f"{name}_{unit if unit is not None else UNITS[name]}"


def dtype_of(name):
    import numpy as np
    return np.uint32 if name in INTEGER_CHANNELS else np.float64
