"""The factory that ``omnislam.estimators`` calls for ``ukf``."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from omnislam.core.modality import Modality
from omnislam.core.sequence_info import SequenceInfo
from omnislam.errors import ConfigError
from omnislam.options import apply_options
from omnislam.ukf.config import UKFConfig
from omnislam.ukf.image_line import AngularLine, image_line_from_rig
from omnislam.ukf.localiser import VerticalLineUKF


def make_estimator(
    info: SequenceInfo, options: Mapping[str, str], rng: np.random.Generator
) -> VerticalLineUKF:
    """The vertical-line UKF from ``UKFConfig`` with ``--set`` overrides (no randomness used).

    The 1-D image comes from the sequence's camera rig when it has one (``SequenceInfo
    .calibration``) and the sightings are vertical lines; otherwise (MR.CLAM bearings) it is an
    ``AngularLine`` of ``image.pixels_per_rad`` and ``image.fov_rad``.

    Raises:
        ConfigError: no prior map (the message says how to give one), an unknown option, or a
            map the configuration cannot use.
    """
    del rng
    prior_map, name = info.prior_map, info.name
    if prior_map is None:
        raise ConfigError(
            f"ukf localises in a known map and {name} has none; give one with "
            "--set prior_map=RUN_DIR (e.g. a graphslam run on the same data)"
        )
    config = apply_options(UKFConfig(), options)
    modality = info.modality or Modality.VERTICAL_LINES
    rig = info.calibration
    image = config.image
    if modality is Modality.VERTICAL_LINES and rig is not None:
        image_line = image_line_from_rig(rig, image.fov_widening)
    else:
        image_line = AngularLine(image.pixels_per_rad, image.fov_rad, image.fov_widening)
    sigma = info.sigma_bearing_rad
    if config.filter.sigma_bearing_rad is None and sigma is not None and sigma <= 0:
        raise ConfigError(f"ukf: {name} states a non-positive bearing sigma")
    return VerticalLineUKF(prior_map, config, modality, image_line)


def check_options(options: Mapping[str, str]) -> None:
    """Validate ``--set`` options against ``UKFConfig`` without building the filter."""
    apply_options(UKFConfig(), options)
