"""Estimator registry: a name on the command line -> a lazily imported factory.

Every back end exposes one factory with the signature of ``EstimatorFactory``; ``omnislam run``
and the comparison runner build estimators only through ``make_estimator``, so a new back end
plugs in by adding one line to ``ESTIMATORS``. Factories raise ConfigError for options they do
not know, so a typo on ``--set`` never passes silently.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from omnislam.core.types import Estimator
from omnislam.errors import ConfigError


@dataclass(frozen=True, slots=True)
class SequenceInfo:
    """What an estimator may know about a run before it sees the frames.

    Attributes:
        name: the sequence's name.
        frames: number of frames.
        has_range_bearing: the frames carry range-bearing sightings.
        has_bearings: the frames carry omni bearings (from the front end's log).
        known_association: sightings carry landmark ids (not UNKNOWN_ID).
        sigma_range_m, sigma_bearing_rad: the loader's sighting noise, when it states one.
        sensor_height_m: height of the omni camera's single viewpoint above the ground plane
            (from the calibration rig), when the sequence has a camera.
        facts: the sequence's ``info`` mapping (free-form, for logging).
    """

    name: str
    frames: int
    has_range_bearing: bool = False
    has_bearings: bool = False
    known_association: bool = False
    sigma_range_m: float | None = None
    sigma_bearing_rad: float | None = None
    sensor_height_m: float | None = None
    facts: Mapping[str, str] = field(default_factory=dict)


#: factory(info, options, rng) -> Estimator
EstimatorFactory = Callable[[SequenceInfo, Mapping[str, str], np.random.Generator], Estimator]

#: estimator name -> "module:factory" (imported only when that estimator is used)
ESTIMATORS: dict[str, str] = {
    "deadreckoning": "omnislam.deadreckoning:make_estimator",
    "graphslam": "omnislam.graphslam:make_estimator",
    "graphslam-batch": "omnislam.graphslam:make_batch_estimator",
    "fastslam1": "omnislam.fastslam:make_fastslam1",
    "fastslam2": "omnislam.fastslam:make_fastslam2",
    "ukf": "omnislam.ukf:make_estimator",
    "ekfslam": "omnislam.ekfslam:make_estimator",
}


def estimator_factory(name: str) -> EstimatorFactory:
    """The factory registered under ``name``.

    Raises:
        ConfigError: unknown name (listing the known ones) or a back end not available yet.
    """
    if name not in ESTIMATORS:
        raise ConfigError(f"unknown estimator {name!r}; known: {', '.join(ESTIMATORS)}")
    module_name, attribute = ESTIMATORS[name].split(":")
    module = importlib.import_module(module_name)
    factory = getattr(module, attribute, None)
    if factory is None:
        raise ConfigError(f"estimator {name!r} is not available yet ({ESTIMATORS[name]})")
    return factory


def make_estimator(
    name: str, info: SequenceInfo, options: Mapping[str, str], rng: np.random.Generator
) -> Estimator:
    """Build the estimator ``name`` for a sequence.

    Args:
        name: a key of ESTIMATORS.
        info: what the estimator may know about the sequence up front.
        options: ``--set key=value`` options meant for the estimator (strings; the factory
            parses and validates them).
        rng: the run's random generator (seeded by ``--seed``).

    Returns:
        An object implementing the Estimator protocol.
    """
    return estimator_factory(name)(info, dict(options), rng)
