"""Progress of long commands on stderr: items done, rate, ETA and what is running.

One ``Progress`` per stage of a command (rendering, front end, runs, report). A stage that
ends within ``FIRST_LINE_DELAY_S`` (``QUIET_STAGE_DELAY_S`` for one that counts nothing, such
as loading) prints nothing: short commands and bad input stay quiet, an error is then the only
line on stderr. A longer one prints, depending on what stderr is:

* a terminal: one line redrawn in place (carriage return, erase-to-end-of-line) at most
  ``TTY_INTERVAL_S`` apart, cut to the terminal's width, ended by a newline with the stage;
* anything else (a pipe, a log file, CI): plain lines, never an escape code or a carriage
  return, at most one every ``PLAIN_INTERVAL_S`` (environment ``OMNISLAM_PROGRESS_INTERVAL``,
  seconds), and one when the stage ends.

A stage's line is printed even while nothing reports (a ticker thread: a long "final estimate"
still shows its time). Stages nest (a run's "front end" stage holds the front end's own
progress): only the innermost open stage prints, the outer one waits until it ends.
``OMNISLAM_PROGRESS=0`` (or ``omnislam --quiet``) silences every progress line; results and
errors are printed as before. A line reads::

    frontend demo-seed0: 30/59 img (51%), 2.6 img/s, ETA 0:11
    run graphslam-batch on lab40: final estimate (0:42)

Progress goes to whatever ``sys.stderr`` is at the moment it prints (so test capture sees it).
"""

from __future__ import annotations

import math
import os
import shutil
import sys
import threading
import time
import weakref
from types import TracebackType
from typing import TextIO

#: seconds between two plain (non-terminal) lines of one stage
PLAIN_INTERVAL_S = 10.0
#: seconds between two redraws of the terminal line
TTY_INTERVAL_S = 0.2
#: a counting stage shorter than this prints nothing [s] (at most the plain interval)
FIRST_LINE_DELAY_S = 1.0
#: the same for a stage that counts nothing (loading, validating: where bad input is found)
QUIET_STAGE_DELAY_S = 5.0
#: environment variables: "0"/"off"/"no"/"false" silences progress; plain-line interval [s]
ENABLE_VARIABLE = "OMNISLAM_PROGRESS"
INTERVAL_VARIABLE = "OMNISLAM_PROGRESS_INTERVAL"
_OFF = {"0", "off", "no", "false"}
_ERASE_LINE = "\x1b[K"
_WRITE_LOCK = threading.Lock()
#: the open stages, innermost last: only that one prints (weak: a stage abandoned by an
#: exception, never closed, goes away with its last reference, and so does its ticker)
_OPEN: list[weakref.ref[Progress]] = []


def enabled() -> bool:
    """False when progress is silenced (``OMNISLAM_PROGRESS=0`` or ``omnislam --quiet``)."""
    return os.environ.get(ENABLE_VARIABLE, "1").strip().lower() not in _OFF


def set_enabled(on: bool) -> None:
    """Switch progress on or off for this process and the processes it starts."""
    os.environ[ENABLE_VARIABLE] = "1" if on else "0"


def plain_interval_s() -> float:
    """Seconds between plain lines (``OMNISLAM_PROGRESS_INTERVAL``, default PLAIN_INTERVAL_S)."""
    text = os.environ.get(INTERVAL_VARIABLE)
    try:
        value = float(text) if text is not None else PLAIN_INTERVAL_S
    except ValueError:
        return PLAIN_INTERVAL_S
    return value if value >= 0 and math.isfinite(value) else PLAIN_INTERVAL_S


