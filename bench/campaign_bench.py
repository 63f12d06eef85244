#!/usr/bin/python3
"""Campaign figures (reported, not asserted; docs/campaigns.md):
  - simulated seconds per CPU second in-process (tribo_client.sim.simulate);
  - runs per second on a Dask LocalCluster of 1 and 2 workers, and the
    scaling efficiency rate(2) / (2 rate(1));
  - Dask's per-run overhead against an in-process loop over the same runs;
  - sub-second runs (--sub-second): `tribo-campaign SPEC` (the local
    default) against a serial loop over the same runs, and against one Dask
    task per run on a 2-worker LocalCluster (the runner without batching),
    each a whole command in its own process (interpreter, spec, runs, run
    folders, results table), in runs per minute, on 40-run specs of three
    workloads.

    PYTHONPATH=client/python:build/python /usr/bin/python3 bench/campaign_bench.py [--runs 8] [--json out.json]
    PYTHONPATH=client/python:build/python /usr/bin/python3 bench/campaign_bench.py --sub-second-only [--repeat 3]
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


# The sub-second workloads: (name, protocol, compute), 40 runs each (seeds 1-40).
SUB_SECOND_WORKLOADS = (("3 s scratch, metrics", "short_scratch", ["metrics"]),
                        ("19 s identification cut, metrics", "tiny", ["metrics"]),
                        ("19 s identification cut, diagnosis (2 candidates)", "tiny", ["diagnosis"]))


def sub_second_spec(directory, protocol, compute, runs):
    """A spec of `runs` seeds of one protocol: the 3 s scratch or the tiny
    reliability spec's 19 s cut of the identification protocol (with its
    base overrides and diagnosis options)."""
    import tomllib
    with open(os.path.join(SOURCE_DIR, "config/campaigns/identification_reliability_tiny.toml"), "rb") as f:
        tiny = tomllib.load(f)
    lines = [f'name = "{protocol}-{"-".join(compute)}"',
             f'config = "{os.path.join(SOURCE_DIR, "config/tribod.textproto")}"',
             f"seeds = {{first = 1, count = {runs}}}", f"compute = {json.dumps(compute)}", "[overrides]"]
    lines += [f'"{k}" = {json.dumps(v)}' for k, v in tiny["overrides"].items()]
    lines += ["[diagnosis]"] + [f"{k} = {json.dumps(v)}" for k, v in tiny["diagnosis"].items()]
    lines += ["[[protocols]]"]
    if protocol == "tiny":
        lines += ['name = "identification-short"', "text = " + json.dumps(tiny["protocols"][0]["text"])]
    else:
        from support_protocols import short_scratch_path
        lines += [f'path = "{short_scratch_path()}"']
    path = os.path.join(directory, f"{protocol}-{'-'.join(compute)}.toml")
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")
    return path


def serial_loop(spec, out):
    """What a user's plain loop does: every run in this process, its folder,
    the table."""
    from tribo_client.campaign import worker
    from tribo_client.campaign.results import write_results
    from tribo_client.campaign.runner import record_result
    from tribo_client.campaign.spec import load_spec
    campaign = load_spec(spec)
    os.makedirs(os.path.join(out, "runs"), exist_ok=True)
    for task in campaign.tasks:
        record_result(out, task, worker.execute(task))
    write_results(out, campaign.name, campaign.spec_path)


def one_task_per_run(spec, out, workers=2):
    """The campaign runner without batching: a LocalCluster started first,
    one Dask task per run."""
    from distributed import as_completed
    from tribo_client.campaign import worker
    from tribo_client.campaign.results import write_results
    from tribo_client.campaign.runner import record_result, start_client
    from tribo_client.campaign.spec import load_spec
    campaign = load_spec(spec)
    os.makedirs(os.path.join(out, "runs"), exist_ok=True)
    client, cluster = start_client(workers=workers, local_directory=os.path.join(out, ".dask-worker-space"))
    try:
        by_key = {}
        for task in campaign.tasks:
            future = client.submit(worker.execute, task, pure=False)
            by_key[future.key] = (future, task)
        for future in as_completed([f for f, _ in by_key.values()], loop=client.loop):
            record_result(out, by_key[future.key][1], future.result())
    finally:
        client.close()
        cluster.close()
    write_results(out, campaign.name, campaign.spec_path)


def timed_command(args):
    """(wall seconds, stderr) of one command in its own process."""
    import subprocess
    started = time.perf_counter()
    result = subprocess.run(args, capture_output=True, text=True, timeout=900)
    wall = time.perf_counter() - started
    if result.returncode != 0:
        raise RuntimeError(f"{' '.join(args)}: exit {result.returncode}: {result.stderr[-2000:]}")
    return wall, result.stderr


def sub_second_figures(runs, repeat, workers):
    """Runs per minute of the three ways on each workload, the median of
    `repeat` rounds (the ways alternate within a round), and where the local
    default put the runs (its `runs:` line)."""
    import statistics
    import tempfile
    figures = []
    me = os.path.abspath(__file__)
    for name, protocol, compute in SUB_SECOND_WORKLOADS:
        with tempfile.TemporaryDirectory() as tmp:
            spec = sub_second_spec(tmp, protocol, compute, runs)
            ways = {"serial loop": [sys.executable, me, "--serial-loop", spec],
                    "tribo-campaign": [sys.executable, "-m", "tribo_client.campaign", spec,
                                       *(["--workers", str(workers)] if workers else []), "--out"],
                    "one task per run": [sys.executable, me, "--one-task-per-run", spec]}
            walls = {way: [] for way in ways}
            where = []
            for round_ in range(repeat):
                for i, (way, command) in enumerate(ways.items()):
                    wall, stderr = timed_command(command + [os.path.join(tmp, f"out-{round_}-{i}")])
                    walls[way].append(wall)
                    where += [line for line in stderr.splitlines() if line.startswith("runs: ")]
            entry = {"workload": name, "runs": runs, "load_after": os.getloadavg(), "local_default_where": where}
            for way, values in walls.items():
                median = statistics.median(values)
                entry[way] = {"wall_s": values, "median_wall_s": median, "runs_per_min": 60 * runs / median}
            figures.append(entry)
            print(f"{name}, {runs} runs: " + "; ".join(
                f"{way} {entry[way]['runs_per_min']:.0f} runs/min ({entry[way]['median_wall_s']:.2f} s)"
                for way in ways))
            print(f"  walls {json.dumps({w: [round(v, 2) for v in walls[w]] for w in walls})}; tribo-campaign {where}")
    return figures


def main():
    if len(sys.argv) == 4 and sys.argv[1] in ("--serial-loop", "--one-task-per-run"):
        (serial_loop if sys.argv[1] == "--serial-loop" else one_task_per_run)(sys.argv[2], sys.argv[3])
        return 0
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=8, help="runs of the identification protocol per measurement")
    parser.add_argument("--short-runs", type=int, default=40, help="runs of a 3 s scratch for the overhead")
    parser.add_argument("--diagnosis", action="store_true",
                        help="also: one diagnosis of a 198 s identification run (wall, CPU, peak memory)")
    parser.add_argument("--sub-second", action="store_true", help="also: the local default against a serial loop")
    parser.add_argument("--sub-second-only", action="store_true", help="only that comparison")
    parser.add_argument("--sub-second-runs", type=int, default=40)
    parser.add_argument("--repeat", type=int, default=3, help="rounds of the sub-second comparison (median)")
    parser.add_argument("--workers", type=int, help="the local default's --workers (default: one per core)")
    parser.add_argument("--json")
    args = parser.parse_args()
    from tribo_client import sim
    figures = {"software_version": sim.software_version, "cpus": os.cpu_count(), "load_before": os.getloadavg()}
    if args.sub_second or args.sub_second_only:
        figures["sub_second"] = sub_second_figures(args.sub_second_runs, args.repeat, args.workers)
    if args.sub_second_only:
        figures["load_after"] = os.getloadavg()
        if args.json:
            with open(args.json, "w", encoding="utf-8") as f:
                json.dump(figures, f, indent=2)
        return 0

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
