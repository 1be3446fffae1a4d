"""``omnislam`` command line: a thin parser per command, heavy imports only inside ``run``.

Each command lives in its own module of this package and exposes ``add_parser(subparsers)``
and ``run(args) -> int``. ``main`` is the one error path: an error of the package
(``OmnislamError``: bad input, named file or key) becomes one line on stderr and exit code 2;
any other exception is a bug and becomes one line asking for a report, exit code 1, with the
traceback only under ``--debug``. A reader that goes away (``omnislam dataset list | head -1``)
ends the command quietly with exit code 141 (128 + SIGPIPE, as other Unix tools). Logging is
configured here and nowhere else: warnings (and Python ``warnings``) are held back until the
command ends and printed only when it succeeds (or fails with a bug under ``--debug``), so an
error is never preceded by a loader's WARNING; ``--verbose`` and ``--debug`` print everything as
it happens. Third-party libraries that log INFO lines by themselves (Dask's ``distributed``:
scheduler and worker start-up) are kept at WARNING unless ``--verbose``. Progress of long
commands goes to stderr (``omnislam._progress``); ``--quiet`` silences it.

Every command that writes follows one overwrite rule (``omnislam._files.check_overwrite``): an
existing output is refused unless ``--overwrite``.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import sys
import traceback
from collections.abc import Sequence
from typing import NoReturn

#: command name -> module of this package that implements it
COMMANDS: dict[str, str] = {
    "dataset": "dataset",
    "estimators": "estimators",
    "frontend": "frontend",
    "run": "run",
    "evaluate": "evaluate",
    "compare": "compare",
    "report": "report",
    "demo": "demo",
    "view": "view",
    "calibrate": "calibrate",
}

#: exit code of a command whose output pipe was closed by its reader (128 + SIGPIPE)
EXIT_BROKEN_PIPE = 141
#: loggers of third-party libraries that print INFO lines on their own (kept at WARNING)
QUIET_LOGGERS = ("distributed", "dask", "bokeh", "tornado", "asyncio")


class _OneLineParser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line on stderr (exit 2), like every other
    bad input; the usage itself stays in ``--help``. Sub-command parsers inherit the class."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


class _SubcommandParser(_OneLineParser):
    """The parser of a command (``omnislam dataset list``): arguments it does not know are its
    usage error, naming it (argparse hands them up to ``omnislam``, which named only itself).
    Nested commands inherit the class (``add_subparsers`` defaults to the parent's class)."""

    def parse_known_args(  # type: ignore[override]
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> tuple[argparse.Namespace, list[str]]:
        namespace, extras = super().parse_known_args(args, namespace)
        if extras:
            self.error(f"unrecognized arguments: {' '.join(extras)}")
        return namespace, extras


def build_parser() -> argparse.ArgumentParser:
    import omnislam

    parser = _OneLineParser(
        prog="omnislam",
        description="Compare SLAM back ends on one shared omnidirectional front end.",
        epilog="Every command that writes refuses an existing output unless --overwrite. "
        "Progress goes to stderr (plain lines when stderr is not a terminal). "
        "See `omnislam COMMAND --help`.",
    )
    parser.add_argument(
        "--version", action="version", version=f"omnislam {omnislam.__version__}"
    )
    parser.add_argument(
        "-v", "--verbose", action="store_true", help="log details, third-party INFO included"
    )
    parser.add_argument(
        "-q", "--quiet", action="store_true", help="no progress lines on stderr"
    )
    parser.add_argument(
        "--debug",
        action="store_true",
        help="print warnings as they happen and the traceback of an unexpected error",
    )
    sub = parser.add_subparsers(
        dest="command", metavar="COMMAND", required=True, parser_class=_SubcommandParser
    )
    for module in COMMANDS.values():
        importlib.import_module(f"omnislam.cli.{module}").add_parser(sub)
    return parser


class _HeldBack(logging.Handler):
    """Holds log records back; ``print_held`` prints them to the stderr of that moment.

    (Not named ``release``: ``logging.Handler.release`` frees the handler's lock after every
    record, which would print each record as it arrives and never free the lock.)
    """

    def __init__(self, level: int) -> None:
        super().__init__(level)
        self.records: list[logging.LogRecord] = []
        self.setFormatter(logging.Formatter(_FORMAT))

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)

    def print_held(self) -> None:
        """Print each distinct line once (a warning logged by every cell of a grid, or by the
        command and by its cells, is one line)."""
        for line in dict.fromkeys(self.format(record) for record in self.records):
            print(line, file=sys.stderr)
        self.records.clear()


class _Stderr(logging.Handler):
    """Prints each record to whatever ``sys.stderr`` is when it arrives (test capture included)."""

    def emit(self, record: logging.LogRecord) -> None:
        print(self.format(record), file=sys.stderr)


_FORMAT = "%(levelname)s %(name)s: %(message)s"


#: environment variables a command sets for itself and the processes it starts (put back after)
COMMAND_ENVIRONMENT = ("DASK_LOGGING__DISTRIBUTED", "OMNISLAM_PROGRESS")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``omnislam`` console script (see the module docstring for exit codes)."""
    saved = {name: os.environ.get(name) for name in COMMAND_ENVIRONMENT}
    try:
        return _main(argv)
    except BrokenPipeError:  # --help, --version, --template into a closed pipe
        _silence_stdout()
        return EXIT_BROKEN_PIPE
    finally:  # a caller in the same process (tests, scripts) keeps its own environment
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def _main(argv: Sequence[str] | None) -> int:
    from omnislam.errors import OmnislamError

    parser = build_parser()
    args = parser.parse_args(argv)
    if args.quiet:
        from omnislam._progress import set_enabled

        set_enabled(False)
    if not args.verbose:
        quiet_third_party()
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
        sys.stdout.flush()  # a closed pipe shows here, inside the error path, not at exit
    except BrokenPipeError:
        _silence_stdout()
        return EXIT_BROKEN_PIPE
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
            handler.print_held()
        return code
    finally:
        logging.captureWarnings(False)
        root.removeHandler(handler)
        root.setLevel(previous_level)


def quiet_third_party() -> None:
    """Keep the INFO lines of Dask / distributed (and their web stack) off stderr.

    ``distributed`` installs its own stderr handler at INFO when it is imported, in this process
    and in every worker it starts; its configuration is read from the environment when dask is
    first imported, so the level is set there (inherited by worker processes) and on the loggers
    of modules already imported.
    """
    os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "warning")
    for name in QUIET_LOGGERS:
        logging.getLogger(name).setLevel(logging.WARNING)


def _silence_stdout() -> None:
    """Point stdout at /dev/null so that the interpreter's last flush cannot fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass


def _one_line(exc: BaseException) -> str:
    """An exception's message with line breaks folded (one stderr line, always)."""
    return " ".join(str(exc).split()) or type(exc).__name__


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
