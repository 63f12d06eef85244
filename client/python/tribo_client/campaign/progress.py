"""The campaign's progress line on stderr, counted in runs:

    [######......] 12/40 runs, 4 before, 0 failed, 31 s, ETA 70 s

Redrawn in place on a terminal, one line per 10 % otherwise. Never wider
than the terminal (its width less one column, so that no terminal wraps it),
or 80 columns when stderr is not a terminal; the bar shrinks first."""

import os
import sys
import time

DEFAULT_COLUMNS = 80
MAX_BAR = 30
MIN_BAR = 5


def stream_columns(stream):
    """The width to draw in: $COLUMNS when set, else the terminal's, else 80."""
    try:
        columns = int(os.environ.get("COLUMNS", ""))
        if columns > 0:
            return columns
    except ValueError:
        pass
    try:
        return os.get_terminal_size(stream.fileno()).columns
    except (AttributeError, OSError, ValueError):
        return DEFAULT_COLUMNS


class Progress:
    def __init__(self, total, skipped, stream=sys.stderr, columns=None):
        self.total, self.done, self.failed, self.skipped = total, skipped, 0, skipped
        self.stream = stream
        self.tty = stream.isatty()
        self.columns = columns or (stream_columns(stream) if self.tty else DEFAULT_COLUMNS)
        self.started = time.monotonic()
        self._last_percent = -1
        self._drawn = 0
        self.draw()

    def advance(self, ok):
        self.done += 1
        self.failed += 0 if ok else 1
        self.draw()

    def line(self):
        fraction = self.done / self.total if self.total else 1.0
        elapsed = time.monotonic() - self.started
        fresh = self.done - self.skipped
        eta = f"{elapsed / fresh * (self.total - self.done):.0f} s" if fresh else "?"
        text = f"{self.done}/{self.total} runs, {self.skipped} before, {self.failed} failed, {elapsed:.0f} s, ETA {eta}"
        room = self.columns - 1
        bar = min(MAX_BAR, room - len(text) - 3)  # "[" bar "] "
        if bar < MIN_BAR:
            return text[:room]
        filled = int(round(bar * fraction))
        return f"[{'#' * filled}{'.' * (bar - filled)}] {text}"

    def draw(self):
        line = self.line()
        percent = int(100 * (self.done / self.total if self.total else 1.0))
        if self.tty:
            self.stream.write("\r" + line.ljust(self._drawn))
            self._drawn = len(line)
            if self.done == self.total:
                self.stream.write("\n")
        elif percent // 10 != self._last_percent // 10 or self.done == self.total:
            self.stream.write(line + "\n")
        self._last_percent = percent
        self.stream.flush()

    def interrupt(self):
        """Ends the line in place on a terminal, before another message."""
        if self.tty and self.done != self.total:
            self.stream.write("\n")
            self.stream.flush()
