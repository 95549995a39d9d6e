"""Progress of long work: a bar on a terminal, a few lines in a log.

A tqdm bar redraws itself hundreds of times; on a terminal that is one line, but written to a
file (a batch job, CI, ``2> log``) every redraw stays, about a thousand per ``pcgeom param``.
So :class:`Progress` draws a tqdm bar only when its stream is a terminal, and otherwise writes
one line when its task ends (with the figures the bar showed), plus, for a task of many items
(scans), one line at each tenth; :func:`log` writes a line only to a log (a terminal has the
bars). Both write to stderr, so stdout keeps only results (``--json``).
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["Progress", "log", "on_terminal"]


def on_terminal(stream: TextIO | None = None) -> bool:
    """Whether ``stream`` (default: stderr) is an interactive terminal."""
    stream = sys.stderr if stream is None else stream
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # closed or not a file
        return False


def log(message: str, *, enabled: bool = True, stream: TextIO | None = None) -> None:
    """Write ``pcgeom: message`` as one line to ``stream`` (stderr) when it is not a terminal."""
    stream = sys.stderr if stream is None else stream
    if enabled and not on_terminal(stream):
        print(f"pcgeom: {message}", file=stream, flush=True)


class Progress:
    """A tqdm bar on a terminal; on a log, one line at the end (and at each tenth when
    ``milestones``).

    Parameters
    ----------
    total : int
        Items of the task.
    desc : str
        What the task is ("stage 2/5", "refine", "scans").
    enabled : bool
        False: nothing at all (``--quiet``).
    unit : str
    initial : int
        Items already done (a resumed batch).
    milestones : bool
        On a log, also one line at each tenth of ``total`` (for tasks of many slow items).
    """

    def __init__(self, total: int, desc: str, *, enabled: bool = True, unit: str = "it",
                 initial: int = 0, milestones: bool = False,
                 stream: TextIO | None = None) -> None:
        self.total, self.desc, self.unit, self.n = total, desc, unit, initial
        self.enabled, self.milestones = enabled, milestones
        self.stream = sys.stderr if stream is None else stream
        self.postfix: dict[str, str] = {}
        self.t0 = time.perf_counter()
        self.bar = None
        self._tenth = self._tenths()
        if enabled and on_terminal(self.stream):
            from tqdm.auto import tqdm

            self.bar = tqdm(total=total, desc=desc, unit=unit, initial=initial, leave=False,
                            dynamic_ncols=True, file=self.stream)

    def _tenths(self) -> int:
        return 10 * self.n // self.total if self.total > 0 else 0

    def _line(self) -> str:
        figures = "".join(f", {k} {v}" for k, v in self.postfix.items())
        return (f"pcgeom: {self.desc}: {self.n}/{self.total} {self.unit} in "
                f"{time.perf_counter() - self.t0:.1f} s{figures}")

    @property
    def logging(self) -> bool:
        """Writing lines to a log (enabled, and the stream is not a terminal)."""
        return self.enabled and self.bar is None

    def update(self, n: int = 1) -> None:
        self.n += n
        if self.bar is not None:
            self.bar.update(n)
        elif self.logging and self.milestones and 0 < self.n < self.total:
            tenth = self._tenths()
            if tenth > self._tenth:
                self._tenth = tenth
                print(self._line(), file=self.stream, flush=True)

    def set_postfix(self, values: dict[str, str]) -> None:
        """Figures shown beside the bar, and on the log's last line."""
        self.postfix = dict(values)
        if self.bar is not None:
            self.bar.set_postfix(self.postfix)

    def write(self, message: str) -> None:
        """A line of its own (above the bar on a terminal)."""
        if self.bar is not None:
            self.bar.write(message, file=self.stream)
        elif self.enabled:
            print(message, file=self.stream, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None
        elif self.logging:
            print(self._line(), file=self.stream, flush=True)
        self.enabled = False  # a second close writes nothing

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
