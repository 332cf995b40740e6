"""Progress reports for long runs: a tqdm bar on a terminal (or in a notebook), plain lines in
a log.

A bar redraws itself with carriage returns, which a file or a pipe keeps as one garbled line,
and bars of nested calls (an ensemble whose chunks print their own bars) overwrite each other.
So a bar is shown by default only where it can be drawn, and a bar asked for explicitly
(``progress=True``) becomes, where it cannot, a line every 10 % or every 30 s at most.
"""

from __future__ import annotations

import sys
import time


def interactive(stream=None) -> bool:
    """Whether a progress bar can be drawn: `stream` (default stderr) is a terminal, or the
    code runs in a Jupyter kernel (where tqdm draws a widget)."""
    stream = sys.stderr if stream is None else stream
    try:
        if stream.isatty():
            return True
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        pass
    return "ipykernel" in sys.modules


class LineProgress:
    """tqdm's update/close/n for logs: one line per report, no carriage returns."""

    def __init__(self, total: int, unit: str, desc: str, initial: int = 0, stream=None,
                 every: float = 30.0, clock=time.monotonic):
        self.total, self.unit, self.desc, self.n = int(total), unit, desc, int(initial)
        self.stream = sys.stderr if stream is None else stream
        self.every, self.clock = every, clock
        self._last_time = clock()
        self._last_tenth = self._tenth()
        self._written = None  # the count of the last line written
        self._closed = False

    def _tenth(self) -> int:
        return 10 * self.n // self.total if self.total > 0 else 10

    def _write(self) -> None:
        share = 100.0 * self.n / self.total if self.total > 0 else 100.0
        print(f"{self.desc}: {share:.0f}% ({self.n:,} of {self.total:,} {self.unit}s)", file=self.stream, flush=True)
        self._last_time = self.clock()
        self._last_tenth = self._tenth()
        self._written = self.n

    def update(self, k: int = 1) -> None:
        self.n += int(k)
        if self._tenth() > self._last_tenth or self.clock() - self._last_time >= self.every:
            self._write()

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            if self._written != self.n:
                self._write()


def bar(total: int, unit: str, desc: str, initial: int = 0, unit_scale: bool = False):
    """A tqdm bar on stderr where it can be drawn, else a :class:`LineProgress`."""
    if not interactive():
        return LineProgress(total, unit, desc, initial)
    from tqdm.auto import tqdm

    return tqdm(total=total, initial=initial, unit=unit, unit_scale=unit_scale, desc=desc, file=sys.stderr)
