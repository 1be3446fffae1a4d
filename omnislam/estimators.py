"""Estimator registry: a name on the command line -> a lazily imported factory.

Every back end exposes one factory with the signature of ``EstimatorFactory``; ``omnislam run``
and the comparison runner build estimators only through ``make_estimator``, so a back end plugs
in by declaring one ``EstimatorEntry``: where its factory lives and which modalities
(``core.modality``) it consumes. ``make_estimator`` resolves the modality once, by the shared
rule, and hands it to the factory in ``SequenceInfo.modality``. Factories raise ConfigError for
options they do not know, so a typo on ``--set`` never passes silently.

One function builds the registry, ``load_registry``: omnislam's own estimators
(``BUILTIN_ESTIMATORS``), then those of every installed package that declares entry points in
the group ``omnislam.estimators`` (``ENTRY_POINT_GROUP``). An entry point's object is either

* an ``EstimatorEntry``, registered under the entry point's name::

      [project.entry-points."omnislam.estimators"]
      ekf-localiser = "ekf_localiser.plugin:ENTRY"

* or a callable taking no argument that returns a mapping ``name -> EstimatorEntry`` (a package
  with several estimators; the entry point's name then only labels the declaration).

A plugin is then listed by ``omnislam estimators``, run by ``omnislam run``, checked and run in
grids, scored and drawn in reports exactly like a built-in estimator. A declaration that cannot
be used -- its module fails to import, it is not an ``EstimatorEntry``, a field is malformed,
its name is taken or reserved -- is left out with one line on stderr naming it (once per
process tree, ``PluginProblem``), and every other estimator still works. ``ESTIMATORS`` (a
module attribute computed on first use) is the registry of this process.
"""

from __future__ import annotations

import enum
import importlib
import os
import re
import sys
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, replace
from functools import cache
from importlib.metadata import EntryPoint

import numpy as np

from omnislam.core.modality import MODALITY_OPTION, Modality, resolve_modality
from omnislam.core.sequence_info import SequenceInfo
from omnislam.core.types import Estimator
from omnislam.errors import ConfigError, OmnislamError, did_you_mean

#: factory(info, options, rng) -> Estimator
EstimatorFactory = Callable[[SequenceInfo, Mapping[str, str], np.random.Generator], Estimator]


class Family(enum.Enum):
    """The method family of an estimator: a verdict names the best of each family and the margin
    between families rather than ranking every variant of one method against the others."""

    FACTOR_GRAPH = "factor graph"
    PARTICLE_FILTER = "particle filter"
    KALMAN_FILTER = "Kalman filter"
    LOCALISER = "localiser in a known map"
    DEAD_RECKONING = "dead reckoning"
    #: results read from another system's files (a grid's ``estimator: external``)
    EXTERNAL = "another system"


@dataclass(frozen=True, slots=True)
class EstimatorEntry:
    """One registered estimator: what a built-in or a plugin declares.

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
        stochastic: it draws from the run's random generator (particle filters), so its result
            depends on the seed; a deterministic one (default False) gives the same trajectory
            for every seed on the same input, and a grid runs it once per dataset on data on
            disk (``harness.grid``).
        family: its method family (``Family``), by which a verdict groups the estimators
            (default ``Family.KALMAN_FILTER``).
    """

    target: str
    modalities: frozenset[Modality]
    check: str = ""
    summary: str = ""
    config: str = ""
    preset: str = ""
    floor_tracks: bool = False
    wheel_odometry: bool = False
    stochastic: bool = False
    family: Family = Family.KALMAN_FILTER


_SLAM_2D_3D = frozenset({Modality.RANGE_BEARING_2D, Modality.BEARINGS_3D})
_GRAPH = frozenset(Modality)

#: the entry-point group installed packages declare their estimators in
ENTRY_POINT_GROUP = "omnislam.estimators"
#: an estimator name: it names cell folders and ``--estimator`` arguments
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.+-]*")
#: names no estimator may take: a grid cell ``estimator: external`` reads results from files
RESERVED_NAMES = frozenset({"external"})
#: environment variable holding the plugins already reported, so that the processes a command
#: starts (the grid's workers) do not repeat its lines
_REPORTED_VARIABLE = "OMNISLAM_REPORTED_PLUGINS"

