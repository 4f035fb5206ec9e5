"""Progress on the terminal: the rendering of the progress callbacks that the numerical and
sweep code calls (``progress(done, total)``). That code only calls the callback; drawing a
rich progress bar or printing log lines is done here (or by the CLI, which passes
``typer.echo`` where a callback takes a message).
"""

from __future__ import annotations

import sys
import time


class ProgressReporter:
    """Progress of a sweep: a rich progress bar on a terminal, otherwise one log line per
    ``every`` points (and at the end), each with points done, rate and ETA. ``unit``: what
    is counted (``points``; ``blocks`` for a Lyapunov exponent's renormalisation blocks).
    ``after``: nothing is shown before this many seconds have passed since the reporter was
    made (a task that ends sooner shows no progress at all)."""

    def __init__(self, label: str, quiet: bool = False, every: int | None = None,
                 unit: str = "points", after: float = 0.0):
        self.label, self.quiet, self.every, self.unit = label, quiet, every, unit
        self.after = after
        self.start, self.last, self.bar = time.perf_counter(), -1, None
        self.tty = sys.stderr.isatty()

    def __call__(self, done: int, total: int) -> None:
        if self.quiet or done == self.last:
            return
        if self.last < 0 and time.perf_counter() - self.start < self.after:
            return  # not yet: short tasks stay silent
        if self.tty:
            self._bar(done, total)
        else:
            every = self.every or max(1, total // 20)
            if done == total or done // every != max(self.last, 0) // every or self.last < 0:
                elapsed = time.perf_counter() - self.start
                rate = done / elapsed if elapsed > 0 else 0.0
                eta = f"{(total - done) / rate:.0f} s" if rate > 0 else "–"
                print(f"{self.label}: {done}/{total} {self.unit}, {rate:.2f} {self.unit}/s, "
                      f"ETA {eta}", file=sys.stderr, flush=True)
        self.last = done

    def _bar(self, done: int, total: int) -> None:
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            ProgressColumn,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )
        from rich.text import Text

        unit = "pts" if self.unit == "points" else self.unit

        class RateColumn(ProgressColumn):
            def render(self, task) -> Text:
                return Text(f"{task.speed:.2f} {unit}/s" if task.speed else f"– {unit}/s")

        if self.bar is None:
            self.bar = Progress(TextColumn(self.label), BarColumn(), MofNCompleteColumn(),
                                RateColumn(), TimeElapsedColumn(), TextColumn("ETA"),
                                TimeRemainingColumn())
            self.bar.start()
            self.task = self.bar.add_task(self.label, total=total, completed=done)
        self.bar.update(self.task, completed=done)
        if done >= total:
            self.bar.stop()
