#!/usr/bin/python3
"""Runs a protocol on tribod and plots it to a PNG: friction and normal force
against time, and the lateral position against its setpoint.

    PYTHONPATH=client/python:build/python /usr/bin/python3 \
        client/python/examples/plot_run.py config/protocols/standard_scratch.textproto run.png \
        [--address HOST:PORT] [--seed N]
"""

import argparse
import sys

import matplotlib
matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tribo_client import Client, load_protocol_file  # noqa: E402


def plot(run, path):
    s = run.samples
    t = s["time_s"]
    fig, (ax_f, ax_x) = plt.subplots(2, 1, sharex=True, figsize=(9, 6))
    ax_f.plot(t, s["lateral_force_n"] * 1e6, lw=0.6, label="lateral force")
    ax_f.plot(t, s["normal_force_n"] * 1e6 * 0.1, lw=0.8, label="normal force / 10")
    ax_f.set_ylabel("force (µN)")
    ax_f.legend(loc="upper right")
    ax_x.plot(t, s["lateral_setpoint_m"] * 1e6, lw=0.8, label="setpoint")
    ax_x.plot(t, s["lateral_position_m"] * 1e6, lw=0.6, label="measured")
    ax_x.set_ylabel("lateral position (µm)")
    ax_x.set_xlabel("time (s)")
    ax_x.legend(loc="upper left")
    for e in run.segment_events:
        for ax in (ax_f, ax_x):
            ax.axvline(e.time_s, color="0.8", lw=0.5)
    fig.suptitle(f"run {run.run_id}: {run.start.protocol.name}, {run.exit_status}")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("protocol")
    parser.add_argument("png")
    parser.add_argument("--address")
    parser.add_argument("--seed", type=int)
    parser.add_argument("--token")
    args = parser.parse_args(argv)
    with Client(args.address, role="controller", token=args.token, name="plot_run.py") as client:
        run = client.run(load_protocol_file(args.protocol), seed=args.seed)
    plot(run, args.png)
    steady = (run.samples["segment_index"] == 2)
    print(f"run {run.run_id}: {run.exit_status}, {len(run.sequence)} samples, "
          f"mean lateral force in segment 2: {np.mean(run.samples['lateral_force_n'][steady]) * 1e6:.2f} µN; "
          f"plot in {args.png}")
    return 0 if run.exit_status == "SUCCESS" else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
