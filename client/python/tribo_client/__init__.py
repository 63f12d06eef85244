"""tribo from Python: the socket client for tribod, the run-folder reader,
figures, the in-process simulator and analyses (tribo_client.sim, over the
native module tribo_native) and campaigns on Dask (tribo_client.campaign,
the tribo-campaign command). docs/python.md.

Channels have one name and one unit everywhere (tribo_client.CHANNELS):
run.samples["lateral_force"] is in N, the CSV column is lateral_force_N.

    from tribo_client import Client, load_protocol_file, read_run
    with Client("127.0.0.1:7460", role="controller") as c:
        run = c.run(load_protocol_file("config/protocols/standard_scratch.textproto"))
        run.samples["lateral_force"]   # numpy array, N
    read_run("runs/RUN_ID").to_dataframe()

Installed with `pip install client/python` after building (the protobuf
modules and the native module come from the build tree), or from the build
tree with PYTHONPATH=client/python:build/python.
"""

from .channels import CHANNELS, NAMES, UNITS, csv_column
from .client import Client, Run, TriboError, load_protocol_file
from .runs import RunData, read_run

__all__ = ["CHANNELS", "NAMES", "UNITS", "csv_column", "Client", "Run", "TriboError",
           "load_protocol_file", "RunData", "read_run"]
__version__ = "0.1.0"
