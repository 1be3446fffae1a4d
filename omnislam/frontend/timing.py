"""Time per front-end stage (extract, group, match, verify, track, ...): wall-clock and CPU."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager


class StageClock:
    """Accumulates seconds per named stage; ``with clock("extract"): ...``.

    ``seconds`` holds wall-clock time and ``cpu_seconds`` the process's CPU time (every
    thread's, OpenCV's workers included) spent inside the stage, so stages timed from two
    threads of one process at once would count each other's CPU. Thread-safe.
    """

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self.cpu_seconds: dict[str, float] = {}
        self._lock = threading.Lock()

    @contextmanager
    def __call__(self, stage: str) -> Iterator[None]:
        start, cpu = time.perf_counter(), time.process_time()
        try:
            yield
        finally:
            self.add(stage, time.perf_counter() - start, time.process_time() - cpu)

    def add(self, stage: str, seconds: float, cpu_seconds: float = 0.0) -> None:
        with self._lock:
            self.seconds[stage] = self.seconds.get(stage, 0.0) + seconds
            self.cpu_seconds[stage] = self.cpu_seconds.get(stage, 0.0) + cpu_seconds

    def total(self) -> float:
        return sum(self.seconds.values())


def children_cpu_s() -> float | None:
    """User + system CPU seconds of this process's ended (waited-for) children; None where
    the platform does not count them (not POSIX)."""
    try:
        import resource
    except ImportError:  # not POSIX
        return None
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def cpu_with_children_s() -> float:
    """CPU seconds of this process and of its ended children (the front end's worker
    processes and their fork server; POSIX, this process alone elsewhere)."""
    return time.process_time() + (children_cpu_s() or 0.0)
