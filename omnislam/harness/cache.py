"""Where omnislam caches what it can recompute: reference solutions, front-end logs of runs.

One folder, ``$OMNISLAM_CACHE`` or ``$XDG_CACHE_HOME/omnislam`` (``~/.cache/omnislam``); every
entry is keyed by what it is a function of, so a stale entry is never reused, and deleting the
folder only costs time.
"""

from __future__ import annotations

import os
from pathlib import Path

#: environment variable naming the cache folder
CACHE_ENV = "OMNISLAM_CACHE"


def cache_dir() -> Path:
    """The cache folder (``$OMNISLAM_CACHE``, else the user cache's ``omnislam``)."""
    override = os.environ.get(CACHE_ENV)
    if override:
        return Path(override).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "omnislam"
