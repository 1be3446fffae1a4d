"""Factories that ``omnislam.estimators`` calls for ``graphslam`` and ``graphslam-batch``."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from omnislam.core.modality import Modality
from omnislam.core.motion import OdometryMotionModel
from omnislam.core.sequence_info import SequenceInfo
from omnislam.errors import ConfigError
from omnislam.graphslam.config import PRESETS, GraphSLAMConfig
from omnislam.options import apply_options

#: the option the dataset's camera height sets unless given (``PoseConfig.sensor_height_m``)
SENSOR_HEIGHT_OPTION = "poses.sensor_height_m"

if TYPE_CHECKING:
    from omnislam.graphslam.batch import BatchGraphSLAM
    from omnislam.graphslam.isam import GraphSLAM


def _config(info: SequenceInfo | None, options: Mapping[str, str]) -> GraphSLAMConfig:
    options = dict(options)
    preset = options.pop("preset", "default")
    if preset not in PRESETS:
        raise ConfigError(f"unknown graphslam preset {preset!r}; known: {', '.join(PRESETS)}")
    config = PRESETS[preset]
    height = None if info is None else info.sensor_height_m
    if height is not None and SENSOR_HEIGHT_OPTION not in options:
        options[SENSOR_HEIGHT_OPTION] = str(height)
    return apply_options(config, options)


def check_options(options: Mapping[str, str]) -> None:
    """Validate ``--set`` options (preset and every field) without building the graph."""
    _config(None, options)


def _modality(info: SequenceInfo) -> Modality:
    """The stream the registry resolved (``SequenceInfo.modality``)."""
    modality = info.modality
    if not isinstance(modality, Modality):
        raise ConfigError(f"graphslam needs the resolved modality of the run, got {modality!r}")
    return modality


def make_estimator(
    info: SequenceInfo, options: Mapping[str, str], rng: np.random.Generator
) -> GraphSLAM:
    """iSAM2 on ``info.modality``, ``PRESETS[preset]`` (default ``default``) with ``--set``."""
    from omnislam.graphslam.isam import GraphSLAM

    del rng  # deterministic
    config = _config(info, options)
    return GraphSLAM(_modality(info), config, motion=OdometryMotionModel(config.motion_noise))


def make_batch_estimator(
    info: SequenceInfo, options: Mapping[str, str], rng: np.random.Generator
) -> BatchGraphSLAM:
    """iSAM2 then Levenberg-Marquardt on the whole graph, warm-started (``graphslam-batch``)."""
    from omnislam.graphslam.batch import BatchGraphSLAM

    del rng
    config = _config(info, options)
    return BatchGraphSLAM(_modality(info), config, motion=OdometryMotionModel(config.motion_noise))
