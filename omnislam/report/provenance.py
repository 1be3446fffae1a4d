"""How a report was made: omnislam version and commit, date, command line, machine.

Everything here is best effort and never raises: a value that cannot be found is "unknown".
"""

from __future__ import annotations

import datetime
import hashlib
import os
import platform
import shlex
import subprocess
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

UNKNOWN = "unknown"


def package_commit(source: Path | None = None) -> str:
    """``git rev-parse HEAD`` of the folder holding the omnislam package when that folder is a
    git checkout (" (uncommitted changes)" appended when tracked files differ), else "unknown".
    """
    try:
        if source is None:
            import omnislam

            source = Path(omnislam.__file__).resolve().parent.parent
        if not (source / ".git").exists():
            return UNKNOWN
        head = subprocess.run(
            ["git", "-C", str(source), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        ).stdout.strip()
        if len(head) != 40:
            return UNKNOWN
        dirty = subprocess.run(
            ["git", "-C", str(source), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=10,
        )
        if dirty.returncode == 0 and dirty.stdout.strip():
            return head + " (uncommitted changes)"
        return head
    except Exception:
        return UNKNOWN


def cpu_model(cpuinfo: Path = Path("/proc/cpuinfo")) -> str:
    """The CPU model from /proc/cpuinfo when present, else platform's guess, else "unknown"."""
    try:
        for line in cpuinfo.read_text(errors="replace").splitlines():
            key, _, value = line.partition(":")
            if (
                key.strip() in ("model name", "Hardware", "Processor", "cpu model")
                and value.strip()
            ):
                return value.strip()
    except OSError:
        pass
    try:
        return platform.processor() or platform.machine() or UNKNOWN
    except Exception:
        return UNKNOWN


def file_digest(path: Path) -> str | None:
    """First 12 hex digits of the file's SHA-256 (None when unreadable)."""
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()[:12]
    except OSError:
        return None


def path_length_m(positions: np.ndarray) -> float:
    """Length of a polyline of positions [m] (NaN rows skipped)."""
    p = np.asarray(positions, dtype=float)
    p = p[np.all(np.isfinite(p), axis=1)]
    if len(p) < 2:
        return 0.0
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


@dataclass(frozen=True, slots=True)
class Machine:
    cpu: str
    cores: int | None
    python: str
    platform: str


def machine() -> Machine:
    try:
        plat = platform.platform()
    except Exception:
        plat = UNKNOWN
    return Machine(cpu_model(), os.cpu_count(), platform.python_version(), plat)


def now_utc() -> str:
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")


def shown_path(path: str | Path, cwd: Path | None = None, cache: Path | None = None) -> str:
    """A path as a report shows it, without this machine's folders: relative to the working
    folder when inside it, ``$OMNISLAM_CACHE/...`` when inside the cache, else ``.../NAME``
    (its last component); a relative path or a registered dataset name as given.

    Args:
        path: the path (or any string: only absolute paths are rewritten).
        cwd: the working folder (default: the current one).
        cache: the cache folder (default: ``harness.cache.cache_dir()``).
    """
    text = str(path)
    if not os.path.isabs(text):
        return text
    try:
        from omnislam.harness.cache import CACHE_ENV, cache_dir

        resolved = Path(text).resolve()
        for base, prefix in (
            ((cwd or Path.cwd()).resolve(), ""),
            ((cache or cache_dir()).resolve(), f"${CACHE_ENV}/"),
        ):
            if resolved == base or base in resolved.parents:
                relative = resolved.relative_to(base).as_posix()
                return f"{prefix}{relative}" if prefix or relative != "." else "."
        return f".../{resolved.name}"
    except Exception:
        return f".../{Path(text).name}"


def command_line(argv: Sequence[str] | None = None) -> str:
    """``argv`` (default ``sys.argv``) as a shell-quoted line, absolute paths as
    ``shown_path`` shows them."""
    args = list(sys.argv if argv is None else argv)
    try:
        return shlex.join(shown_path(a) for a in args) if args else UNKNOWN
    except Exception:
        return UNKNOWN
