"""``omnislam`` command line: a thin parser per command, heavy imports only inside ``run``.

Each command lives in its own module of this package and exposes ``add_parser(subparsers)``
and ``run(args) -> int``. ``main`` is the one error path: an error of the package
(``OmnislamError``: bad input, named file or key) becomes one line on stderr and exit code 2;
any other exception is a bug and becomes one line asking for a report, exit code 1, with the
traceback only under ``--debug``. Logging is configured here and nowhere else: warnings (and
Python ``warnings``) are held back until the command ends and printed only when it succeeds (or
fails with a bug under ``--debug``), so an error is never preceded by a loader's WARNING;
``--verbose`` and ``--debug`` print everything as it happens.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
import traceback
from collections.abc import Sequence
from typing import NoReturn

#: command name -> module of this package that implements it
COMMANDS: dict[str, str] = {
    "dataset": "dataset",
    "frontend": "frontend",
    "run": "run",
    "evaluate": "evaluate",
    "compare": "compare",
    "report": "report",
    "demo": "demo",
    "calibrate": "calibrate",
}


class _OneLineParser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line on stderr (exit 2), like every other
    bad input; the usage itself stays in ``--help``. Sub-command parsers inherit the class."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _OneLineParser(
        prog="omnislam",
        description="Compare SLAM back ends on one shared omnidirectional front end.",
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress details")
    parser.add_argument(
        "--debug",
        action="store_true",
        help="print warnings as they happen and the traceback of an unexpected error",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for module in COMMANDS.values():
        importlib.import_module(f"omnislam.cli.{module}").add_parser(sub)
    return parser


class _HeldBack(logging.Handler):
    """Holds log records back; ``release`` prints them to the stderr of that moment."""

    def __init__(self, level: int) -> None:
        super().__init__(level)
        self.records: list[logging.LogRecord] = []
        self.setFormatter(logging.Formatter(_FORMAT))

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)

    def release(self) -> None:
        for record in self.records:
            print(self.format(record), file=sys.stderr)
        self.records.clear()


class _Stderr(logging.Handler):
    """Prints each record to whatever ``sys.stderr`` is when it arrives (test capture included)."""

    def emit(self, record: logging.LogRecord) -> None:
        print(self.format(record), file=sys.stderr)


_FORMAT = "%(levelname)s %(name)s: %(message)s"


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``omnislam`` console script (see the module docstring for exit codes)."""
    from omnislam.errors import OmnislamError

    parser = build_parser()
    args = parser.parse_args(argv)
    streaming = args.verbose or args.debug
    handler: logging.Handler
    if streaming:
        handler = _Stderr()
        handler.setFormatter(logging.Formatter(_FORMAT))
    else:
        handler = _HeldBack(logging.WARNING)
    root = logging.getLogger()
    previous_level = root.level
    root.addHandler(handler)
    root.setLevel(logging.INFO if args.verbose else logging.WARNING)
    logging.captureWarnings(True)
    try:
        code = int(args.handler(args) or 0)
    except OmnislamError as exc:
        print(f"omnislam {args.command}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"omnislam {args.command}: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # the one place a bug is reported
        if args.debug:
            traceback.print_exc()
        print(
            f"omnislam {args.command}: internal error (a bug, please report it with the "
            f"command line; --debug shows the traceback): {type(exc).__name__}: "
            f"{_one_line(exc)}",
            file=sys.stderr,
        )
        return 1
    else:
        if isinstance(handler, _HeldBack):
            handler.release()
        return code
    finally:
        logging.captureWarnings(False)
        root.removeHandler(handler)
        root.setLevel(previous_level)


def _one_line(exc: BaseException) -> str:
    """An exception's message with line breaks folded (one stderr line, always)."""
    return " ".join(str(exc).split()) or type(exc).__name__


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
