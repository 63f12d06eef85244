"""A blocking client: handshake, requests matched by id, run documents queued
for events(), runs streamed into numpy arrays with gaps fetched back from the
daemon's recording."""

import collections
import os
import socket

import numpy as np
from google.protobuf import text_format

from .channels import CHANNELS, INTEGER_CHANNELS, NAMES
from .framing import encode_frame, read_frame
from .friction_models import read_friction_reports, set_friction_model
from .records import as_record

try:
    from tribo.v1 import api_pb2, protocol_pb2
except ImportError as e:  # pragma: no cover - a setup problem, said plainly
    raise ImportError(
        "tribo.v1 protobuf modules not found: build the project (cmake) and add "
        "build/python to PYTHONPATH") from e

API_VERSION = 1
DEFAULT_ADDRESS = "127.0.0.1:7460"
# The SampleBlock field carrying each channel (tribo_client/channels.py).
_BLOCK_FIELDS = {c.name: c.block_field for c in CHANNELS}
_ROLES = {"observer": api_pb2.OBSERVER, "controller": api_pb2.CONTROLLER}
# The controller's loops by the tribo CLI's names (tribo.v1.ControlLoop).
LOOPS = {"lateral-displacement": api_pb2.LOOP_LATERAL_DISPLACEMENT,
         "lateral-force": api_pb2.LOOP_LATERAL_FORCE,
         "normal-force": api_pb2.LOOP_NORMAL_FORCE,
         "normal-displacement": api_pb2.LOOP_NORMAL_DISPLACEMENT}


def _loop(loop):
    """A ControlLoop from a CLI name, an enum name or the enum value."""
    if isinstance(loop, int):
        return loop
    if loop in LOOPS:
        return LOOPS[loop]
    try:
        return api_pb2.ControlLoop.Value(loop.upper())
    except ValueError:
        raise ValueError(f"{loop!r} is not a control loop (one of {', '.join(LOOPS)})") from None


class TriboError(Exception):
    """The daemon's typed error (code, field, message), or a transport failure."""

    def __init__(self, error):
        self.code = api_pb2.ErrorCode.Name(error.code)
        self.field = error.field
        self.message = error.message
        super().__init__(f"{self.code}: {self.field + ': ' if self.field else ''}{self.message}")


def load_protocol_file(path, friction_model=None):
    """Parses a protocol file (protobuf text format, tribo.v1.Protocol), with
    the friction model reports it names read in (relative to its directory);
    friction_model: a `tribo-fit diagnose --json` report that compensates
    every displacement segment instead (as `tribo run --friction-model`)."""
    with open(path, encoding="utf-8") as f:
        protocol = text_format.Parse(f.read(), protocol_pb2.Protocol())
    read_friction_reports(protocol, os.path.dirname(os.path.abspath(path)))
    return set_friction_model(protocol, friction_model)


def _parse_address(address):
    host, _, port = address.rpartition(":")
    return (host or "127.0.0.1", int(port))


