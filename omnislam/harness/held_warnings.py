"""The warnings of a grid's task, returned with its result instead of printed where it ran.

A loader's warning ("12 sightings with unknown barcodes dropped") is logged by every cell that
loads the dataset; in a worker process it would reach stderr on its own, between the progress
lines, once per cell. ``held_warnings`` holds back what is logged at WARNING or above (and
Python ``warnings``) inside a block, so the task returns them with its result; the runner keeps
each distinct one once (``distinct``) and the command prints them after its progress.
"""

from __future__ import annotations

import logging
import warnings
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class LoggedWarning:
    """One warning a task logged.

    Attributes:
        level: its logging level (``logging.WARNING``, ``logging.ERROR``, ...).
        logger: the name of the logger that logged it (``py.warnings`` for Python warnings).
        message: the message, formatted.
    """

    level: int
    logger: str
    message: str

    def log(self) -> None:
        """Log it again, in this process, through the logger that logged it."""
        logging.getLogger(self.logger).log(self.level, self.message)


class _Holder(logging.Handler):
    """Keeps the records at WARNING or above; passes lower ones on to ``others``."""

    def __init__(self, held: list[LoggedWarning], others: list[logging.Handler]) -> None:
        super().__init__(logging.NOTSET)
        self.held = held
        self.others = others

    def emit(self, record: logging.LogRecord) -> None:
        if record.levelno >= logging.WARNING:
            self.held.append(LoggedWarning(record.levelno, record.name, record.getMessage()))
            return
        for handler in self.others:
            if record.levelno >= handler.level:
                handler.handle(record)


@contextmanager
def held_warnings() -> Iterator[list[LoggedWarning]]:
    """Hold back the warnings of the block; yields the list they are appended to.

    The root logger's handlers are set aside for the block (records below WARNING still reach
    them: ``--verbose`` shows a task's INFO lines as before), and Python warnings are recorded
    rather than shown.
    """
    held: list[LoggedWarning] = []
    root = logging.getLogger()
    saved = root.handlers[:]
    root.handlers = [_Holder(held, saved)]
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("default")
            yield held
        held.extend(
            LoggedWarning(
                logging.WARNING,
                "py.warnings",
                f"{w.filename}:{w.lineno}: {w.category.__name__}: {w.message}",
            )
            for w in caught
        )
    finally:
        root.handlers = saved


def distinct(found: Iterable[LoggedWarning]) -> tuple[LoggedWarning, ...]:
    """Each warning once, in the order of first appearance."""
    return tuple(dict.fromkeys(found))