#: omnislam's own estimators: name -> where its factory lives and what it consumes
BUILTIN_ESTIMATORS: dict[str, EstimatorEntry] = {
    "deadreckoning": EstimatorEntry(
        "omnislam.deadreckoning:make_estimator",
        frozenset(),
        "omnislam.deadreckoning:check_options",
        summary="the odometry composed, sightings ignored: the baseline every SLAM back end "
        "must beat",
        wheel_odometry=True,
        family=Family.DEAD_RECKONING,
    ),
    "graphslam": EstimatorEntry(
        "omnislam.graphslam:make_estimator",
        _GRAPH,
        "omnislam.graphslam.factory:check_options",
        summary="factor graph solved incrementally by GTSAM's iSAM2 at every frame",
        config="omnislam.graphslam.config:PRESETS",
        preset="default",
        floor_tracks=True,
        family=Family.FACTOR_GRAPH,
    ),
    "graphslam-batch": EstimatorEntry(
        "omnislam.graphslam:make_batch_estimator",
        _GRAPH,
        "omnislam.graphslam.factory:check_options",
        summary="iSAM2, then batch Levenberg-Marquardt on the whole graph warm-started from it",
        config="omnislam.graphslam.config:PRESETS",
        preset="default",
        floor_tracks=True,
        family=Family.FACTOR_GRAPH,
    ),
    "fastslam1": EstimatorEntry(
        "omnislam.fastslam:make_fastslam1",
        _SLAM_2D_3D,
        "omnislam.fastslam.factory:check_fastslam1_options",
        summary="FastSLAM 1.0: particles drawn from the motion model, one EKF per landmark "
        "(thesis sec. 4.4)",
        config="omnislam.fastslam.config:PRESETS",
        preset="fastslam1",
        stochastic=True,
        family=Family.PARTICLE_FILTER,
    ),
    "fastslam2": EstimatorEntry(
        "omnislam.fastslam:make_fastslam2",
        _SLAM_2D_3D,
        "omnislam.fastslam.factory:check_fastslam2_options",
        summary="FastSLAM 2.0: the proposal refined by the matched sightings (Montemerlo 2003)",
        config="omnislam.fastslam.config:PRESETS",
        preset="fastslam2",
        stochastic=True,
        family=Family.PARTICLE_FILTER,
    ),
    "ukf": EstimatorEntry(
        "omnislam.ukf:make_estimator",
        frozenset({Modality.VERTICAL_LINES, Modality.RANGE_BEARING_2D}),
        "omnislam.ukf.factory:check_options",
        summary="UKF localiser on vertical-line bearings in a known map (Barra & Costa)",
        config="omnislam.ukf.config:UKFConfig",
        family=Family.LOCALISER,
    ),
    "ekfslam": EstimatorEntry(
        "omnislam.ekfslam:make_estimator",
        _SLAM_2D_3D,
        "omnislam.ekfslam.factory:check_options",
        summary="EKF-SLAM on range-bearing sightings or omni bearings (delayed triangulation), "
        "one joint Gaussian (SLAM for Dummies)",
        config="omnislam.ekfslam.config:EKFSLAMConfig",
        family=Family.KALMAN_FILTER,
    ),
}


@dataclass(frozen=True, slots=True)
class PluginProblem:
    """A plugin declaration left out of the registry.

    Attributes:
        declaration: which one, ``entry point NAME (DISTRIBUTION)``.
        reason: why, one line.
    """

    declaration: str
    reason: str

    def line(self) -> str:
        """The line on stderr."""
        return f"omnislam: estimator plugin {self.declaration} skipped: {self.reason}"


@dataclass(frozen=True, slots=True)
class Registry:
    """The estimators of this installation (``load_registry``).

    Attributes:
        entries: name -> entry, the built-ins first, then the plugins in entry-point order.
        origins: name -> where it comes from: "omnislam", or the plugin's distribution.
        problems: the declarations left out, each with its reason.
    """

    entries: dict[str, EstimatorEntry]
    origins: dict[str, str]
    problems: tuple[PluginProblem, ...] = ()


