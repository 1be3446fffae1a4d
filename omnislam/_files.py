"""File helpers: atomic writes (a failure never leaves a half-written file behind), safe names,
output locations checked before any work starts, the one overwrite rule, one-line YAML errors,
the errors of a bad npz.

Files and folders written through a temporary name get the permissions a plain ``open`` /
``mkdir`` would give (0644 / 0755 under the usual umask 022), not the private 0600 / 0700 of
``tempfile``: results, reports and caches are meant to be read by others.
"""

from __future__ import annotations

import os
import re
import tempfile
import zipfile
import zlib
from collections.abc import Callable
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


def current_umask() -> int:
    """The process's umask (read by setting it and putting it back)."""
    umask = os.umask(0)
    os.umask(umask)
    return umask


def make_public(path: str | Path) -> None:
    """Give a ``tempfile.mkstemp`` file (0600) or ``mkdtemp`` folder (0700) the permissions of
    a plain ``open`` (0666 & ~umask) or ``mkdir`` (0777 & ~umask)."""
    path = Path(path)
    mode = 0o777 if path.is_dir() else 0o666
    os.chmod(path, mode & ~current_umask())


def check_overwrite(
    path: str | Path,
    overwrite: bool,
    what: str,
    ours: Callable[[Path], bool] | None = None,
    hint: str = "pass --overwrite to replace it",
) -> bool:
    """The one overwrite rule of every command that writes, checked before any work starts.

    An output that does not exist (or is an empty folder) is written. One that exists is
    refused unless ``overwrite`` (``--overwrite``), and even then only when it is what the
    command writes (``ours(path)``: a RUN_DIR, a report, ...): a folder of something else is
    never replaced. The replacement itself is atomic (the old output stays until the new one
    is complete).

    Args:
        path: the output (file or folder).
        overwrite: ``--overwrite`` was given.
        what: what the output is, for the message ("RUN_DIR", "report folder").
        ours: True when ``path`` is an output of this command (default: any file, no folder).
        hint: what to do about an existing output (the message's end).

    Returns:
        True when ``path`` exists and will be replaced.

    Raises:
        ConfigError: "<path>: the <what> exists; pass --overwrite to replace it", or
            "<path>: exists and is not a <what>; refusing to overwrite it".
    """
    path = Path(path)
    if not path.exists() and not path.is_symlink():
        return False
    if path.is_dir() and not path.is_symlink() and not any(path.iterdir()):
        return False
    is_ours = ours(path) if ours is not None else path.is_file()
    if not is_ours:
        raise ConfigError(f"{path}: exists and is not a {what}; refusing to overwrite it")
    if not overwrite:
        raise ConfigError(f"{path}: the {what} exists; {hint}")
    return True


def output_error(
    exc: OSError, path: str | Path, what: str = "output", *, atomic: bool = False
) -> ConfigError:
    """The one-line ConfigError of an OSError met while writing ``path``.

    Args:
        exc: the error.
        path: the output being written.
        what: what the output is, for the message.
        atomic: the output is written aside and renamed into place, so an earlier ``path`` is
            untouched; the message then says so when there is one (a full disk, a quota).
    """
    reason = exc.strerror or str(exc)
    where = f" ({exc.filename})" if exc.filename and str(exc.filename) != str(path) else ""
    kept = f"; the previous {what} is left as it was" if atomic and Path(path).exists() else ""
    return ConfigError(f"{path}: cannot write the {what}: {reason}{where}{kept}")


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
    """Write ``text`` (UTF-8) to a temporary file next to ``path``, then rename it into place."""
    atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to a temporary file next to ``path``, then rename it into place."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
        make_public(tmp)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_texts(texts: dict[Path, str]) -> None:
    """Write several files together: each to a temporary file next to it, then, once all are
    written, rename each into place (a write that fails leaves every earlier file as it was)."""
    staged: list[tuple[Path, Path]] = []
    try:
        for path, text in texts.items():
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
            staged.append((Path(tmp), path))
            with os.fdopen(fd, "w") as handle:
                handle.write(text)
            make_public(tmp)
        for tmp, path in staged:
            os.replace(tmp, path)
    finally:
        for tmp, _ in staged:
            tmp.unlink(missing_ok=True)

