"""Fixtures of the compare tests."""

from __future__ import annotations

from pathlib import Path

import pytest
from room_log import write_room_log


@pytest.fixture
def room_log(tmp_path: Path) -> Path:
    """A 60-frame corrected CARMEN log with pseudo ground truth and laser scans."""
    return write_room_log(tmp_path / "data" / "room.log")
