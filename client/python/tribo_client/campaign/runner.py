"""Runs a campaign: on an existing Dask scheduler, or by default in this
process and on a LocalCluster on 127.0.0.1. The driver (this process) writes
each finished run at once, atomically, to OUT/runs/<key>/ (result.json with
the row, the reports, and the run's exact config, protocol and seed); a
restart skips every key that has its result.json, so a killed or interrupted
campaign loses only the runs in flight. The results table is rebuilt from
the run folders afterwards (cli.py).

The local default starts running in this process (in_process.py) and starts
a LocalCluster only once the runs left are estimated to take more than
CLUSTER_WORTH_S in a serial loop; the runs go to the cluster in batches
(batches.py). Ctrl-C (KeyboardInterrupt) cancels the tasks not done, closes
the cluster and returns with Outcome.interrupted set."""

import collections
import contextlib
import json
import os
import signal
import sys
import threading
import uuid
from dataclasses import dataclass, field

from google.protobuf import text_format

from tribo.v1 import daemon_config_pb2, protocol_pb2

from . import worker
from .batches import RunCost, batch_size
from .in_process import InProcessRunner
from .progress import Progress

# A 2-worker LocalCluster took 1.2-1.7 s to start and 0.5 s to close on a
# loaded 2-core VM (2026-11-29): below about 3 s of serial work left it
# cannot pay for itself.
CLUSTER_WORTH_S = 3.0
# Tasks queued per worker thread beyond the one it runs: no worker waits
# for the driver between two tasks.
IN_FLIGHT_PER_SLOT = 2
# How often the main thread looks at the in-process runs, to start a cluster.
IN_PROCESS_LOOK_S = 0.1

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


@dataclass
class Outcome:
    """What run_campaign did. attempted: runs finished this time, recorded
    or failed; left: runs of the spec without a result.json afterwards;
    task_sizes: runs per Dask task, in submission order."""
    attempted: int = 0
    skipped: int = 0
    failed: int = 0
    left: int = 0
    in_process: int = 0
    interrupted: bool = False
    task_sizes: list = field(default_factory=list)


class _Recorder:
    """Writes each result as it arrives, advances the progress line, learns
    the per-run cost; from the main thread and the in-process runner's."""

    def __init__(self, out_dir, progress, stream, outcome):
        self.out_dir, self.progress, self.stream, self.outcome = out_dir, progress, stream, outcome
        self.cost = RunCost()
        self._errors_said = set()
        self._lock = threading.Lock()

    def result(self, task, result):
        with self._lock:
            if "exception" in result:
                self._failed(task, result["exception"])
                return
            record_result(self.out_dir, task, result)
            ok = result["row"].get("status") == "ok"
            self.outcome.attempted += 1
            self.outcome.failed += 0 if ok else 1
            self.cost.add(result["row"])
            self.progress.advance(ok)

    def in_process_result(self, task, result):
        with self._lock:
            self.outcome.in_process += 1
        self.result(task, result)

    def failed(self, task, error):
        """A run without a result (a lost worker, an exception): not recorded, retried on restart."""
        with self._lock:
            self._failed(task, error)

    def _failed(self, task, error):
        self.outcome.attempted += 1
        self.outcome.failed += 1
        if error not in self._errors_said:  # each cause once, not once per run
            self._errors_said.add(error)
            self.progress.interrupt()
            print(f"run {task.key} failed: {error}", file=self.stream)
        self.progress.advance(False)


def run_campaign(campaign, out_dir, scheduler=None, workers=None, limit=None, progress_stream=sys.stderr):
    """Runs every task not yet done; returns an Outcome. limit: stop after
    this many new runs (trial runs, tests). workers: local worker processes
    (default: one per core); with one, every run is done in this process."""
    os.makedirs(os.path.join(out_dir, "runs"), exist_ok=True)
    pending = [t for t in campaign.tasks if not is_done(out_dir, t.key)]
    outcome = Outcome(skipped=len(campaign.tasks) - len(pending))
    if limit is not None:
        pending = pending[:max(0, limit)]
    progress = Progress(outcome.skipped + len(pending), outcome.skipped, progress_stream)
    recorder = _Recorder(out_dir, progress, progress_stream, outcome)
    try:
        if pending and scheduler:
            _run_on_scheduler(scheduler, pending, recorder)
        elif pending:
            _run_locally(pending, workers or os.cpu_count() or 1, recorder,
                         os.path.join(out_dir, ".dask-worker-space"))
    except KeyboardInterrupt:
        outcome.interrupted = True
        progress.interrupt()
    outcome.left = sum(1 for t in campaign.tasks if not is_done(out_dir, t.key))
    return outcome


