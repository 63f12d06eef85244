#!/usr/bin/python3
"""Simulated seconds per CPU second of tribo_native.simulate in-process
(reported, not asserted; docs/testing.md): the identification protocol on
each named instrument config, CPU time of this process (process_time), so a
shared machine's load costs wall time, not the figure.

    PYTHONPATH=client/python:build/python /usr/bin/python3 bench/sim_in_process_bench.py [--repeat 3]
"""

import argparse
import os
import statistics
import time

SOURCE_DIR = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
CONFIGS = ["config/tribod.textproto", "config/instruments/dissertation_fit.textproto",
           "config/instruments/lugre_plain.textproto", "config/instruments/appendix_c.textproto"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs per config, seeds 1..N (the best CPU time first)")
    parser.add_argument("--protocol", default="config/protocols/identification.textproto")
    parser.add_argument("--config", action="append", help="only this config (repeatable; default: the four named)")
    args = parser.parse_args()
    from tribo_client import sim
    protocol = sim.load_protocol(os.path.join(SOURCE_DIR, args.protocol))
    for name in args.config or CONFIGS:
        config = sim.load_config(os.path.join(SOURCE_DIR, name))
        cpus = []
        for seed in range(1, args.repeat + 1):
            cpu = time.process_time()
            run = sim.simulate(config, protocol, seed=seed)
            cpus.append(time.process_time() - cpu)
            simulated = float(run.samples["t"][-1])
        rates = sorted(simulated / cpu for cpu in cpus)
        print(f"{name}: {simulated:.0f} s simulated in {min(cpus):.2f} s CPU: {rates[-1]:.0f}x real time per CPU second"
              f" (seeds 1-{args.repeat}: min {rates[0]:.0f}x, median {statistics.median(rates):.0f}x, max {rates[-1]:.0f}x)")


if __name__ == "__main__":
    main()