def _declared_by(point: EntryPoint) -> str:
    """``entry point NAME (DISTRIBUTION VERSION)``, naming a declaration in messages."""
    dist = point.dist
    where = "" if dist is None else f" ({dist.metadata['Name']} {dist.version})"
    return f"entry point {point.name!r}{where}"


def _target_problem(field_name: str, value: object, required: bool) -> str | None:
    """Why ``value`` is not a ``"module:attribute"`` string (None when it is, or may be "")."""
    if not isinstance(value, str):
        return f"{field_name} must be a 'module:attribute' string, got {value!r}"
    if not value and not required:
        return None
    module, _, attribute = value.partition(":")
    if not module or not attribute.isidentifier() or not all(
        part.isidentifier() for part in module.split(".")
    ):
        return f"{field_name} must be 'module:attribute', got {value!r}"
    return None


def entry_problem(name: object, entry: object) -> str | None:
    """Why a declared (name, entry) cannot be registered (None when it can).

    Checks the name (text, ``[A-Za-z0-9][A-Za-z0-9_.+-]*``, not reserved) and the entry's
    fields: the ``"module:attribute"`` strings, the modalities (a frozenset of ``Modality``),
    a preset only with a configuration; nothing is imported.
    """
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        return f"estimator name {name!r} is not a name ([A-Za-z0-9][A-Za-z0-9_.+-]*)"
    if name in RESERVED_NAMES:
        return f"estimator name {name!r} is reserved"
    if not isinstance(entry, EstimatorEntry):
        return f"{name!r} declares a {type(entry).__name__}, not an omnislam EstimatorEntry"
    for field_name, required in (("target", True), ("check", False), ("config", False)):
        problem = _target_problem(field_name, getattr(entry, field_name), required)
        if problem is not None:
            return f"{name!r}: {problem}"
    if not isinstance(entry.modalities, frozenset) or not all(
        isinstance(m, Modality) for m in entry.modalities
    ):
        return f"{name!r}: modalities must be a frozenset of omnislam Modality values"
    if not isinstance(entry.summary, str) or not isinstance(entry.preset, str):
        return f"{name!r}: summary and preset must be text"
    if entry.preset and not entry.config:
        return f"{name!r}: a preset needs a config mapping of presets"
    return None


def _declared(point: EntryPoint) -> Mapping[object, object]:
    """What one entry point declares: name -> entry (not yet checked).

    Raises:
        ConfigError: a declaration of another kind.
        Exception: whatever importing the plugin raises.
    """
    declared = point.load()
    if isinstance(declared, EstimatorEntry):
        return {point.name: declared}
    if callable(declared):
        declared = declared()
        if isinstance(declared, Mapping):
            return declared
    raise ConfigError(
        f"declares a {type(declared).__name__}; expected an EstimatorEntry or a callable "
        "returning a mapping of name -> EstimatorEntry"
    )


def load_registry(points: Iterable[EntryPoint] = ()) -> Registry:
    """The built-in estimators and those the entry points ``points`` declare.

    Args:
        points: entry points of the group ``ENTRY_POINT_GROUP`` (``registry()`` passes the
            installed ones).

    Returns:
        The registry; a declaration that cannot be used is a ``PluginProblem`` instead (its
        import failing, any exception, included), the others are registered.
    """
    entries = dict(BUILTIN_ESTIMATORS)
    origins = dict.fromkeys(BUILTIN_ESTIMATORS, "omnislam")
    problems = []
    for point in points:
        where = _declared_by(point)
        try:
            declared = _declared(point)
        except Exception as exc:  # a broken plugin must not take the others down
            reason = str(exc) if isinstance(exc, ConfigError) else f"{type(exc).__name__}: {exc}"
            problems.append(PluginProblem(where, " ".join(reason.split())))
            continue
        for name, entry in declared.items():
            problem = entry_problem(name, entry)
            if problem is None and name in entries:
                problem = f"estimator name {name!r} is taken (by {origins[name]})"
            if problem is not None:
                problems.append(PluginProblem(where, problem))
                continue
            entries[name] = entry  # type: ignore[index,assignment]
            origins[name] = where if point.dist is None else point.dist.metadata["Name"]
    return Registry(entries, origins, tuple(problems))


