"""Factories: ``make_fastslam`` from a configuration, and the registry's ``fastslam1`` / ``2``."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from omnislam.core.modality import MODALITY_OPTION, Modality
from omnislam.core.motion import OdometryMotionModel
from omnislam.core.sequence_info import SequenceInfo
from omnislam.core.types import OdometrySource
from omnislam.errors import ConfigError
from omnislam.fastslam.config import PRESETS, FastSLAMConfig, Variant
from omnislam.fastslam.filter import FastSLAM
from omnislam.options import apply_options

#: the option that chose 2-D or 3-D before the shared modality (``--set modality=NAME``)
_REMOVED_OPTION = "sensor_mode"


def make_fastslam(
    config: FastSLAMConfig,
    modality: Modality,
    rng: np.random.Generator,
    initial_pose: np.ndarray | None = None,
    odometry_source: OdometrySource = OdometrySource.WHEEL,
) -> FastSLAM:
    """A FastSLAM of ``config`` on ``modality``, its motion model built from
    ``config.motion_noise`` (the thesis's odometry model, eqs. 4.38-4.44); ``odometry_source``
    as ``FastSLAM`` takes it.

    Raises:
        ConfigError: a modality FastSLAM does not consume.
    """
    motion = OdometryMotionModel(config.motion_noise)
    return FastSLAM(
        config,
        rng,
        modality=modality,
        motion=motion,
        initial_pose=initial_pose,
        odometry_source=odometry_source,
    )


def _config(
    variant: Variant, info: SequenceInfo | None, options: Mapping[str, str]) -> FastSLAMConfig:
    """The configuration of ``variant``: its preset (or ``preset=NAME``) with ``--set``."""
    options = dict(options)
    if _REMOVED_OPTION in options:
        raise ConfigError(
            f"option {_REMOVED_OPTION!r} was replaced by the shared "
            f"{MODALITY_OPTION}=range-bearing-2d|bearings-3d"
        )
    preset = options.pop("preset", variant.value)
    if preset not in PRESETS:
        raise ConfigError(f"unknown fastslam preset {preset!r}; known: {', '.join(PRESETS)}")
    config: FastSLAMConfig = PRESETS[preset]
    if config.variant is not variant:
        raise ConfigError(f"preset {preset!r} is {config.variant.value}, not {variant.value}")
    height = None if info is None else info.sensor_height_m
    if height is not None and "sensor_height_m" not in options:
        config = config.with_(sensor_height_m=float(height))
    return apply_options(config, options)


def _make(
    variant: Variant, info: SequenceInfo, options: Mapping[str, str], rng: np.random.Generator
) -> FastSLAM:
    config = _config(variant, info, options)
    return make_fastslam(config, info.modality, rng, odometry_source=info.odometry_source)


def check_fastslam1_options(options: Mapping[str, str]) -> None:
    """Validate ``fastslam1``'s ``--set`` options without building the filter."""
    _config(Variant.FASTSLAM1, None, options)


def check_fastslam2_options(options: Mapping[str, str]) -> None:
    """Validate ``fastslam2``'s ``--set`` options without building the filter."""
    _config(Variant.FASTSLAM2, None, options)


def make_fastslam1(
    info: SequenceInfo, options: Mapping[str, str], rng: np.random.Generator
) -> FastSLAM:
    """FastSLAM 1.0 from ``PRESETS["fastslam1"]`` (or ``preset=NAME``) with ``--set`` overrides,
    on the modality the registry resolved (``info.modality``)."""
    return _make(Variant.FASTSLAM1, info, options, rng)


def make_fastslam2(
    info: SequenceInfo, options: Mapping[str, str], rng: np.random.Generator
) -> FastSLAM:
    """FastSLAM 2.0 from ``PRESETS["fastslam2"]`` (or ``preset=NAME``) with ``--set`` overrides,
    on the modality the registry resolved (``info.modality``)."""
    return _make(Variant.FASTSLAM2, info, options, rng)