def format_duration(seconds: float) -> str:
    """``75`` -> ``"1:15"``, ``3725`` -> ``"1:02:05"`` (whole seconds, rounded up)."""
    if not math.isfinite(seconds) or seconds < 0:
        return "?"
    total = math.ceil(seconds)
    hours, rest = divmod(total, 3600)
    minutes, secs = divmod(rest, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"


def format_rate(done: float, elapsed_s: float, unit: str) -> str:
    """``"12.3 frame/s"``, or ``"2.5 s/frame"`` below one per second ("" before any)."""
    if done <= 0 or elapsed_s <= 0:
        return ""
    rate = done / elapsed_s
    if rate >= 1000.0:
        return f"{rate:.0f} {unit}/s"
    if rate >= 1.0:
        return f"{rate:.3g} {unit}/s"
    return f"{1.0 / rate:.3g} s/{unit}"


class Progress:
    """The progress of one stage (see the module docstring for where and how it prints).

    Args:
        label: what the stage is ("frontend demo", "run graphslam on lab40").
        total: number of items the stage will do (None: unknown; no percentage or ETA).
        unit: what an item is ("frame", "img", "cell").
        stream: where to print (default: ``sys.stderr`` at each print).
        interval_s: plain-line interval (default: ``plain_interval_s()``).
        tty: force terminal (True) or plain (False) output (default: ``stream.isatty()``).
    """

    def __init__(
        self,
        label: str,
        total: int | None = None,
        unit: str = "frame",
        *,
        stream: TextIO | None = None,
        interval_s: float | None = None,
        tty: bool | None = None,
    ) -> None:
        self.label = label
        self.total = total
        self.unit = unit
        self.done = 0
        self.doing = ""
        self.note = ""
        self._stream = stream
        self._enabled = enabled()
        self._tty = self._is_tty() if tty is None else tty
        plain = plain_interval_s() if interval_s is None else float(interval_s)
        self._interval_s = TTY_INTERVAL_S if self._tty else plain
        self._plain_s = plain
        self._start = time.monotonic()
        #: (time, items done) at the first update: the rate and ETA count from there, so what
        #: the stage spent before it (loading, setting up) is not taken for work
        self._mark: tuple[float, int] | None = None
        self._last_print = -math.inf
        self._printed = False
        self._closed = threading.Event()
        self._lock = threading.Lock()
        self._ticker: threading.Thread | None = None
        if self._enabled:
            with _WRITE_LOCK:
                _OPEN.append(weakref.ref(self))
            period = min(max(self._interval_s, TTY_INTERVAL_S), 1.0)
            self._ticker = threading.Thread(
                target=_tick, args=(weakref.ref(self), self._closed, period), daemon=True
            )
            self._ticker.start()

    # -- state -------------------------------------------------------------------------------

    def update(
        self,
        done: int | None = None,
        *,
        advance: int = 0,
        total: int | None = None,
        doing: str | None = None,
        note: str | None = None,
        quiet: bool = False,
    ) -> None:
        """Set the items done (or ``advance`` them), the total, what is running now, and a
        ``note`` shown before the counts ("3/7 cells"); ``quiet``: do not print now."""
        with self._lock:
            if note is not None:
                self.note = note
            if total is not None:
                self.total = total
            if done is not None:
                self.done = int(done)
            self.done += int(advance)
            if doing is not None:
                self.doing = doing
            if self._mark is None:
                self._mark = (time.monotonic(), self.done)
        if not quiet:
            self._print()

    def advance(self, n: int = 1) -> None:
        """``update(advance=n)``."""
        self.update(advance=n)

    def set_total(self, total: int | None) -> None:
        """Change the total (None: unknown) without printing."""
        with self._lock:
            self.total = total

    def close(self, summary: str | None = None) -> None:
        """End the stage: its last line (``summary`` instead of the counts when given, then the
        time it took), printed
        when the stage lasted FIRST_LINE_DELAY_S or printed before."""
        if self._closed.is_set():
            return
        self._closed.set()
        self._leave()
        elapsed = time.monotonic() - self._start
        if not self._enabled or (not self._printed and elapsed < self._delay_s()):
            return
        if summary:
            text = f"{self.label}: {summary} in {format_duration(elapsed)}"
        else:
            text = self._text(final=True)
            text += f"{'' if text.endswith(':') else ','} done in {format_duration(elapsed)}"
        self._write(text, final=True)

    def abandon(self) -> None:
        """End the stage without a last line (it failed; the error says why)."""
        if self._closed.is_set():
            return
        self._closed.set()
        self._leave()
        if self._tty and self._printed and self._enabled:
            self._write_raw("\n")

    def __enter__(self) -> Progress:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        if kind is None:
            self.close()
        else:
            self.abandon()

    # -- text --------------------------------------------------------------------------------

    def eta_s(self) -> float | None:
        """Seconds left at the mean rate since the first update (None when unknown)."""
        if self.total is None or self._mark is None:
            return None
        worked = self.done - self._mark[1]
        elapsed = time.monotonic() - self._mark[0]
        if worked <= 0 or elapsed <= 0:
            return None
        return max(self.total - self.done, 0) * elapsed / worked

    def _text(self, final: bool = False) -> str:
        with self._lock:
            parts = [self.note] if self.note else []
            if self.total is not None:
                share = f" ({100.0 * self.done / self.total:.0f}%)" if self.total > 0 else ""
                parts.append(f"{self.done}/{self.total} {self.unit}{share}")
            elif self.done:
                parts.append(f"{self.done} {self.unit}")
            if self._mark is not None:
                rate = format_rate(
                    self.done - self._mark[1], time.monotonic() - self._mark[0], self.unit
                )
                if rate:
                    parts.append(rate)
            timed = False
            if not final:
                eta = self.eta_s()
                if eta is not None and self.total is not None and self.done < self.total:
                    parts.append(f"ETA {format_duration(eta)}")
                    timed = True
            text = f"{self.label}: {', '.join(parts)}" if parts else f"{self.label}:"
            if final:
                return text
            if self.doing:
                text += f" - {self.doing}" if parts else f" {self.doing}"
            if not timed:  # no ETA (nothing counted yet): say for how long it has been going
                text += f" ({format_duration(time.monotonic() - self._start)})"
            return text

    # -- output ------------------------------------------------------------------------------

    def _leave(self) -> None:
        with _WRITE_LOCK:
            _OPEN[:] = [ref for ref in _OPEN if ref() is not None and ref() is not self]

    def _delay_s(self) -> float:
        quiet = self.total is None and self.done == 0
        return min(QUIET_STAGE_DELAY_S if quiet else FIRST_LINE_DELAY_S, self._plain_s)

    def _out(self) -> TextIO:
        return self._stream if self._stream is not None else sys.stderr

    def _is_tty(self) -> bool:
        try:
            return bool(self._out().isatty())
        except (AttributeError, ValueError):
            return False

    def _print(self) -> None:
        if not self._enabled or self._closed.is_set():
            return
        now = time.monotonic()
        if not self._printed and now - self._start < self._delay_s():
            return
        if now - self._last_print < self._interval_s:
            return
        text = self._text()
        with _WRITE_LOCK:  # checked and written at once: an inner stage cannot open between
            _OPEN[:] = [ref for ref in _OPEN if ref() is not None]
            if self._closed.is_set() or (_OPEN and _OPEN[-1]() is not self):
                return
            self._last_print = now
            self._write(text, locked=True)

    def _write(self, text: str, final: bool = False, locked: bool = False) -> None:
        if self._tty:
            width = max(shutil.get_terminal_size((100, 24)).columns - 1, 20)
            self._write_raw("\r" + text[:width] + _ERASE_LINE + ("\n" if final else ""), locked)
        else:
            self._write_raw(text + "\n", locked)
        self._printed = True

    def _write_raw(self, text: str, locked: bool = False) -> None:
        if not locked:
            with _WRITE_LOCK:
                self._write_raw(text, locked=True)
            return
        out = self._out()
        try:
            out.write(text)
            out.flush()
        except (OSError, ValueError):  # a closed stderr: progress is never worth an error
            self._enabled = False


def _tick(ref: weakref.ref[Progress], closed: threading.Event, period_s: float) -> None:
    """A stage's ticker: print its line while nothing reports, until it closes or is gone."""
    while not closed.wait(period_s):
        progress = ref()
        if progress is None:
            return
        progress._print()
        del progress


class Stages:
    """An ``on_step(stage, done, total)`` callback shown as one Progress per stage.

    A stage that counts (it starts with ``done < total``) shows its frames, rate and ETA; one
    that does not ("loading", "front end", "final estimate") shows for how long it has been
    going. A new stage ends the previous one.

    Args:
        label: what runs ("run graphslam on lab40").
        unit: what the stages count.
    """

    def __init__(self, label: str, unit: str = "frame") -> None:
        self.label = label
        self.unit = unit
        self.stage: str | None = None
        self._current: Progress | None = None
        self._counts = False

    def __call__(self, stage: str, done: int, total: int) -> None:
        if stage != self.stage:
            self.close()
            self.stage = stage
            counts = 0 <= done < total
            self._current = Progress(self.label, total if counts else None, self.unit)
            self._counts = counts
        assert self._current is not None
        if self._counts:
            self._current.update(done, total=total, doing=stage)
        else:
            self._current.update(doing=stage)

    def close(self, ok: bool = True) -> None:
        """End the current stage's line (``ok=False``: the stage failed, no last line)."""
        if self._current is not None:
            if ok:
                self._current.close(None if self._counts else f"{self.stage} done")
            else:
                self._current.abandon()
            self._current = None

    def __enter__(self) -> Stages:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self.close(ok=kind is None)
