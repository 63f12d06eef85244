"""Runs of a campaign in the driver process, one after another, on a thread
that also records each result (the native module releases the GIL while it
simulates and analyses; the main thread only looks in now and then, to start
a cluster, so the two hardly ever wait for each other's GIL on a loaded
machine). The local default begins this way: a campaign whose runs would all
be done before a local cluster could start and pay for itself never starts
one (runner.py)."""

import threading
import time

from . import worker


class InProcessRunner(threading.Thread):
    """Takes tasks from the front of `tasks` (a deque shared with the main
    thread, under `lock`) until it is empty or stop() is called; hands each
    (task, result) to `record` on this thread."""

    def __init__(self, tasks, lock, record):
        super().__init__(name="tribo-campaign-in-process", daemon=True)
        self.tasks, self.lock, self.record = tasks, lock, record
        self._stop_requested = threading.Event()
        self._running_since = None

    def stop(self):
        """Takes no further task; the run in progress finishes."""
        self._stop_requested.set()

    def running_for_s(self):
        """How long the run in progress has taken so far (0 when idle)."""
        since = self._running_since
        return time.monotonic() - since if since is not None else 0.0

    def run(self):
        while not self._stop_requested.is_set():
            with self.lock:
                if not self.tasks:
                    break
                task = self.tasks.popleft()
            self._running_since = time.monotonic()
            result = worker.execute_safely(task)
            self._running_since = None
            self.record(task, result)