def report_problems(problems: Iterable[PluginProblem]) -> None:
    """One line on stderr per problem not yet reported by this process or the one that started
    it (the ``OMNISLAM_REPORTED_PLUGINS`` environment variable, inherited by workers)."""
    reported = set(filter(None, os.environ.get(_REPORTED_VARIABLE, "").split("\n")))
    for problem in problems:
        if problem.line() not in reported:
            print(problem.line(), file=sys.stderr, flush=True)
            reported.add(problem.line())
    os.environ[_REPORTED_VARIABLE] = "\n".join(sorted(reported))


@cache
def registry() -> Registry:
    """The registry of this process: built-ins and installed plugins, read once; the plugins
    left out are reported on stderr (``report_problems``)."""
    from importlib.metadata import entry_points

    loaded = load_registry(entry_points(group=ENTRY_POINT_GROUP))
    report_problems(loaded.problems)
    return loaded


def __getattr__(name: str) -> object:
    """``ESTIMATORS``: name -> EstimatorEntry of every registered estimator, built on first use
    (``registry``)."""
    if name == "ESTIMATORS":
        return registry().entries
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def estimator_origin(name: str) -> str:
    """Where estimator ``name`` comes from: "omnislam" or its plugin's distribution."""
    return registry().origins.get(name, "")


def _entries() -> dict[str, EstimatorEntry]:
    return registry().entries


def unknown_estimator_message(name: str) -> str:
    """The one line for an estimator name the registry does not hold, with the nearest names."""
    names = list(_entries())
    return f"unknown estimator {name!r}{did_you_mean(name, names, count=2)}; known: " + ", ".join(
        names
    )


def _attribute(name: str, target: str) -> object | None:
    """The object ``"module:attribute"`` names (None when the module lacks it).

    A plugin's module that fails to import is the plugin's fault, not the run's: any exception
    becomes one ConfigError naming the estimator and its distribution. A built-in's import
    errors (a missing extra) pass as they are.

    Raises:
        ConfigError: a plugin's module that cannot be imported.
    """
    module_name, attribute = target.split(":")
    origin = estimator_origin(name)
    if origin == "omnislam":
        return getattr(importlib.import_module(module_name), attribute, None)
    try:
        module = importlib.import_module(module_name)
    except OmnislamError:
        raise
    except Exception as exc:  # the plugin's own code: one line, not a traceback
        reason = " ".join(f"{type(exc).__name__}: {exc}".split())
        raise ConfigError(
            f"estimator {name!r} (plugin {origin}): cannot import {module_name}: {reason}"
        ) from None
    return getattr(module, attribute, None)


def estimator_factory(name: str) -> EstimatorFactory:
    """The factory registered under ``name``.

    Raises:
        ConfigError: unknown name (listing the known ones), a back end not available yet, or a
            plugin whose module cannot be imported.
    """
    if name not in _entries():
        raise ConfigError(unknown_estimator_message(name))
    target = _entries()[name].target
    factory = _attribute(name, target)
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
    if name not in _entries():
        raise ConfigError(unknown_estimator_message(name))
    entry = _entries()[name]
    if not entry.config:
        return None, ()
    target = _attribute(name, entry.config)
    if target is None:
        raise ConfigError(f"estimator {name!r}: no configuration {entry.config}")
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
        if not _entries()[name].modalities:
            raise ConfigError(f"{name} uses no sightings; {MODALITY_OPTION} does not apply")
        Modality.parse(text)
    check = _entries()[name].check
    if check:
        function = _attribute(name, check)
        if not callable(function):
            raise ConfigError(f"estimator {name!r}: no option check {check}")
        function({k: v for k, v in options.items() if k != MODALITY_OPTION})


def resolve_estimator_modality(
    name: str, info: SequenceInfo, options: Mapping[str, str]
) -> Modality | None:
    """The stream estimator ``name`` consumes on this sequence (None: it uses no sightings).

    ``options[MODALITY_OPTION]`` (``--set modality=NAME``) overrides the shared rule.

    Raises:
        ConfigError: unknown estimator or modality name, or no usable stream (the message
            names the data's modalities and the estimator's).
    """
    if name not in _entries():
        raise ConfigError(unknown_estimator_message(name))
    accepted = _entries()[name].modalities
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
