"""``omnislam`` command line: a thin parser per command, heavy imports only inside ``run``.

Each command lives in its own module of this package and exposes ``add_parser(subparsers)``
and ``run(args) -> int``. Errors of the package (``OmnislamError``) become one line on stderr
and exit code 2; logging is configured here and nowhere else.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Sequence

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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="omnislam",
        description="Compare SLAM back ends on one shared omnidirectional front end.",
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress details")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for module in COMMANDS.values():
        importlib.import_module(f"omnislam.cli.{module}").add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``omnislam`` console script."""
    from omnislam.errors import OmnislamError

    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )
    try:
        return int(args.handler(args) or 0)
    except OmnislamError as exc:
        print(f"omnislam {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"omnislam {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