class Run:
    """One run as a client saw it: documents and samples as numpy arrays,
    keyed by channel name (run.samples["lateral_force"], in N; units in
    tribo_client.UNITS and run.units)."""

    units = dict((c.name, c.unit) for c in CHANNELS)

    def __init__(self, run_id):
        self.run_id = run_id
        self.start = None
        self.descriptor = None
        self.stop = None
        self.segment_events = []
        self.faults = []
        self.gaps = []
        self.fetched_samples = 0
        self.sequence = np.zeros(0, dtype=np.uint64)
        self.samples = {name: np.zeros(0) for name in NAMES}
        self._blocks = []

    @property
    def exit_status(self):
        return api_pb2.ExitStatus.Name(self.stop.exit_status) if self.stop else None

    def add_block(self, block, decimation=1):
        n = len(block.time_s)
        if n == 0:
            return
        seq = block.first_sequence + decimation * np.arange(n, dtype=np.uint64)
        self._blocks.append((seq, {name: np.asarray(getattr(block, field),
                                                    dtype=np.uint32 if name in INTEGER_CHANNELS else float)
                                   for name, field in _BLOCK_FIELDS.items()}))

    def assemble(self):
        """Orders everything received by sequence number, drops duplicates."""
        if not self._blocks:
            return
        seq = np.concatenate([b[0] for b in self._blocks])
        order = np.argsort(seq, kind="stable")
        seq = seq[order]
        keep = np.concatenate(([True], seq[1:] != seq[:-1]))
        self.sequence = seq[keep]
        for name in NAMES:
            self.samples[name] = np.concatenate([b[1][name] for b in self._blocks])[order][keep]

    @property
    def protocol_name(self):
        return self.start.protocol.name if self.start else ""

    @property
    def segment_names(self):
        """Segment names by segment index (repeat blocks unrolled)."""
        return list(self.descriptor.segment_names) if self.descriptor else []

    def to_dataframe(self):
        """The samples as a pandas DataFrame (units in df.attrs["units"])."""
        from .runs import samples_dataframe
        return samples_dataframe(self.samples, self.segment_names)


