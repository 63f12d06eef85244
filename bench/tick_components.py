#!/usr/bin/python3
"""Where a simulated tick's CPU time goes, by component (reported, not
asserted; docs/testing.md, "Benchmarks"): reads a `perf record` of an
in-process run and sorts its samples, by symbol and source file (the tick's
code is inlined across files, so the source file of each sample says what it
belongs to), into the components of the tick, scaled to a measured CPU time
per tick.

    PYTHONPATH=client/python:build/python perf record -F 5000 -o tick.data \\
        /usr/bin/python3 bench/sim_in_process_bench.py --config config/instruments/lugre_plain.textproto
    /usr/bin/python3 bench/tick_components.py tick.data --ns-per-tick 286

Samples outside the timed call (interpreter start, imports, config parsing,
the kernel) are counted apart and left out of the scaling.
"""

import argparse
import collections
import re
import subprocess

OUTSIDE = "outside the tick (interpreter, imports, kernel)"


def component(symbol, source):
    daemon = "tribo::daemon" in symbol
    if source == "normal_axis.cc":
        return "normal axis (Newton solve, actuator law)"
    if source == "step_size.cc":
        return "sub-step planning (rate bound, plan, sanity check)"
    if source in ("capacitive_sensor.cc", "noise_source.cc", "sensor_model.cc", "gauss_markov.cc",
                  "s_nearbyint-sse4_1.S") or "NoiseSource" in symbol or "nearbyint" in symbol:
        return "sensors and noise"
    if "SafetySupervisor" in symbol or "stiffness" in symbol or (daemon and source in (
            "safety_supervisor.cc", "signal_filters.h", "electrostatic_drive.cc", "electrostatic_drive.h")):
        return "safety supervisor"
    if "pid_update" in symbol or "Controller" in symbol or "SegmentRunner" in symbol or "path_" in symbol or (
            daemon and source in ("controller.cc", "pid.cc", "load_function.cc", "load_function.h", "pid.h")):
        return "controller (PID) and segment runner"
    if daemon or "RunLoop" in symbol or "Acquisition" in symbol:
        return "run loop, acquisition, sample queue"
    if "tribo::hal" in symbol:
        return "HAL (SimTransducer read, write, step call)"
    if "SimInstrument::step" in symbol and source in ("electrostatic_drive.cc", "electrostatic_drive.h",
                                                      "parallel_plates.h"):
        return "lateral drive electronics"
    if "SimInstrument::step" in symbol:
        return "instrument step (levels, tilt, slow states)"
    if source in ("e_exp.c", "w_exp.c", "math_config.h") or symbol.startswith("exp@"):
        return "glibc exp (the Stribeck curve)"
    if "tribo::sim" in symbol:
        return "plant: evaluations, RK4 sub-steps, static limit"
    if "pybind11" in symbol or source == "tribo_native.cc":
        return "hand-off (queue pops, columns to numpy)"
    return OUTSIDE


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("perf_data")
    parser.add_argument("--ns-per-tick", type=float, required=True, help="measured CPU time per tick")
    args = parser.parse_args()
    report = subprocess.run(["perf", "report", "-i", args.perf_data, "--no-children", "--sort", "sym,srcfile",
                             "--stdio"], capture_output=True, text=True, check=True).stdout
    shares = collections.Counter()
    for line in report.splitlines():
        m = re.match(r"\s*([0-9.]+)%\s+\[(.)\]\s+(.*?)\s{2,}(\S*)\s*$", line)
        if m:
            kernel = m.group(2) == "k"
            shares[OUTSIDE if kernel else component(m.group(3), m.group(4))] += float(m.group(1))
    inside = sum(shares.values()) - shares[OUTSIDE]
    print("| component | share | ns a tick |\n|---|---|---|")
    for name, share in shares.most_common():
        if name != OUTSIDE:
            print(f"| {name} | {share / inside * 100:.1f} % | {share / inside * args.ns_per_tick:.0f} |")
    print(f"({OUTSIDE}: {shares[OUTSIDE]:.1f} % of all samples, not scaled)")


if __name__ == "__main__":
    main()
