"""A 3 s scratch (the standard scratch shortened, as the Python tests use) for
bench/campaign_bench.py's per-run overhead, written to a temporary file."""

import os
import tempfile

from google.protobuf import text_format

SOURCE_DIR = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))


def short_scratch_path():
    from tribo_client import load_protocol_file
    p = load_protocol_file(os.path.join(SOURCE_DIR, "config/protocols/standard_scratch.textproto"))
    p.name = "short-scratch"
    for seg, duration in zip(p.segments, (0.5, 0.5, 1.0, 0.5, 0.5)):
        seg.duration_s = duration
    p.segments[2].lateral.end_um = 2.5
    p.segments[3].lateral.end_um = 2.5
    fd, path = tempfile.mkstemp(suffix=".textproto")
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(text_format.MessageToString(p))
    return path
