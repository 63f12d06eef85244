"""The identified friction models a protocol compensates with
(docs/friction_compensation.md): a protocol's friction_compensation names a
`tribo-fit diagnose --json` report by report_file; the client reads the file
and sends its bytes, unchanged, in report_json (the daemon never reads a
client's path). The same rules as the tribo CLI (client/friction_model_files.h).
"""

import os


def read_friction_reports(protocol, protocol_dir):
    """Fills report_json of every friction_compensation of the protocol (its
    own and its segments', repeat blocks included) that names a report_file
    and has no report_json yet; report_file relative to protocol_dir unless
    absolute. Returns the protocol; OSError names the field and the file."""
    def read(compensation, field):
        if not compensation.report_file or compensation.report_json:
            return
        path = os.path.join(protocol_dir, compensation.report_file)
        try:
            with open(path, encoding="utf-8") as f:
                compensation.report_json = f.read()
        except OSError as e:
            raise OSError(f"{field}.report_file: cannot read the friction model report {path}: {e.strerror}") from None

    def segments(items, prefix):
        for i, segment in enumerate(items):
            at = f"{prefix}segments[{i}]"
            if segment.HasField("friction_compensation"):
                read(segment.friction_compensation, at + ".friction_compensation")
            if segment.HasField("repeat"):
                segments(segment.repeat.segments, at + ".repeat.")

    if protocol.HasField("friction_compensation"):
        read(protocol.friction_compensation, "friction_compensation")
    segments(protocol.segments, "")
    return protocol


def set_friction_model(protocol, report_path):
    """`tribo run --friction-model REPORT`: the report compensates every
    displacement segment, in place of the protocol's own friction_compensation
    (segments that set theirs keep it). Returns the protocol; report_path None
    leaves it unchanged."""
    if report_path is None:
        return protocol
    with open(report_path, encoding="utf-8") as f:
        text = f.read()
    protocol.friction_compensation.Clear()
    protocol.friction_compensation.report_file = os.fspath(report_path)
    protocol.friction_compensation.report_json = text
    return protocol
