#!/usr/bin/python3
"""Runs a protocol on tribod (or plots a recorded run folder) and draws the
run figure to a PNG at 200 dpi: friction and µ while sliding, normal force,
lateral position against its setpoint, segments named (tribo_client.plots).
Prints the scratch metrics of every loaded sliding segment.

    plot_run.py config/protocols/standard_scratch.textproto run.png [--address HOST:PORT] [--seed N]
    plot_run.py --run-dir runs/RUN_ID run.png
"""

import argparse
import sys

from tribo_client import Client, load_protocol_file, plots, read_run


def scratch_metrics(run):
    """tribo-fit metrics of the run (None without the native module)."""
    try:
        from tribo_client import sim
    except ImportError:  # the native module is optional here
        return None
    return sim.metrics(run)


def print_metrics(metrics):
    for s in metrics["scratches"] if metrics else []:
        print(f"segment {s['segment']}: {s['velocity_m_per_s'] * 1e6:+.2f} µm/s at {s['normal_force_n'] * 1e6:.1f} µN: "
              f"friction {s['mean_friction_n'] * 1e6:.2f} µN, µ {s['mu']:.4f}")


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("protocol", nargs="?", help="protocol file to run on tribod")
    parser.add_argument("png")
    parser.add_argument("--run-dir", help="plot this recorded run folder instead of running")
    parser.add_argument("--address")
    parser.add_argument("--seed", type=int)
    parser.add_argument("--token")
    args = parser.parse_args(argv)
    if args.run_dir:
        run = read_run(args.run_dir)
    elif args.protocol:
        with Client(args.address, role="controller", token=args.token, name="plot_run.py") as client:
            run = client.run(load_protocol_file(args.protocol), seed=args.seed)
    else:
        parser.error("give a protocol to run or --run-dir")
    metrics = scratch_metrics(run)
    plots.plot_run(run, args.png, metrics=metrics)
    print(f"run {run.run_id}: {run.exit_status}, {len(run.samples['t'])} samples; plot in {args.png}")
    print_metrics(metrics)
    return 0 if run.exit_status == "SUCCESS" else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
