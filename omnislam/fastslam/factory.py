"""Factories that ``omnislam.estimators`` calls for ``fastslam1`` and ``fastslam2``."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from omnislam.errors import ConfigError
from omnislam.fastslam.config import PRESETS, FastSLAMConfig, Variant
from omnislam.fastslam.filter import FastSLAM
from omnislam.options import apply_options


def _make(
    variant: Variant, info: object, options: Mapping[str, str], rng: np.random.Generator
) -> FastSLAM:
    options = dict(options)
    preset = options.pop("preset", variant.value)
    if preset not in PRESETS:
        raise ConfigError(f"unknown fastslam preset {preset!r}; known: {', '.join(PRESETS)}")
    config: FastSLAMConfig = PRESETS[preset]
    if config.variant is not variant:
        raise ConfigError(f"preset {preset!r} is {config.variant.value}, not {variant.value}")
    height = getattr(info, "sensor_height_m", None)
    if height is not None and "sensor_height_m" not in options:
        config = config.with_(sensor_height_m=float(height))
    return FastSLAM(apply_options(config, options), rng)


def make_fastslam1(info: object, options: Mapping[str, str], rng: np.random.Generator) -> FastSLAM:
    """FastSLAM 1.0 from ``PRESETS["fastslam1"]`` (or ``preset=NAME``) with ``--set`` overrides."""
    return _make(Variant.FASTSLAM1, info, options, rng)


def make_fastslam2(info: object, options: Mapping[str, str], rng: np.random.Generator) -> FastSLAM:
    """FastSLAM 2.0 from ``PRESETS["fastslam2"]`` (or ``preset=NAME``) with ``--set`` overrides."""
    return _make(Variant.FASTSLAM2, info, options, rng)
