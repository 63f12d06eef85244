"""What one run of a campaign does: simulate it in-process and compute on
it. Runs in a Dask worker process (execute_batch: one task, several runs) or
in the driver (runner.py); returns plain data (picklable, small): the row of
the results table and the full reports for the run's folder."""

import time
import traceback

import numpy as np


def execute_batch(tasks):
    """One Dask task of several runs (batches.py sizes them): one result per
    run, in order, each as execute_safely gives it."""
    return [execute_safely(task) for task in tasks]


def execute_safely(task):
    """execute(task), or {"exception": text} when it raises (a bug, not a
    failed run: the driver records nothing, so a rerun retries the run)."""
    try:
        return execute(task)
    except Exception as e:  # noqa: BLE001 - reported per run by the driver
        return {"exception": f"{type(e).__name__}: {e}", "traceback": traceback.format_exc()}


def execute(task):
    """task: a RunTask. Returns {"row": {...}, "metrics": ..., "diagnosis": ...,
    "scorecard": ...}. A task without a protocol (a scorecard-only campaign)
    simulates nothing itself: the scorecard runs its own experiments."""
    from tribo_client import sim  # imported in the worker

    started = time.perf_counter()
    cpu_started = time.process_time()
    row = {"key": task.key, "index": task.index, "seed": task.seed, "software_version": sim.software_version}
    row.update(task.labels)
    out = {"row": row, "metrics": None, "diagnosis": None, "scorecard": None}
    if not task.protocol_bytes:
        row.update(status="ok", error="")
        _scorecard(task, row, out)
        row["wall_s"] = time.perf_counter() - started
        row["cpu_s"] = time.process_time() - cpu_started
        return out
    try:
        run = sim.simulate(task.config_bytes, task.protocol_bytes, seed=task.seed)
    except Exception as e:  # noqa: BLE001 - the row records the failure, the campaign goes on
        row.update(status="error", error=f"{type(e).__name__}: {e}")
        return out
    simulated = time.perf_counter()
    samples = run.samples
    row.update(status="ok", error="", exit_status=run.exit_status, trip_reason=run.stop.get("reason", ""),
               samples=len(samples["t"]), simulated_s=float(samples["t"][-1]) if len(samples["t"]) else 0.0,
               sim_wall_s=simulated - started)
    if "metrics" in task.compute:
        m = sim.metrics(run)
        out["metrics"] = m
        scratches = m["scratches"]
        row["scratches"] = len(scratches)
        row["mu_mean"] = float(np.mean([s["mu"] for s in scratches])) if scratches else float("nan")
        row["friction_mean_n"] = float(np.mean([s["mean_friction_n"] for s in scratches])) if scratches else float("nan")
        row["stiction_peak_mean_n"] = (float(np.mean([s["stiction_peak_n"] for s in scratches]))
                                       if scratches else float("nan"))
        row["drift_mean_rate_n_per_s"] = m["drift"]["mean_rate_n_per_s"]
        row["tilt_slope"] = m["tilt"]["slope"] if m["tilt"] else float("nan")
    if "diagnosis" in task.compute:
        diag_started = time.perf_counter()
        try:
            d = sim.diagnose(_diagnosed_samples(samples, task.diagnosis), effects=task.diagnosis.get("effects"),
                             begin_s=task.diagnosis.get("begin_s"), end_s=task.diagnosis.get("end_s"),
                             base_model=task.diagnosis.get("base_model", "lugre"))
            out["diagnosis"] = d
            row["accepted_effects"] = ";".join(a["name"] for a in d["accepted_effects"])
            row["heldout_rms_before"] = d["error_before"]["heldout"]["rms"]
            row["heldout_rms_after"] = d["error_after"]["heldout"]["rms"]
        except Exception as e:  # noqa: BLE001
            row.update(status="error", error=f"diagnosis: {type(e).__name__}: {e}")
        row["diagnosis_wall_s"] = time.perf_counter() - diag_started
    _scorecard(task, row, out)
    row["wall_s"] = time.perf_counter() - started
    row["cpu_s"] = time.process_time() - cpu_started
    return out


def _scorecard(task, row, out):
    """tribo-scorecard --json on the task's config and seed (sim.scorecard):
    the full report for the run's folder and the table's scorecard_* summary
    (rows, rows with a goal of issue 14, rows within it)."""
    if "scorecard" not in task.compute:
        return
    from tribo_client import sim
    started = time.perf_counter()
    try:
        report = sim.scorecard(task.config_bytes, groups=task.scorecard.get("groups"),
                               quick=task.scorecard.get("quick", False), seed=task.seed)
        out["scorecard"] = report
        rows = report["rows"]
        row["scorecard_rows"] = len(rows)
        row["scorecard_goals"] = sum(1 for r in rows if r["goal"] > 0)
        row["scorecard_within_goal"] = sum(1 for r in rows if r["within_goal"])
    except Exception as e:  # noqa: BLE001
        row.update(status="error", error=f"scorecard: {type(e).__name__}: {e}")
    row["scorecard_wall_s"] = time.perf_counter() - started


def _diagnosed_samples(samples, options):
    """loaded_segments_only: without the first and the last segment (the
    unloaded approach and return of the identification protocol), as the
    diagnosis tests feed it (tests/analysis/sim_identification_run.cc)."""
    if not options.get("loaded_segments_only"):
        return samples
    segment = samples["segment"]
    keep = (segment >= 1) & (segment < segment[-1])
    return {name: values[keep] for name, values in samples.items()}
