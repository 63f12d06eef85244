"""Runs a campaign on Dask: a LocalCluster on 127.0.0.1 by default, or an
existing scheduler. The driver (this process) writes each finished run at
once, atomically, to OUT/runs/<key>/ (result.json with the row, the reports,
and the run's exact config, protocol and seed); a restart skips every key
that has its result.json, so a killed campaign loses only the runs in flight.
The results table (OUT/results.csv and OUT/results.h5) is rebuilt from the
run folders at the end."""

import json
import os
import sys
import time

from google.protobuf import text_format

from tribo.v1 import daemon_config_pb2, protocol_pb2

from . import worker

RESULT_FILE = "result.json"


def _write_atomically(path, text):
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def run_dir(out_dir, key):
    return os.path.join(out_dir, "runs", key)


def is_done(out_dir, key):
    return os.path.exists(os.path.join(run_dir(out_dir, key), RESULT_FILE))


def record_result(out_dir, task, result):
    """The run's folder: config and protocol as text (rerun exactly with the
    seed), and result.json last (its presence marks the run done)."""
    folder = run_dir(out_dir, task.key)
    os.makedirs(folder, exist_ok=True)
    config = daemon_config_pb2.DaemonConfig.FromString(task.config_bytes)
    _write_atomically(os.path.join(folder, "config.textproto"), text_format.MessageToString(config))
    if task.protocol_bytes:  # a scorecard-only run has none
        protocol = protocol_pb2.Protocol.FromString(task.protocol_bytes)
        _write_atomically(os.path.join(folder, "protocol.textproto"), text_format.MessageToString(protocol))
    row = dict(result["row"])
    row["run_folder"] = os.path.join("runs", task.key)
    document = {"row": row, "metrics": result.get("metrics"), "diagnosis": result.get("diagnosis")}
    if result.get("scorecard") is not None:
        # With the options: `tribo-scorecard --config config.textproto --seed SEED [--group G]... [--quick]`
        # reruns it exactly.
        document["scorecard_options"] = task.scorecard
        document["scorecard"] = result["scorecard"]
    _write_atomically(os.path.join(folder, RESULT_FILE), json.dumps(document, default=_json_default))


def _json_default(value):
    if hasattr(value, "item"):
        return value.item()
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


class Progress:
    """One line on stderr: done/total, skipped, failed, elapsed, ETA."""

    def __init__(self, total, skipped, stream=sys.stderr, width=30):
        self.total, self.done, self.failed, self.skipped = total, skipped, 0, skipped
        self.stream, self.width = stream, width
        self.started = time.monotonic()
        self.tty = stream.isatty()
        self._last_percent = -1
        self.draw()

    def advance(self, ok):
        self.done += 1
        self.failed += 0 if ok else 1
        self.draw()

    def draw(self):
        fraction = self.done / self.total if self.total else 1.0
        elapsed = time.monotonic() - self.started
        fresh = self.done - self.skipped
        remaining = self.total - self.done
        eta = f"{elapsed / fresh * remaining:5.0f} s" if fresh else "    ? s"
        filled = int(round(self.width * fraction))
        line = (f"[{'#' * filled}{'.' * (self.width - filled)}] {self.done}/{self.total} runs "
                f"({self.skipped} done before, {self.failed} failed), {elapsed:.0f} s, ETA {eta}")
        percent = int(100 * fraction)
        if self.tty:
            self.stream.write("\r" + line)
            if self.done == self.total:
                self.stream.write("\n")
        elif percent // 10 != self._last_percent // 10 or self.done == self.total:
            self.stream.write(line + "\n")
        self._last_percent = percent
        self.stream.flush()


def start_client(scheduler=None, workers=None, threads_per_worker=1, local_directory=None):
    """A distributed.Client: on the given scheduler, or on a LocalCluster of
    `workers` processes bound to 127.0.0.1 (default: one per core), their
    scratch space in local_directory (default Dask's, under /tmp)."""
    from distributed import Client, LocalCluster
    if scheduler:
        return Client(scheduler), None
    cluster = LocalCluster(n_workers=workers or os.cpu_count(), threads_per_worker=threads_per_worker,
                           processes=True, host="127.0.0.1", dashboard_address=None,
                           protocol="tcp", silence_logs=40, local_directory=local_directory)
    return Client(cluster), cluster


def run_campaign(campaign, out_dir, scheduler=None, workers=None, limit=None, progress_stream=sys.stderr):
    """Runs every task not yet done; returns (done_now, skipped, failed).
    limit: stop after this many new runs (for tests and trial runs)."""
    os.makedirs(os.path.join(out_dir, "runs"), exist_ok=True)
    pending = [t for t in campaign.tasks if not is_done(out_dir, t.key)]
    skipped = len(campaign.tasks) - len(pending)
    if limit is not None:
        pending = pending[:limit]
    progress = Progress(skipped + len(pending), skipped, progress_stream)
    failed = 0
    if pending:
        from distributed import as_completed
        client, cluster = start_client(scheduler, workers,
                                       local_directory=os.path.join(out_dir, ".dask-worker-space"))
        try:
            by_future = {}
            futures = []
            for task in pending:
                future = client.submit(worker.execute, task, key=f"tribo-run-{task.key}", pure=False)
                by_future[future.key] = task
                futures.append(future)
            for future in as_completed(futures):
                task = by_future[future.key]
                try:
                    result = future.result()
                except Exception as e:  # noqa: BLE001 - a lost worker; recorded as failed, retried on restart
                    failed += 1
                    progress.advance(False)
                    print(f"\nrun {task.key} failed: {type(e).__name__}: {e}", file=progress_stream)
                    continue
                record_result(out_dir, task, result)
                ok = result["row"].get("status") == "ok"
                failed += 0 if ok else 1
                progress.advance(ok)
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    return len(pending), skipped, failed
