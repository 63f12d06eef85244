#!/usr/bin/python3
"""Campaign figures (reported, not asserted; docs/campaigns.md):
  - simulated seconds per CPU second in-process (tribo_client.sim.simulate);
  - runs per second on a Dask LocalCluster of 1 and 2 workers, and the
    scaling efficiency rate(2) / (2 rate(1));
  - Dask's per-run overhead against an in-process loop over the same runs.

    PYTHONPATH=client/python:build/python /usr/bin/python3 bench/campaign_bench.py [--runs 8] [--json out.json]
"""

import argparse
import json
import os
import sys
import time

SOURCE_DIR = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))


def tasks_for(protocol_path, count, compute=("metrics",)):
    from tribo_client import sim
    from tribo_client.campaign.spec import RunTask
    config = sim.load_config(os.path.join(SOURCE_DIR, "config/tribod.textproto"))
    config.controller.lateral_displacement.setpoint_weight_p = 1.0
    protocol = sim.load_protocol(protocol_path)
    return [RunTask(f"bench{i}", i, protocol.name, protocol.SerializeToString(), config.SerializeToString(), i + 1,
                    {}, list(compute), {}) for i in range(count)]


def in_process(tasks):
    from tribo_client.campaign import worker
    wall, cpu = time.perf_counter(), time.process_time()
    rows = [worker.execute(t)["row"] for t in tasks]
    return time.perf_counter() - wall, time.process_time() - cpu, rows


def on_dask(tasks, workers):
    from distributed import wait
    from tribo_client.campaign import worker
    from tribo_client.campaign.runner import start_client
    client, cluster = start_client(workers=workers)
    try:
        client.run(lambda: __import__("tribo_client.sim"))  # imports and the module load out of the timing
        started = time.perf_counter()
        futures = [client.submit(worker.execute, t, pure=False) for t in tasks]
        wait(futures)
        elapsed = time.perf_counter() - started
        rows = [f.result()["row"] for f in futures]
    finally:
        client.close()
        cluster.close()
    return elapsed, rows


DIAGNOSIS_CHILD = """
import json, resource, sys, time
from tribo_client import sim
config = sim.load_config(sys.argv[1])
config.controller.lateral_displacement.setpoint_weight_p = 1.0
config.sim.tip.tilt_offset.enabled = False
run = sim.simulate(config, sys.argv[2], seed=1)
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
wall, cpu = time.perf_counter(), time.process_time()
sim.diagnose(run)
wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
print(json.dumps({"samples": len(run), "wall_s": wall, "cpu_s": cpu, "rss_before_kib": before,
                  "peak_rss_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}))
"""


def diagnosis_figures(protocol):
    """All ten candidates on a 198 s identification run (in a child process,
    so that its peak RSS is the diagnosis' own)."""
    import subprocess
    out = subprocess.run([sys.executable, "-c", DIAGNOSIS_CHILD, os.path.join(SOURCE_DIR, "config/tribod.textproto"),
                          protocol], capture_output=True, text=True, check=True)
    d = json.loads(out.stdout)
    d["peak_bytes_per_sample"] = (d["peak_rss_kib"] - d["rss_before_kib"]) * 1024 / d["samples"]
    print(f"diagnosis of a {d['samples']}-sample identification run: {d['wall_s']:.1f} s wall, {d['cpu_s']:.1f} s CPU, "
          f"peak RSS {d['peak_rss_kib'] / 1024:.0f} MiB ({d['peak_bytes_per_sample']:.0f} bytes per sample above the "
          f"{d['rss_before_kib'] / 1024:.0f} MiB before)")
    return d


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=8, help="runs of the identification protocol per measurement")
    parser.add_argument("--short-runs", type=int, default=40, help="runs of a 3 s scratch for the overhead")
    parser.add_argument("--diagnosis", action="store_true",
                        help="also: one diagnosis of a 198 s identification run (wall, CPU, peak memory)")
    parser.add_argument("--json")
    args = parser.parse_args()
    from tribo_client import sim
    figures = {"software_version": sim.software_version, "cpus": os.cpu_count(), "load_before": os.getloadavg()}

    identification = os.path.join(SOURCE_DIR, "config/protocols/identification.textproto")
    long_tasks = tasks_for(identification, args.runs)
    wall, cpu, rows = in_process(long_tasks[:2])
    simulated = sum(r["simulated_s"] for r in rows)
    sim_cpu = sum(r["cpu_s"] for r in rows)
    figures["in_process"] = {"runs": len(rows), "simulated_s": simulated, "cpu_s": cpu, "wall_s": wall,
                             "simulated_s_per_cpu_s": simulated / cpu,
                             "simulated_s_per_cpu_s_sim_and_metrics_per_run": simulated / sim_cpu}
    print(f"in-process: {simulated:.0f} s simulated in {cpu:.2f} s CPU ({wall:.2f} s wall): "
          f"{simulated / cpu:.0f}x real time per CPU second (simulation + metrics)")

    # The simulation alone (no metrics), CPU time of this process.
    config = sim.load_config(os.path.join(SOURCE_DIR, "config/tribod.textproto"))
    config.controller.lateral_displacement.setpoint_weight_p = 1.0
    cpu = time.process_time()
    run = sim.simulate(config, identification, seed=1)
    cpu = time.process_time() - cpu
    figures["simulate_only"] = {"simulated_s": float(run.samples["t"][-1]), "cpu_s": cpu,
                                "simulated_s_per_cpu_s": float(run.samples["t"][-1]) / cpu}
    print(f"sim.simulate alone: {run.samples['t'][-1]:.0f} s simulated in {cpu:.2f} s CPU: "
          f"{run.samples['t'][-1] / cpu:.0f}x real time per CPU second")

    rates = {}
    for workers in (1, 2):
        elapsed, rows = on_dask(long_tasks, workers)
        rates[workers] = len(rows) / elapsed
        print(f"Dask LocalCluster, {workers} worker(s): {len(rows)} runs of {rows[0]['simulated_s']:.0f} s "
              f"in {elapsed:.2f} s: {rates[workers]:.2f} runs/s")
    figures["runs_per_s"] = rates
    figures["scaling_efficiency_2_workers"] = rates[2] / (2 * rates[1])
    print(f"scaling efficiency at 2 workers: {figures['scaling_efficiency_2_workers']:.2f}")

    from support_protocols import short_scratch_path
    short_tasks = tasks_for(short_scratch_path(), args.short_runs, compute=())
    loop_wall, _, _ = in_process(short_tasks)
    dask_wall, _ = on_dask(short_tasks, 1)
    overhead = (dask_wall - loop_wall) / len(short_tasks)
    figures["overhead"] = {"runs": len(short_tasks), "in_process_s": loop_wall, "dask_1_worker_s": dask_wall,
                           "per_run_overhead_s": overhead, "in_process_per_run_s": loop_wall / len(short_tasks)}
    print(f"per-run overhead of Dask (1 worker) against an in-process loop: {overhead * 1e3:.1f} ms "
          f"({len(short_tasks)} runs of a 3 s scratch: loop {loop_wall:.2f} s, Dask {dask_wall:.2f} s)")
    if args.diagnosis:
        figures["diagnosis"] = diagnosis_figures(identification)
    figures["load_after"] = os.getloadavg()
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(figures, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    sys.exit(main())
