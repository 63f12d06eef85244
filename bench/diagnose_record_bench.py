#!/usr/bin/python3
"""The cost of `tribo-fit diagnose` on real tribod records of several lengths.

Records the identification protocol (config/protocols/identification.textproto)
at 1 kHz with its three loads repeated so that the run lasts about 200, 800 and
3200 s, on tribod with config/tribod.textproto or --config's (the lateral loop's setpoint
weighted in P, as that protocol asks), saved by `tribo run --out` as a run
directory; then times `tribo-fit diagnose RUN --json` on each and prints the
wall time, the CPU time, the peak resident memory and the bytes per sample, and
what the diagnosis accepted.

usage: diagnose_record_bench.py BUILD_DIR WORK_DIR [--lengths 1,4,16] [--reuse] [--tribo-fit PATH]
                                [--baseline PATH] [--reports DIR] [--config FILE]
       (--lengths: how many times the three loads are run: 1 is about 200 s;
        --reuse: keep run directories already in WORK_DIR;
        --baseline: a second tribo-fit (e.g. built from main) timed on each record
        just before the first, so that both see the same load: the table gives a
        row for each, and says whether their diagnoses name the same effects;
        --reports: keep each JSON report there;
        --config: the daemon config to record on, default config/tribod.textproto)

Figures (this build beside main's, the command, the load, where the CPU goes):
docs/identification.md, "Cost". Not part of the test suite: each record takes
from 20 s to minutes of CPU to diagnose.
"""
import argparse
import json
import os
import re
import resource
import subprocess
import sys
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
for p in (os.path.join(ROOT, "client", "python"),):
    if p not in sys.path:
        sys.path.insert(0, p)


def write_inputs(build, work, repeats, base_config):
    sys.path.insert(0, os.path.join(build, "python"))
    from google.protobuf import text_format
    from tribo_client import load_protocol_file
    from tribo_client.campaign.spec import set_field
    from tribo.v1 import daemon_config_pb2
    config = daemon_config_pb2.DaemonConfig()
    with open(base_config) as f:
        text_format.Parse(f.read(), config)
    set_field(config, "controller.lateral_displacement.setpoint_weight_p", 1.0)
    config_path = os.path.join(work, "tribod.textproto")
    with open(config_path, "w") as f:
        f.write(text_format.MessageToString(config))
    protocols = {}
    for k in repeats:
        p = load_protocol_file(os.path.join(ROOT, "config", "protocols", "identification.textproto"))
        p.name = f"identification-x{k}"
        p.acquisition_rate_hz = 1000
        loads = p.segments[1].repeat
        loads.count = 3 * k
        first = loads.segments[0].per_pass
        values = list(first.normal_end_uN)
        del first.normal_end_uN[:]
        first.normal_end_uN.extend(values * k)
        path = os.path.join(work, f"identification_x{k}.textproto")
        with open(path, "w") as f:
            f.write(text_format.MessageToString(p))
        protocols[k] = path
    return config_path, protocols


def record(build, work, config_path, protocols, reuse):
    runs = {k: os.path.join(work, f"run_x{k}") for k in protocols}
    todo = [k for k in protocols if not (reuse and os.path.exists(os.path.join(runs[k], "samples.csv")))]
    if not todo:
        return runs
    data = os.path.join(work, "data")
    os.makedirs(data, exist_ok=True)
    daemon = subprocess.Popen([os.path.join(build, "daemon", "tribod"), "--config", config_path, "--port", "0",
                               "--data-dir", data], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        line = daemon.stdout.readline()
        address = line.strip().split()[-1]
        for k in todo:
            subprocess.run([os.path.join(build, "client", "tribo"), "run", protocols[k], "--address", address,
                            "--out", runs[k], "--force", "--no-progress"], check=True, stdout=subprocess.DEVNULL)
    finally:
        daemon.terminate()
        daemon.wait()
    return runs


def diagnose(tribo_fit, run):
    started = time.perf_counter()
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    r = subprocess.run(["/usr/bin/time", "-v", tribo_fit, "diagnose", run, "--json"],
                       capture_output=True, text=True)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    peak_kb = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", r.stderr).group(1))
    if r.returncode != 0:
        raise RuntimeError(r.stderr[-2000:])
    report = json.loads(r.stdout)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return report, wall, cpu, peak_kb * 1024


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("build")
    ap.add_argument("work")
    ap.add_argument("--lengths", default="1,4,16")
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--tribo-fit", help="the tribo-fit to time (default BUILD_DIR/analysis/tribo-fit)")
    ap.add_argument("--baseline", help="a second tribo-fit timed on each record just before the first")
    ap.add_argument("--reports", help="a directory for each diagnosis' JSON report")
    ap.add_argument("--record-only", action="store_true", help="make the run directories, time nothing")
    ap.add_argument("--config", default=os.path.join(ROOT, "config", "tribod.textproto"),
                    help="the daemon config to record on (default config/tribod.textproto)")
    args = ap.parse_args()
    build, work = os.path.abspath(args.build), os.path.abspath(args.work)
    os.makedirs(work, exist_ok=True)
    repeats = [int(k) for k in args.lengths.split(",")]
    config_path, protocols = write_inputs(build, work, repeats, os.path.abspath(args.config))
    runs = record(build, work, config_path, protocols, args.reuse)
    if args.record_only:
        return
    binaries = [("", args.tribo_fit or os.path.join(build, "analysis", "tribo-fit"))]
    if args.baseline:
        binaries.insert(0, ("baseline", args.baseline))
    if args.reports:
        os.makedirs(args.reports, exist_ok=True)
    print("| record | tribo-fit | samples | duration s | wall s | CPU s | peak RSS MB | B/sample | accepted |")
    print("|---|---|---|---|---|---|---|---|---|")
    for k in repeats:
        accepted_by = {}
        for tag, binary in binaries:
            report, wall, cpu, peak = diagnose(binary, runs[k])
            if args.reports:
                with open(os.path.join(args.reports, f"run_x{k}.{tag or 'tribo-fit'}.json"), "w") as f:
                    json.dump(report, f, indent=1)
            n = report["input"]["samples"]
            accepted = ", ".join(a["name"] for a in report["accepted_effects"]) or "nothing"
            accepted_by[tag] = accepted
            print(f"| identification x{k} | {tag or 'timed'} | {n} | {report['input']['duration_s']:.0f} | {wall:.1f} "
                  f"| {cpu:.1f} | {peak / 1e6:.0f} | {peak / n:.0f} | {accepted} |", flush=True)
        if len(set(accepted_by.values())) > 1:
            print(f"| identification x{k} | the two diagnoses accept different effects | | | | | | | |", flush=True)

if __name__ == "__main__":
    main()
