"""What an estimator may know about a run before it sees the frames (``SequenceInfo``).

Every estimator factory takes one (``omnislam.estimators.EstimatorFactory``): the harness builds
it from the loaded sequence and the frames as fed (``harness.frames.sequence_info``), and the
registry fills in the modality it resolved.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from omnislam.core.modality import Modality
from omnislam.core.types import OdometrySource, PriorMap


@dataclass(frozen=True, slots=True)
class SequenceInfo:
    """What an estimator may know about a run before it sees the frames.

    Attributes:
        name: the sequence's name.
        frames: number of frames.
        modalities: the observation streams the frames carry (with the front-end log's).
        modality: the stream the estimator consumes, resolved by ``make_estimator``
            (``core.modality.resolve_modality``); None before that.
        known_association: sightings carry landmark ids (not UNKNOWN_ID).
        sigma_range_m, sigma_bearing_rad: the loader's sighting noise, when it states one.
        sensor_height_m: height of the omni camera's single viewpoint above the ground plane
            (from the calibration rig), when the sequence has a camera.
        prior_map: the map known before the run (``Sequence.prior_map``, or the landmarks of
            an earlier RUN_DIR), for localisers; None when there is none.
        calibration: the sequence's camera rig (``omnislam.camera.CameraRig``) when it has
            images, for estimators that express pixel thresholds as angles (the UKF); else None.
        facts: the sequence's ``info`` mapping (free-form, for logging).
        odometry_source: where the frames' odometry comes from (``OdometrySource``: the
            dataset's wheels, or the front end's scan matching with a covariance measured per
            step).
    """

    name: str
    frames: int
    modalities: frozenset[Modality] = frozenset()
    modality: Modality | None = None
    known_association: bool = False
    sigma_range_m: float | None = None
    sigma_bearing_rad: float | None = None
    sensor_height_m: float | None = None
    prior_map: PriorMap | None = None
    calibration: Any = None
    facts: Mapping[str, str] = field(default_factory=dict)
    odometry_source: OdometrySource = OdometrySource.WHEEL
