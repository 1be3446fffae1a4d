"""Shared fixtures and the tolerances the tests use, named in one place."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO_ROOT.parent / "shared" / "data"


@pytest.fixture(scope="session", autouse=True)
def _private_cache(tmp_path_factory: pytest.TempPathFactory):
    """Caches the code writes (the victoria-park-gtsam LM reference) go to a temporary folder,
    never to the user's ``~/.cache``."""
    patch = pytest.MonkeyPatch()
    patch.setenv("OMNISLAM_CACHE", str(tmp_path_factory.mktemp("omnislam-cache")))
    yield
    patch.undo()


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20081105)


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The real recorded data folder (../shared/data); skips the test when it is absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real data not found at {SHARED_DATA}")
    return SHARED_DATA
