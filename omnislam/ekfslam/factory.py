"""The factory ``omnislam.estimators`` calls for ``ekfslam``."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from omnislam.core.modality import Modality
from omnislam.core.sequence_info import SequenceInfo
from omnislam.ekfslam.bearings import BearingEKFSLAM
from omnislam.ekfslam.config import EKFSLAMConfig
from omnislam.ekfslam.filter import EKFSLAM
from omnislam.errors import ConfigError
from omnislam.options import apply_options

#: the option that sets the omni camera's height; the factory takes the rig's otherwise
HEIGHT_OPTION = "bearings.sensor_height_m"


def make_estimator(
    info: SequenceInfo, options: Mapping[str, str], rng: np.random.Generator
) -> EKFSLAM | BearingEKFSLAM:
    """EKF-SLAM from the default ``EKFSLAMConfig`` with ``--set`` overrides.

    On range-bearing sightings the 2-D filter (``filter.EKFSLAM``); on the omni front end's
    bearings the 3-D one with delayed initialisation (``bearings.BearingEKFSLAM``), its
    ``bearings.sensor_height_m`` taken from the calibration rig (``info.sensor_height_m``) unless
    set.
    The filters are deterministic (``rng`` is unused); the sighting noise comes from the data.

    Raises:
        ConfigError: an unknown option or a bad value, or a modality other than these two.
    """
    del rng
    modality = info.modality
    config = EKFSLAMConfig()
    if modality is Modality.BEARINGS_3D:
        height = info.sensor_height_m
        if height is not None and HEIGHT_OPTION not in options:
            config = config.with_(bearings=replace(config.bearings, sensor_height_m=float(height)))
        return BearingEKFSLAM(apply_options(config, options))
    if modality is not None and modality is not Modality.RANGE_BEARING_2D:
        raise ConfigError(
            f"ekfslam consumes range-bearing-2d or bearings-3d sightings, not {modality.value}"
        )
    return EKFSLAM(apply_options(config, options))


def check_options(options: Mapping[str, str]) -> None:
    """Validate ``--set`` options against ``EKFSLAMConfig`` without building the filter."""
    apply_options(EKFSLAMConfig(), options)