class Client:
    """A session with tribod. role: "observer" (default) or "controller"
    (token: the daemon's control token; default $TRIBO_TOKEN)."""

    def __init__(self, address=None, role="observer", token=None, name="tribo-python", timeout_s=60.0):
        address = address or os.environ.get("TRIBO_ADDRESS", DEFAULT_ADDRESS)
        self._sock = socket.create_connection(_parse_address(address), timeout=timeout_s)
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._next_id = 1
        self._events = collections.deque()
        hello = api_pb2.Hello(api_version=API_VERSION, client_name=name, role=_ROLES[role],
                              token=token if token is not None else os.environ.get("TRIBO_TOKEN", ""))
        # Enums by name: self.hello.role == "CONTROLLER".
        self.hello = as_record(self.request(hello=hello).hello)

    def close(self):
        self._sock.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # -- requests

    def request(self, **body):
        """Sends ClientMessage(body) and returns the reply (a ServerMessage);
        raises TriboError for an error reply."""
        message = api_pb2.ClientMessage(request_id=self._next_id, **body)
        self._next_id += 1
        self._sock.sendall(encode_frame(message))
        while True:
            reply = self._read()
            if reply.request_id == 0 and not reply.HasField("error"):
                self._events.append(reply)
                continue
            if reply.HasField("error"):
                raise TriboError(reply.error)
            if reply.request_id == message.request_id:
                return reply

    def _read(self):
        reply = api_pb2.ServerMessage()
        reply.ParseFromString(read_frame(self._sock))
        return reply

    def status(self):
        """The daemon's status, enums by name: status().state == "ARMED"."""
        return as_record(self.request(get_status=api_pb2.GetStatus()).status)

    def list_runs(self):
        return [as_record(r) for r in self.request(list_runs=api_pb2.ListRuns()).list_runs.runs]

    def subscribe(self, decimation=1):
        self.request(subscribe=api_pb2.Subscribe(decimation=decimation))

    def load_protocol(self, protocol):
        return self.request(load_protocol=api_pb2.LoadProtocol(protocol=protocol)).load_protocol

    def start_run(self, seed=None):
        start = api_pb2.StartRun() if seed is None else api_pb2.StartRun(seed=seed)
        return self.request(start_run=start).start_run.run_id

    def abort_run(self, reason=""):
        return self.request(abort_run=api_pb2.AbortRun(reason=reason)).abort_run

    # -- control (SI units: the loops' output is a drive force in N)

    def get_gains(self):
        """Every loop's gains: {"lateral-displacement": PidGains, ...}."""
        names = {v: k for k, v in LOOPS.items()}
        loops = self.request(get_gains=api_pb2.GetGains()).get_gains.loops
        return {names.get(l.loop, api_pb2.ControlLoop.Name(l.loop)): l.gains for l in loops}

    def set_gains(self, loop, **changes):
        """Changes only the given PidGains fields of one loop (kp=..., ki=...;
        needs the controller role) and returns the SetGainsReply: what the
        daemon applied."""
        loop = _loop(loop)
        gains = next(l.gains for l in self.request(get_gains=api_pb2.GetGains()).get_gains.loops
                     if l.loop == loop)
        for field, value in changes.items():
            setattr(gains, field, value)
        return self.request(set_gains=api_pb2.SetGains(loop=loop, gains=gains)).set_gains

    def rearm(self):
        return self.request(rearm=api_pb2.Rearm()).rearm

    def emergency_stop(self, reason=""):
        return self.request(emergency_stop=api_pb2.EmergencyStop(reason=reason)).emergency_stop

    def events(self):
        """Run documents (ServerMessage with request_id 0), blocking."""
        while True:
            if self._events:
                yield self._events.popleft()
                continue
            message = self._read()
            if message.request_id == 0:
                yield message

    # -- runs

    def run(self, protocol, seed=None, decimation=1, on_document=None, friction_model=None):
        """Loads and runs a protocol (needs the controller role), streams its
        samples into a Run; fetches any range the stream missed (decimation 1).
        friction_model: a `tribo-fit diagnose --json` report that compensates
        every displacement segment (as `tribo run --friction-model`)."""
        if friction_model is not None:
            copy = protocol_pb2.Protocol()
            copy.CopyFrom(protocol)
            protocol = set_friction_model(copy, friction_model)
        self.load_protocol(protocol)
        self.subscribe(decimation)
        run = Run(self.start_run(seed))
        for doc in self.events():
            if on_document:
                on_document(doc)
            kind = doc.WhichOneof("body")
            if kind == "samples" and doc.samples.run_id == run.run_id:
                run.add_block(doc.samples, decimation)
            elif kind == "run_start" and doc.run_start.run_id == run.run_id:
                run.start = doc.run_start
            elif kind == "run_descriptor" and doc.run_descriptor.run_id == run.run_id:
                run.descriptor = doc.run_descriptor
            elif kind == "segment_event" and doc.segment_event.run_id == run.run_id:
                run.segment_events.append(doc.segment_event)
            elif kind == "fault" and doc.fault.run_id == run.run_id:
                run.faults.append(doc.fault)
            elif kind == "gap" and doc.gap.run_id == run.run_id:
                run.gaps.append(doc.gap)
            elif kind == "run_stop" and doc.run_stop.run_id == run.run_id:
                run.stop = doc.run_stop
                break
        if decimation <= 1:
            for gap in run.gaps:
                for block in self._fetch_blocks(run.run_id, gap.first_sequence, gap.end_sequence):
                    run.add_block(block)
                    run.fetched_samples += len(block.time_s)
        run.assemble()
        return run

    def _fetch_blocks(self, run_id, start, end=None):
        while end is None or start < end:
            fetch = api_pb2.FetchSamples(run_id=run_id, from_sequence=start,
                                         max_samples=0 if end is None else end - start)
            page = self.request(fetch_samples=fetch).fetch_samples
            yield page.samples
            if page.next_sequence == start or page.end_of_recording:
                return
            start = page.next_sequence

    def fetch(self, run_id, start=0, end=None):
        """Samples [start, end) of a recorded run (end None: all recorded) as a Run."""
        run = Run(run_id)
        metadata = self.request(get_run=api_pb2.GetRun(run_id=run_id)).get_run.metadata
        run.start = metadata.start
        run.descriptor = metadata.run_descriptor if metadata.HasField("run_descriptor") else None
        run.stop = metadata.stop if metadata.HasField("stop") else None  # None while it runs
        run.segment_events = list(metadata.segment_events)
        run.faults = list(metadata.faults)
        for block in self._fetch_blocks(run_id, start, end):
            run.add_block(block)
        run.assemble()
        return run
