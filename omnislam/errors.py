"""The package's own exceptions; the CLI turns them into one line on stderr and exit code 2."""

from __future__ import annotations


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
