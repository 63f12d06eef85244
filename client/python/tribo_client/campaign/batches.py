"""How runs are grouped into Dask tasks. A Dask task costs about 20 ms of
scheduling, serialisation and round trip (bench/campaign_bench.py), as much
as a whole sub-second run; so runs travel in batches sized from the wall
time of the runs done so far: each task lasts about TASK_TARGET_S, and a
batch never takes so many of the runs left that some worker slots would sit
idle at the end (each slot keeps at least TASKS_PER_SLOT_LEFT tasks)."""

import math
import statistics

TASK_TARGET_S = 1.0
TASKS_PER_SLOT_LEFT = 3
# The cost of the runs in progress is judged from the last runs only: a
# campaign's runs may differ in length (protocols, grid values).
RECENT_RUNS = 16


class RunCost:
    """The wall time per run, from the runs done so far (their row's wall_s)."""

    def __init__(self):
        self._recent = []

    def add(self, row):
        seconds = (row or {}).get("wall_s")
        if isinstance(seconds, (int, float)) and math.isfinite(seconds) and seconds >= 0:
            self._recent = (self._recent + [float(seconds)])[-RECENT_RUNS:]

    @property
    def per_run_s(self):
        """The median of the recent runs, None before the first."""
        return statistics.median(self._recent) if self._recent else None


def batch_size(per_run_s, remaining, slots):
    """Runs in the next task: 1 while the cost is unknown."""
    if remaining <= 0:
        return 0
    if per_run_s is None:
        return 1
    by_time = max(1, int(TASK_TARGET_S / max(per_run_s, 1e-3)))
    by_balance = max(1, math.ceil(remaining / (TASKS_PER_SLOT_LEFT * max(1, slots))))
    return min(by_time, by_balance, remaining)
