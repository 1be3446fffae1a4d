"""Estimator registry: a name on the command line -> a lazily imported factory.

Every back end exposes one factory with the signature of ``EstimatorFactory``; ``omnislam run``
and the comparison runner build estimators only through ``make_estimator``, so a new back end
plugs in by adding one line to ``ESTIMATORS``: where its factory lives and which modalities
(``core.modality``) it consumes. ``make_estimator`` resolves the modality once, by the shared
rule, and hands it to the factory in ``SequenceInfo.modality``. Factories raise ConfigError for
options they do not know, so a typo on ``--set`` never passes silently.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace

import numpy as np

from omnislam.core.modality import MODALITY_OPTION, Modality, resolve_modality
from omnislam.core.sequence_info import SequenceInfo
from omnislam.core.types import Estimator
from omnislam.errors import ConfigError, did_you_mean

#: factory(info, options, rng) -> Estimator
EstimatorFactory = Callable[[SequenceInfo, Mapping[str, str], np.random.Generator], Estimator]


@dataclass(frozen=True, slots=True)
class EstimatorEntry:
    """One registered estimator.

    Attributes:
        target: ``"module:factory"``, imported only when the estimator is used.
        modalities: the observation streams it consumes; empty for estimators that use no
            sightings at all (dead reckoning).
        check: ``"module:function"`` validating the estimator's ``--set`` options without
            building it (``function(options)`` raises ConfigError); a grid checks every cell's
            options with it before any work starts.
        summary: what the estimator is, in one line (``omnislam estimators``).
        config: ``"module:attribute"`` of its configuration: a dataclass (its defaults) or a
            mapping of named presets (``--set preset=NAME``); "" when it takes no options.
        preset: the preset of ``config`` the estimator starts from when it is a mapping.
        floor_tracks: it models the floor, so it takes the front end's floor tracks
            (``frontend.floor_tracks``, ``ObservationLog.floor_ids_from``) among the omni
            bearings; the others are fed the landmark tracks alone (``harness.frames``). The
            graph places them on the floor (``graphslam.floor_points``); a filter would take
            them as ordinary landmarks and, on lab40, FastSLAM 2.0's map came out ~3 % small
            with them (docs/results/frontend.md, "Floor tracks").
        wheel_odometry: it always steps on the dataset's own odometry, even where the front
            end's log carries laser odometry that replaces it for the others (dead reckoning:
            the baseline the SLAM estimators are compared with).
    """

    target: str
    modalities: frozenset[Modality]
    check: str = ""
    summary: str = ""
    config: str = ""
    preset: str = ""
    floor_tracks: bool = False
    wheel_odometry: bool = False


_SLAM_2D_3D = frozenset({Modality.RANGE_BEARING_2D, Modality.BEARINGS_3D})
_GRAPH = frozenset(Modality)

#: estimator name -> where its factory lives and what it consumes
ESTIMATORS: dict[str, EstimatorEntry] = {
    "deadreckoning": EstimatorEntry(
        "omnislam.deadreckoning:make_estimator",
        frozenset(),
        "omnislam.deadreckoning:check_options",
        summary="the odometry composed, sightings ignored: the baseline every SLAM back end "
        "must beat",
        wheel_odometry=True,
    ),
    "graphslam": EstimatorEntry(
        "omnislam.graphslam:make_estimator",
        _GRAPH,
        "omnislam.graphslam.factory:check_options",
        summary="factor graph solved incrementally by GTSAM's iSAM2 at every frame",
        config="omnislam.graphslam.config:PRESETS",
        preset="default",
        floor_tracks=True,
    ),
    "graphslam-batch": EstimatorEntry(
        "omnislam.graphslam:make_batch_estimator",
        _GRAPH,
        "omnislam.graphslam.factory:check_options",
        summary="iSAM2, then batch Levenberg-Marquardt on the whole graph warm-started from it",
        config="omnislam.graphslam.config:PRESETS",
        preset="default",
        floor_tracks=True,
    ),
    "fastslam1": EstimatorEntry(
        "omnislam.fastslam:make_fastslam1",
        _SLAM_2D_3D,
        "omnislam.fastslam.factory:check_fastslam1_options",
        summary="FastSLAM 1.0: particles drawn from the motion model, one EKF per landmark "
        "(thesis sec. 4.4)",
        config="omnislam.fastslam.config:PRESETS",
        preset="fastslam1",
    ),
    "fastslam2": EstimatorEntry(
        "omnislam.fastslam:make_fastslam2",
        _SLAM_2D_3D,
        "omnislam.fastslam.factory:check_fastslam2_options",
        summary="FastSLAM 2.0: the proposal refined by the matched sightings (Montemerlo 2003)",
        config="omnislam.fastslam.config:PRESETS",
        preset="fastslam2",
    ),
    "ukf": EstimatorEntry(
        "omnislam.ukf:make_estimator",
        frozenset({Modality.VERTICAL_LINES, Modality.RANGE_BEARING_2D}),
        "omnislam.ukf.factory:check_options",
        summary="UKF localiser on vertical-line bearings in a known map (Barra & Costa)",
        config="omnislam.ukf.config:UKFConfig",
    ),
    "ekfslam": EstimatorEntry(
        "omnislam.ekfslam:make_estimator",
        _SLAM_2D_3D,
        "omnislam.ekfslam.factory:check_options",
        summary="EKF-SLAM on range-bearing sightings or omni bearings (delayed triangulation), "
        "one joint Gaussian (SLAM for Dummies)",
        config="omnislam.ekfslam.config:EKFSLAMConfig",
    ),
}


def unknown_estimator_message(name: str) -> str:
    """The one line for an estimator name the registry does not hold, with the nearest names."""
    hint = did_you_mean(name, ESTIMATORS, count=2)
    return f"unknown estimator {name!r}{hint}; known: {', '.join(ESTIMATORS)}"


def estimator_factory(name: str) -> EstimatorFactory:
    """The factory registered under ``name``.

    Raises:
        ConfigError: unknown name (listing the known ones) or a back end not available yet.
    """
    if name not in ESTIMATORS:
        raise ConfigError(unknown_estimator_message(name))
    target = ESTIMATORS[name].target
    module_name, attribute = target.split(":")
    module = importlib.import_module(module_name)
    factory = getattr(module, attribute, None)
    if factory is None:
        raise ConfigError(f"estimator {name!r} is not available yet ({target})")
    return factory


def estimator_defaults(name: str) -> tuple[object | None, tuple[str, ...]]:
    """(default configuration dataclass of estimator ``name`` or None, its preset names).

    Imports only the configuration module (not the back end: gtsam is not needed to list
    graphslam's options).

    Raises:
        ConfigError: unknown estimator.
    """
    if name not in ESTIMATORS:
        raise ConfigError(unknown_estimator_message(name))
    entry = ESTIMATORS[name]
    if not entry.config:
        return None, ()
    module_name, attribute = entry.config.split(":")
    target = getattr(importlib.import_module(module_name), attribute)
    if isinstance(target, Mapping):
        return target[entry.preset], tuple(target)
    return target(), ()


def check_estimator_options(name: str, options: Mapping[str, str]) -> None:
    """Validate the ``--set`` options meant for estimator ``name`` without building it.

    The modality option is checked by name; the rest against the estimator's configuration
    dataclass (``omnislam.options.apply_options``), so a grid fails on a bad value before any
    cell runs rather than when that cell's turn comes.

    Raises:
        ConfigError: unknown estimator, option or value.
    """
    estimator_factory(name)
    text = options.get(MODALITY_OPTION)
    if text is not None:
        if not ESTIMATORS[name].modalities:
            raise ConfigError(f"{name} uses no sightings; {MODALITY_OPTION} does not apply")
        Modality.parse(text)
    check = ESTIMATORS[name].check
    if check:
        module_name, attribute = check.split(":")
        getattr(importlib.import_module(module_name), attribute)(
            {k: v for k, v in options.items() if k != MODALITY_OPTION}
        )


def resolve_estimator_modality(
    name: str, info: SequenceInfo, options: Mapping[str, str]
) -> Modality | None:
    """The stream estimator ``name`` consumes on this sequence (None: it uses no sightings).

    ``options[MODALITY_OPTION]`` (``--set modality=NAME``) overrides the shared rule.

    Raises:
        ConfigError: unknown estimator or modality name, or no usable stream (the message
            names the data's modalities and the estimator's).
    """
    if name not in ESTIMATORS:
        raise ConfigError(unknown_estimator_message(name))
    accepted = ESTIMATORS[name].modalities
    text = options.get(MODALITY_OPTION)
    override = None if text is None else Modality.parse(text)
    if not accepted:
        if override is not None:
            raise ConfigError(f"{name} uses no sightings; {MODALITY_OPTION} does not apply")
        return None
    return resolve_modality(info.modalities, accepted, override, estimator=name, dataset=info.name)


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

    Raises:
        ConfigError: unknown estimator or option, or no modality the estimator can use.
    """
    factory = estimator_factory(name)
    modality = resolve_estimator_modality(name, info, options)
    rest = {k: v for k, v in options.items() if k != MODALITY_OPTION}
    return factory(replace(info, modality=modality), rest, rng)
