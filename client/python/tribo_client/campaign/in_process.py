"""Runs of a campaign in the driver process, one after another, on a thread
(the native module releases the GIL while it simulates and analyses, so the
driver's main thread goes on recording, and starting a cluster). The local
default begins this way: a campaign whose runs would all be done before a
local cluster could start and pay for itself never starts one (runner.py)."""

import queue
import threading
import time

from . import worker


class InProcessRunner(threading.Thread):
    """Takes tasks from the front of `tasks` (a deque shared with the main
    thread, under `lock`) until it is empty or stop() is called; puts
    (task, result) on `results`, then None when it ends."""

    def __init__(self, tasks, lock):
        super().__init__(name="tribo-campaign-in-process", daemon=True)
        self.tasks, self.lock = tasks, lock
        self.results = queue.Queue()
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
        try:
            while not self._stop_requested.is_set():
                with self.lock:
                    if not self.tasks:
                        break
                    task = self.tasks.popleft()
                self._running_since = time.monotonic()
                result = worker.execute_safely(task)
                self._running_since = None
                self.results.put((task, result))
        finally:
            self.results.put(None)