@contextlib.contextmanager
def _sigint_ignored():
    """A second Ctrl-C while the cluster closes would leave its worker
    processes behind: ignored until the cleanup is done."""
    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    try:
        yield
    finally:
        if main:
            signal.signal(signal.SIGINT, previous)


def _close(client, cluster):
    with _sigint_ignored():
        if client is not None:
            _drop_batched_send_timeout_report(client)
            client.close()
        if cluster is not None:
            cluster.close()


def _drop_batched_send_timeout_report(client):
    """Dask distributed 2022.12's client sends its last messages on closing
    through a batched sender that then waits 10 ms with a timeout; when the
    scheduler closes the stream first, the client stops its event loop
    without waiting for that sender, and a timeout that fired in the loop's
    last turn is reported at exit as "Future exception was never retrieved
    ... TimeoutError('Timeout')" (in about one close of ten on a loaded
    2-core VM, on an existing scheduler; tornado's with_timeout in
    distributed/batched.py's _background_send, seen with
    PYTHONASYNCIODEBUG=1). Nothing waits for that timeout: this report alone
    is dropped, every other goes to asyncio's default handler."""
    loop = getattr(client.loop, "asyncio_loop", None)
    if loop is None:
        return

    def handler(loop, context):
        exception = context.get("exception")
        if isinstance(exception, TimeoutError) and str(exception) == "Timeout" \
                and context.get("message", "").startswith("Future exception was never retrieved"):
            return
        loop.default_exception_handler(context)

    loop.set_exception_handler(handler)


def _run_on_scheduler(address, tasks, recorder):
    client, cluster = start_client(scheduler=address)
    try:
        _run_on_cluster(client, tasks, recorder, lambda: _scheduler_slots(client))
    finally:
        _close(client, cluster)


def _scheduler_slots(client):
    """Worker threads on the scheduler now (at least 1: workers may join later)."""
    workers = client.scheduler_info().get("workers", {})
    return max(1, sum(w.get("nthreads", 1) for w in workers.values()))


def _run_locally(tasks, workers, recorder, local_directory):
    """In this process first; a LocalCluster of `workers` processes once the
    runs left are worth one. The in-process runner goes on while the cluster
    starts."""
    todo, lock = collections.deque(tasks), threading.Lock()
    local = InProcessRunner(todo, lock, recorder.in_process_result)
    local.start()
    client = cluster = None
    try:
        while local.is_alive():
            local.join(timeout=IN_PROCESS_LOOK_S)
            if local.is_alive() and workers > 1 and _worth_a_cluster(recorder.cost, local, todo, lock):
                break
        else:
            return  # all done in this process
        client, cluster = start_client(workers=workers, local_directory=local_directory)
        local.stop()
        with lock:
            rest = list(todo)
            todo.clear()
        _run_on_cluster(client, rest, recorder, lambda: workers)
        local.join()  # its last run, recorded on its thread
    except KeyboardInterrupt:
        local.stop()
        _finish_in_process(local, recorder)
        raise
    finally:
        local.stop()
        _close(client, cluster)


def _finish_in_process(local, recorder):
    """After Ctrl-C: the run in progress in this process ends and is kept
    (a native call cannot be abandoned: the interpreter would abort at
    exit); a second Ctrl-C exits at once, without it."""
    if not local.is_alive():
        return
    recorder.progress.interrupt()
    print("stopping: the run in progress in this process ends first (Ctrl-C again to drop it)", file=recorder.stream)
    previous = signal.signal(signal.SIGINT, lambda *_: os._exit(130))
    try:
        local.join()
    finally:
        signal.signal(signal.SIGINT, previous)


