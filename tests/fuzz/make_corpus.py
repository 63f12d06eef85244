#!/usr/bin/python3
"""Writes the seed corpus of the fuzz targets (committed under corpus/).

    PYTHONPATH=client/python:build/python /usr/bin/python3 tests/fuzz/make_corpus.py
"""

import os

from google.protobuf import text_format
from tribo.v1 import api_pb2, protocol_pb2
from tribo_client.framing import encode_frame

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


def write(target, name, data):
    d = os.path.join(HERE, "corpus", target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def standard():
    with open(os.path.join(ROOT, "config/protocols/standard_scratch.textproto"), encoding="utf-8") as f:
        return text_format.Parse(f.read(), protocol_pb2.Protocol())


def frames(*messages):
    return b"".join(encode_frame(m) for m in messages)


def main():
    hello = api_pb2.ClientMessage(request_id=1, hello=api_pb2.Hello(api_version=1, client_name="seed",
                                                                    role=api_pb2.CONTROLLER, token="t"))
    load = api_pb2.ClientMessage(request_id=2, load_protocol=api_pb2.LoadProtocol(protocol=standard()))
    status = api_pb2.ClientMessage(request_id=3, get_status=api_pb2.GetStatus())
    fetch = api_pb2.ClientMessage(request_id=4, fetch_samples=api_pb2.FetchSamples(
        run_id="20260101-000000-000", from_sequence=100, max_samples=10))
    # Prefix: max frame selector (0: 4 MiB), chunk size - 1.
    write("frame_decoder", "session", bytes([0, 255]) + frames(hello, load, status, fetch))
    write("frame_decoder", "byte_by_byte", bytes([0, 0]) + frames(hello, status))
    write("frame_decoder", "small_max", bytes([2, 7]) + frames(hello, load))
    write("frame_decoder", "oversized", bytes([0, 3]) + b"\x80\x80\x80\x80\x04")
    write("frame_decoder", "bad_header", bytes([1, 1]) + b"\xff" * 8)
    write("frame_decoder", "garbage", bytes([0, 16]) + b"\x05\xff\xff\xff\xff\xff" + frames(status))

    p = standard()
    write("protocol_validator", "standard.bin", p.SerializeToString())
    write("protocol_validator", "standard.textproto",
          ("# standard\n" + text_format.MessageToString(p)).encode())
    short = standard()
    for seg, d in zip(short.segments, (0.5, 0.5, 1.0, 0.5, 0.5)):
        seg.duration_s = d
    short.segments[2].lateral.end_um = 2.5
    short.segments[3].lateral.end_um = 2.5
    short.segments[2].acquisition_rate_hz = 10000
    write("protocol_validator", "short.bin", short.SerializeToString())
    over = standard()
    over.segments[1].normal.end_uN = 20000
    write("protocol_validator", "overload.bin", over.SerializeToString())
    cross = standard()
    cross.segments[2].lateral.end_um = -5
    write("protocol_validator", "crosses_zero.bin", cross.SerializeToString())
    modes = standard()
    modes.segments[2].normal.mode = protocol_pb2.NORMAL_CLOSED_LOOP_FORCE
    modes.segments[2].lateral.mode = protocol_pb2.LATERAL_FORCE
    modes.segments[2].lateral.end_uN = 100
    write("protocol_validator", "modes.bin", modes.SerializeToString())

    # Non-finite values in every field the validator bounds.
    nan, inf = float("nan"), float("inf")
    for name, spoil in (
            ("nan_normal_end.bin", lambda q: setattr(q.segments[4].normal, "end_uN", nan)),
            ("nan_lateral_end.bin", lambda q: setattr(q.segments[2].lateral, "end_um", nan)),
            ("inf_lateral_delta.bin", lambda q: setattr(q.segments[2].lateral, "delta_um", -inf)),
            ("nan_rate.bin", lambda q: setattr(q, "acquisition_rate_hz", nan)),
            ("negative_zero_rate.bin", lambda q: setattr(q, "acquisition_rate_hz", -0.0)),
            ("nan_sine_end.bin", lambda q: setattr(q.segments[2].lateral.sine, "end_amplitude_um", nan))):
        q = standard()
        spoil(q)
        write("protocol_validator", name, q.SerializeToString())

    # The session's request handling: a controller's conversation, an
    # observer's, and requests that carry non-finite or oversized values.
    def msg(i, **body):
        return api_pb2.ClientMessage(request_id=i, **body)
    ctl = api_pb2.ClientMessage(request_id=1, hello=api_pb2.Hello(
        api_version=1, client_name="seed", role=api_pb2.CONTROLLER, token="fuzz-token"))
    obs = api_pb2.ClientMessage(request_id=1, hello=api_pb2.Hello(api_version=1, client_name="obs\nforged"))
    short_load = msg(2, load_protocol=api_pb2.LoadProtocol(protocol=short))
    notes = api_pb2.RunAnnotations(sample="s", tip="t", operator_name="o", note="n")
    notes.extra["k"] = "v"
    write("client_session", "controller", frames(
        ctl, short_load, msg(3, subscribe=api_pb2.Subscribe(decimation=10)),
        msg(4, start_run=api_pb2.StartRun(seed=5, annotations=notes)), status,
        msg(5, abort_run=api_pb2.AbortRun(reason="r")), msg(6, list_runs=api_pb2.ListRuns(max_runs=3))))
    write("client_session", "observer", frames(
        obs, status, msg(2, emergency_stop=api_pb2.EmergencyStop(reason="x" * 300)),
        msg(3, abort_run=api_pb2.AbortRun(token="fuzz-token")), msg(4, get_gains=api_pb2.GetGains())))
    from tribo.v1 import daemon_config_pb2
    gains = daemon_config_pb2.PidGains(kp=nan, ki=1, kd=inf, output_min=-1, output_max=1)
    write("client_session", "nonfinite", frames(
        ctl, msg(2, set_gains=api_pb2.SetGains(loop=api_pb2.LOOP_LATERAL_DISPLACEMENT, gains=gains)),
        msg(3, load_protocol=api_pb2.LoadProtocol(protocol=over)),
        msg(4, autotune=api_pb2.Autotune(relay_amplitude_n=nan))))
    write("client_session", "estop_rearm", frames(
        ctl, msg(2, emergency_stop=api_pb2.EmergencyStop()), msg(3, rearm=api_pb2.Rearm()),
        msg(4, get_run=api_pb2.GetRun(run_id="../../etc")), fetch))
    write("client_session", "no_hello", frames(status, short_load) + b"\x80\x80\x40")
    # The harness's data directory holds a finished run under this id: the
    # read paths read a real recording; a run started and left going is
    # aborted by the harness; autotune runs as an activity.
    seed_run = "20260101-000000-000"
    write("client_session", "read_recording", frames(
        obs, msg(2, get_run=api_pb2.GetRun(run_id=seed_run)),
        msg(3, fetch_samples=api_pb2.FetchSamples(run_id=seed_run, from_sequence=2990, max_samples=50)),
        msg(4, export_csv=api_pb2.ExportCsv(run_id=seed_run, from_sequence=0, max_samples=20)),
        msg(5, list_runs=api_pb2.ListRuns(max_runs=2))))
    write("client_session", "run_left_going", frames(
        ctl, short_load, msg(3, start_run=api_pb2.StartRun(seed=9)), status,
        msg(4, emergency_stop=api_pb2.EmergencyStop(reason="seed"))))
    write("client_session", "autotune", frames(ctl, msg(2, autotune=api_pb2.Autotune(apply=True)), status))


if __name__ == "__main__":
    main()
