"""Python client for tribod's socket API (tribo.v1).

The protobuf modules are generated from proto/tribo/v1/*.proto at build time
(cmake builds them into build/python); put both this directory and that one on
the path:

    PYTHONPATH=client/python:build/python /usr/bin/python3 ...

    from tribo_client import Client, load_protocol_file
    with Client("127.0.0.1:7460", role="controller") as c:
        run = c.run(load_protocol_file("config/protocols/standard_scratch.textproto"))
        run.samples["lateral_force_n"]   # numpy array, SI units, one entry per sample
"""

from .client import Client, Run, TriboError, load_protocol_file

__all__ = ["Client", "Run", "TriboError", "load_protocol_file"]
