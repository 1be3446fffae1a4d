"""File helpers: atomic writes (a failure never leaves a half-written file behind), safe names,
output locations checked before any work starts, one-line YAML errors, the errors of a bad npz."""

from __future__ import annotations

import os
import re
import tempfile
import zipfile
import zlib
from pathlib import Path
from typing import Any

from omnislam.errors import ConfigError, DataError

_SAFE = re.compile(r"[^A-Za-z0-9._=+-]+")

#: what ``np.load`` of a missing, truncated or corrupt ``.npz`` (or reading one of its arrays)
#: raises; loaders turn these into a DataError naming the file
NPZ_ERRORS: tuple[type[BaseException], ...] = (
    OSError,
    ValueError,
    EOFError,
    KeyError,
    zipfile.BadZipFile,
    zlib.error,
)


def npz_reason(exc: BaseException) -> str:
    """Why an npz could not be read, in one line (a truncated file raises BadZipFile)."""
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}; the file is truncated or corrupt"


def safe_name(text: str) -> str:
    """``text`` reduced to characters safe in a file or folder name."""
    return _SAFE.sub("-", text).strip("-") or "x"


def check_output_location(path: str | Path, what: str = "output") -> None:
    """Raise ConfigError unless ``path`` can be created or replaced (checked before any work).

    Walks up to the nearest existing ancestor: it must be a writable folder (a regular file on
    the way, e.g. ``--out some.txt/run``, or a read-only folder is refused). An existing
    ``path`` that is a regular file is left to the caller (some outputs are files).

    Raises:
        ConfigError: "<path>: cannot write the <what> here: <reason>".
    """
    path = Path(path)
    parent = path.parent
    while not parent.exists() and parent != parent.parent:
        if parent.is_symlink():  # a dangling link
            break
        parent = parent.parent
    if not parent.is_dir():
        raise ConfigError(f"{path}: cannot write the {what} here: {parent} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ConfigError(f"{path}: cannot write the {what} here: {parent} is read-only")


def output_error(exc: OSError, path: str | Path, what: str = "output") -> ConfigError:
    """The one-line ConfigError of an OSError met while writing ``path``."""
    reason = exc.strerror or str(exc)
    where = f" ({exc.filename})" if exc.filename and str(exc.filename) != str(path) else ""
    return ConfigError(f"{path}: cannot write the {what}: {reason}{where}")


def yaml_error_line(exc: Exception) -> str:
    """A YAML syntax error as one line: ``line L, column C: problem`` (PyYAML prints 5-8)."""
    mark = getattr(exc, "problem_mark", None)
    problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    context = getattr(exc, "context", None)
    where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""
    text = f"{context}, {problem}" if context else str(problem)
    return f"{where}not valid YAML ({' '.join(text.split())})"


def read_yaml(path: str | Path, error: type[Exception] = DataError) -> Any:
    """Parse a YAML file; unreadable files and syntax errors become one-line ``error``s."""
    import yaml

    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise _error(error, "file not found", path) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise _error(
            error, f"cannot read the file ({getattr(exc, 'strerror', None) or exc})", path
        ) from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise _error(error, yaml_error_line(exc), path) from None


def _error(error: type[Exception], message: str, path: Path) -> Exception:
    return error(message, path) if issubclass(error, DataError) else error(f"{path}: {message}")


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write ``text`` to a temporary file next to ``path``, then rename it into place."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as handle:
            handle.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
