"""The package's own exceptions; the CLI turns them into one line on stderr and exit code 2.

``did_you_mean`` is the one hint of every message about an unknown name (an estimator, an
option key, a dataset): the known names nearest to it.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


class OmnislamError(Exception):
    """Base class of every error omnislam raises on purpose."""


class DataError(OmnislamError):
    """A file or array given to omnislam is malformed, inconsistent or missing.

    The message names the file (when there is one) and what is wrong with it; ``reason`` is
    what is wrong alone (for a caller that names the file its own way).
    """

    def __init__(self, message: str, path: object | None = None) -> None:
        self.path = path
        self.reason = message
        super().__init__(f"{path}: {message}" if path is not None else message)


class ConfigError(OmnislamError):
    """A configuration value or option is out of range or unknown."""


class MissingExtraError(OmnislamError, ImportError):
    """An optional dependency is not installed; the message names the extra to install."""

    def __init__(self, module: str, extra: str) -> None:
        self.module = module
        self.extra = extra
        super().__init__(
            f"{module} is not installed; install the '{extra}' extra: "
            f"pip install '.[{extra}]' in an omnislam clone"
        )


class EstimationError(OmnislamError):
    """An estimator reached a state it cannot continue from (e.g. a singular system)."""


def nearest(name: str, known: Iterable[str], *, count: int = 3, cutoff: float = 0.6) -> list[str]:
    """The known names most similar to ``name``, nearest first (``difflib.get_close_matches``:
    at most ``count``, each of similarity ``SequenceMatcher.ratio`` >= ``cutoff``)."""
    return difflib.get_close_matches(name, list(known), n=count, cutoff=cutoff)


def did_you_mean(
    name: str,
    known: Iterable[str],
    *,
    count: int = 3,
    cutoff: float = 0.6,
    otherwise: Iterable[str] = (),
) -> str:
    """`` (did you mean 'a' or 'b'?)``: the known names nearest to an unknown one, or "".

    Args:
        name: the unknown name as given.
        known: the names it could have meant.
        count: at most this many suggestions, nearest first.
        cutoff: the least similarity of a suggestion (``difflib.SequenceMatcher.ratio``, 0-1).
        otherwise: the names to suggest when none is that similar.
    """
    near = nearest(name, known, count=count, cutoff=cutoff) or list(otherwise)
    return f" (did you mean {' or '.join(repr(n) for n in near)}?)" if near else ""
