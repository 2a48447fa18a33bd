"""Progress of a project run: instances done out of N, elapsed time and ETA.

On a terminal the line is redrawn in place; otherwise (a log file, a CI job)
each update is a line of its own, at most one every ``interval`` seconds, so
logs stay readable. Nothing is shown for runs shorter than ``delay``.
"""

from __future__ import annotations

import sys
import time

from .plan import duration


class Progress:
    """Counts instances and reports them on ``stream`` (stderr by default).

    Parameters
    ----------
    total
        N when known, else None (then no percentage or ETA).
    stream
        Where to write; a terminal gets an in-place line.
    delay, interval
        Seconds before the first report, and between reports (default 0.5 s
        on a terminal, 10 s otherwise).

    Examples
    --------
    >>> import io
    >>> out = io.StringIO()
    >>> p = Progress(200, stream=out, delay=0.0, interval=0.0)
    >>> p.update(50); p.close()
    >>> out.getvalue().splitlines()[0].split(",")[0]
    'falsifying: 50 / 200 instances (25.0 %)'
    """

    def __init__(self, total: int | None, *, stream=None, delay: float = 3.0, interval: float | None = None,
                 label: str = "falsifying"):
        self.total, self.label = total, label
        self.stream = sys.stderr if stream is None else stream
        isatty = getattr(self.stream, "isatty", None)
        self.tty = bool(isatty and isatty())
        self.delay = delay
        self.interval = interval if interval is not None else (0.5 if self.tty else 10.0)
        self.start = time.monotonic()
        self.last = -float("inf")
        self.done = 0
        self.shown = False

    def line(self) -> str:
        elapsed = time.monotonic() - self.start
        text = f"{self.label}: {self.done:,}"
        if self.total:
            share = self.done / self.total
            text += f" / {self.total:,} instances ({100.0 * share:.1f} %), {duration(elapsed)}"
            if 0 < share < 1:
                text += f", ETA {duration(elapsed * (1 - share) / share)}"
        else:
            text += f" instances, {duration(elapsed)}"
        return text

    def _emit(self) -> None:
        if self.tty:
            self.stream.write("\r" + self.line() + "\x1b[K")
        else:
            self.stream.write(self.line() + "\n")
        self.stream.flush()
        self.shown = True

    def update(self, n: int) -> None:
        """``n`` more instances done."""
        self.done += n
        now = time.monotonic()
        if now - self.start >= self.delay and now - self.last >= self.interval:
            self.last = now
            self._emit()

    def close(self) -> None:
        """The final count (only if anything was shown)."""
        if self.shown:
            self._emit()
            if self.tty:
                self.stream.write("\n")
                self.stream.flush()
