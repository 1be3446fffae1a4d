"""The factory ``omnislam.estimators`` calls for ``ekfslam``."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from omnislam.core.modality import Modality
from omnislam.ekfslam.config import EKFSLAMConfig
from omnislam.ekfslam.filter import EKFSLAM
from omnislam.errors import ConfigError
from omnislam.options import apply_options


def make_estimator(info: object, options: Mapping[str, str], rng: np.random.Generator) -> EKFSLAM:
    """EKF-SLAM from the default ``EKFSLAMConfig`` with ``--set`` overrides.

    The filter is deterministic (``rng`` is unused); the sighting noise comes from the data.

    Raises:
        ConfigError: an unknown option or a bad value, or a modality other than 2-D range-bearing.
    """
    del rng
    modality = getattr(info, "modality", None)
    if modality is not None and modality is not Modality.RANGE_BEARING_2D:
        raise ConfigError(f"ekfslam consumes range_bearing_2d sightings, not {modality.value}")
    return EKFSLAM(apply_options(EKFSLAMConfig(), options))


def check_options(options: Mapping[str, str]) -> None:
    """Validate ``--set`` options against ``EKFSLAMConfig`` without building the filter."""
    apply_options(EKFSLAMConfig(), options)
