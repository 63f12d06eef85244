"""Shared by the Python tests: where the build and the sources are, a tribod
started on 127.0.0.1 with an ephemeral port and its own data directory, and a
short protocol (3 s, 3000 samples) to keep the tests quick."""

import argparse
import os
import subprocess
import sys
import unittest

from tribo_client import load_protocol_file


class _Args:
    source_dir = build_dir = tribod = tribo_fit = tribo_cli = None

    def configure(self, args):
        self.source_dir = os.path.abspath(args.source_dir)
        self.build_dir = os.path.abspath(args.build_dir)
        self.tribod = os.path.join(self.build_dir, "daemon", "tribod")
        self.tribo_fit = os.path.join(self.build_dir, "analysis", "tribo-fit")
        self.tribo_cli = os.path.join(self.build_dir, "client", "tribo")


ARGS = _Args()


def short_protocol():
    p = load_protocol_file(os.path.join(ARGS.source_dir, "config/protocols/standard_scratch.textproto"))
    p.name = "short-scratch"
    for seg, duration in zip(p.segments, (0.5, 0.5, 1.0, 0.5, 0.5)):
        seg.duration_s = duration
    p.segments[2].lateral.end_um = 2.5
    p.segments[3].lateral.end_um = 2.5
    return p


class Daemon:
    """tribod on 127.0.0.1:0 (it prints the port it got); stop() ends it."""

    def __init__(self, data_dir, config=None):
        self.proc = subprocess.Popen(
            [ARGS.tribod, "--config", config or os.path.join(ARGS.source_dir, "config/tribod.textproto"),
             "--port", "0", "--data-dir", data_dir],
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        line = self.proc.stdout.readline()  # "tribod listening on 127.0.0.1:PORT"
        if "listening" not in line:
            self.proc.kill()
            raise RuntimeError(f"tribod did not start: {line!r}")
        self.address = line.split()[-1]

    def stop(self):
        self.proc.terminate()
        self.proc.wait(timeout=30)
        self.proc.stdout.close()


def identification_short():
    """The 19 s cut of the identification protocol of the tiny reliability
    campaign (config/campaigns/identification_reliability_tiny.toml)."""
    import tomllib
    from google.protobuf import text_format
    from tribo.v1 import protocol_pb2
    with open(os.path.join(ARGS.source_dir, "config/campaigns/identification_reliability_tiny.toml"), "rb") as f:
        spec = tomllib.load(f)
    return text_format.Parse(spec["protocols"][0]["text"], protocol_pb2.Protocol())


def main():
    """Runs the calling test file's tests: --build-dir and --source-dir say
    where the build and the sources are; other arguments go to unittest."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--build-dir", required=True)
    parser.add_argument("--source-dir", required=True)
    args, rest = parser.parse_known_args()
    ARGS.configure(args)
    unittest.main(module="__main__", argv=[sys.argv[0]] + rest, verbosity=2)