def _worth_a_cluster(cost, local, todo, lock):
    """The serial time left, judged from the runs done (or the one in
    progress, when it already took longer), exceeds CLUSTER_WORTH_S."""
    with lock:
        left = len(todo) + 1
    per_run = max(cost.per_run_s or 0.0, local.running_for_s())
    return per_run * left > CLUSTER_WORTH_S


def _run_on_cluster(client, tasks, recorder, slots):
    """Submits the tasks in batches, at most IN_FLIGHT_PER_SLOT per worker
    thread ahead; records each run as its batch returns."""
    from distributed import as_completed
    todo = collections.deque(tasks)
    in_flight = {}
    completed = as_completed(loop=client.loop)
    try:
        while todo or in_flight:
            n_slots = slots()
            while todo and len(in_flight) < IN_FLIGHT_PER_SLOT * n_slots:
                batch = [todo.popleft() for _ in range(batch_size(recorder.cost.per_run_s, len(todo), n_slots))]
                future = client.submit(worker.execute_batch, batch, pure=False,
                                       key=f"tribo-runs-{batch[0].key}-{len(batch)}-{uuid.uuid4().hex[:8]}")
                in_flight[future.key] = (future, batch)
                completed.add(future)
                recorder.outcome.task_sizes.append(len(batch))
            if not in_flight:
                break
            future = next(completed)
            _, batch = in_flight.pop(future.key)
            try:
                results = future.result()
            except Exception as e:  # noqa: BLE001 - a lost worker: its runs are retried on restart
                for task in batch:
                    recorder.failed(task, f"{type(e).__name__}: {e}")
                continue
            for task, result in zip(batch, results):
                recorder.result(task, result)
    finally:
        if in_flight:  # interrupted: nothing left running for this campaign
            with _sigint_ignored():
                client.cancel([f for f, _ in in_flight.values()])


def _start_forkserver():
    """Ctrl-C reaches every process of the terminal's group. The local
    cluster's worker processes are forked from a forkserver started here
    with SIGINT ignored, which they inherit: the driver alone handles Ctrl-C
    and closes them (spawned workers would each die with a traceback). Must
    run under the "forkserver" multiprocessing method (start_client)."""
    import multiprocessing.forkserver
    from distributed.utils import get_mp_context
    get_mp_context()  # sets Dask's forkserver preload before the server starts
    if threading.current_thread() is not threading.main_thread():
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)  # a few ms: the server's fork and exec
    try:
        multiprocessing.forkserver.ensure_running()
    finally:
        signal.signal(signal.SIGINT, previous)


@contextlib.contextmanager
def _sigint_deferred():
    """A Ctrl-C during the block is raised as KeyboardInterrupt at its end,
    so that what the block starts (a cluster) can be closed."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught = []
    previous = signal.signal(signal.SIGINT, lambda *_: caught.append(True))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if caught:
        raise KeyboardInterrupt


def start_client(scheduler=None, workers=None, threads_per_worker=1, local_directory=None):
    """A distributed.Client: on the given scheduler, or on a LocalCluster of
    `workers` processes bound to 127.0.0.1 (default: one per core), their
    scratch space in local_directory (default Dask's, under /tmp)."""
    import dask
    from distributed import Client, LocalCluster
    if scheduler:
        return Client(scheduler, set_as_default=False), None
    client = cluster = None
    try:
        with _sigint_deferred(), dask.config.set({"distributed.worker.multiprocessing-method": "forkserver"}):
            _start_forkserver()
            # The status page on an ephemeral port: the default 8787 may be taken, and Dask warns on stderr.
            cluster = LocalCluster(n_workers=workers or os.cpu_count(), threads_per_worker=threads_per_worker,
                                   processes=True, host="127.0.0.1", dashboard_address="127.0.0.1:0",
                                   protocol="tcp", silence_logs=40, local_directory=local_directory)
            client = Client(cluster, set_as_default=False)
        return client, cluster
    except BaseException:  # a Ctrl-C during the start: no worker left behind
        _close(client, cluster)
        raise
