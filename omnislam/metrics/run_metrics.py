"""The metrics of one run: a frozen record, and ``metrics.json`` as its ``read_``/``write_`` pair.

``harness.evaluation.evaluate_run`` computes a RunMetrics; metrics.json, results.csv, the report's
tables, ``omnislam evaluate``, ``omnislam compare``, ``omnislam demo`` and the benchmarks read
its fields. Each metric is spelled once: a field of one of the parts below, whose ``metric(...)``
declares its metrics.json key when the key is not the field's own name. Whatever needs the keys
(the file, results.csv's columns) iterates ``METRIC_FIELDS``, which is derived from these
declarations.

metrics.json is one flat JSON object: ``schema_version`` first, then every field's key in the
order declared here (parts in the order of RunMetrics). A metric that cannot be computed (no
ground truth, no covariances, no landmarks) is null; every number is finite and >= 0. Version 1
is the first to write ``schema_version``; files written before carry exactly its keys without
it and are read as version 1. Version 2 adds the median pose NEES and the warm-up
(``ADDED_IN_2``); a version 1 file is read with those null. ``read_run_metrics`` checks every
key once, so a malformed file fails there with a DataError naming the file and the key, never
later in a report.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import json
import math
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from omnislam._files import atomic_write_text
from omnislam.datasets.sequence import GroundTruthKind
from omnislam.errors import DataError
from omnislam.metrics.landmarks import LandmarkAssociation
from omnislam.metrics.trajectory import Alignment

#: version of the metrics.json layout this module writes (and the only one it reads)
SCHEMA_VERSION = 2
#: the versions this module reads
READABLE_VERSIONS = (1, 2)
#: keys version 2 added: null when a version 1 file is read
ADDED_IN_2 = frozenset({"nees_median", "warmup_s", "warmup_steps"})
#: the key of the version in metrics.json
SCHEMA_KEY = "schema_version"


def metric(key: str | None = None, *, csv: bool = False, measured: bool = False) -> Mapping:
    """The metadata that declares a field a metric: ``field(metadata=metric("KEY"))``.

    A field without it is a metric keyed by its own name, in no results.csv column.

    Args:
        key: its metrics.json key (None: the field's name).
        csv: a column of results.csv (columns in declaration order).
        measured: wall time or memory: it differs between two runs of the same cell, while
            every other metric is a function of the data, the estimator, its options and seed.

    Returns:
        The ``dataclasses.field`` metadata.
    """
    return types.MappingProxyType({"key": key, "csv": csv, "measured": measured})


@dataclass(frozen=True, slots=True, kw_only=True)
class RunInfo:
    """What ran: the labels of the run the metrics belong to.

    Attributes:
        dataset: the DATASET argument (registered name or path).
        estimator: estimator name.
        seed: the run's seed (None when not given).
        estimator_options: options passed to the estimator.
        dataset_options: options passed to the dataset's loader.
    """

    dataset: str
    estimator: str
    seed: int | None
    estimator_options: Mapping[str, str]
    dataset_options: Mapping[str, str]

    def __post_init__(self) -> None:
        _validate(self)


@dataclass(frozen=True, slots=True, kw_only=True)
class AteMetrics:
    """Absolute trajectory error (Sturm et al. 2012); all None without a ground-truth trajectory.

    Attributes:
        rmse_m, max_m, mean_m, median_m: position errors after SE(2) alignment [m].
        origin_rmse_m, origin_max_m: the same with only the first pose anchored (drift) [m].
        matched: estimate poses associated with a ground-truth pose.
        coverage: matched / estimate poses (GPS gaps lower it) [0, 1].
    """

    rmse_m: float | None = field(default=None, metadata=metric("ate_rmse_m", csv=True))
    max_m: float | None = field(default=None, metadata=metric("ate_max_m", csv=True))
    mean_m: float | None = field(default=None, metadata=metric("ate_mean_m"))
    median_m: float | None = field(default=None, metadata=metric("ate_median_m"))
    origin_rmse_m: float | None = field(
        default=None, metadata=metric("ate_origin_rmse_m", csv=True)
    )
    origin_max_m: float | None = field(default=None, metadata=metric("ate_origin_max_m"))
    matched: int | None = field(default=None, metadata=metric("ate_matched"))
    coverage: float | None = field(default=None, metadata=metric("ate_coverage"))

    def __post_init__(self) -> None:
        _validate(self)


@dataclass(frozen=True, slots=True, kw_only=True)
class RpeSegment:
    """One point of the RPE error-over-distance curve.

    Attributes:
        length_m: segment length of ground-truth travel [m].
        trans_rmse_m: translation RMSE over the segments [m].
        rot_rmse_deg: rotation RMSE over the segments [deg] (None: no orientation truth).
        pairs: number of segments (pose pairs).
    """

    length_m: float
    trans_rmse_m: float | None
    rot_rmse_deg: float | None
    pairs: int

    def __post_init__(self) -> None:
        _validate(self)


@dataclass(frozen=True, slots=True, kw_only=True)
class RpeMetrics:
    """Relative pose error (evo's pair rule); all None without a ground-truth trajectory.

    Attributes:
        segment_m: segment length of ``trans_rmse_m`` / ``rot_rmse_deg`` [m].
        trans_rmse_m: translation RMSE over segments of ``segment_m`` of travel [m].
        rot_rmse_deg: rotation RMSE over those segments [deg].
        pairs: number of those segments.
        planar: SE(2) errors (planar run) rather than SE(3).
        frame_trans_rmse_m, frame_rot_rmse_deg: the same between consecutive frames.
        travel_m: ground-truth distance travelled over the associated poses [m].
        by_distance: the error-over-distance curve (KITTI-like segment lengths).
    """

    segment_m: float | None = field(default=None, metadata=metric("rpe_segment_m"))
    trans_rmse_m: float | None = field(default=None, metadata=metric("rpe_trans_rmse_m", csv=True))
    rot_rmse_deg: float | None = field(default=None, metadata=metric("rpe_rot_rmse_deg", csv=True))
    pairs: int | None = field(default=None, metadata=metric("rpe_pairs"))
    planar: bool | None = field(default=None, metadata=metric("rpe_planar"))
    frame_trans_rmse_m: float | None = field(
        default=None, metadata=metric("rpe_frame_trans_rmse_m")
    )
    frame_rot_rmse_deg: float | None = field(
        default=None, metadata=metric("rpe_frame_rot_rmse_deg")
    )
    travel_m: float | None = field(default=None)
    by_distance: tuple[RpeSegment, ...] | None = field(
        default=None, metadata=metric("rpe_by_distance")
    )

    def __post_init__(self) -> None:
        _validate(self)


@dataclass(frozen=True, slots=True, kw_only=True)
class LandmarkMetrics:
    """Landmark map error after the trajectory's alignment (None where not computable).

    Attributes:
        rmse_m, median_m, max_m: position errors of the matched landmarks [m].
        estimated: landmarks in the estimate.
        matched: estimated landmarks matched to a true one.
        truth: true landmarks (None: the data has no landmark truth).
        missed: true landmarks nothing was matched to.
        duplicates: further estimated landmarks of an already matched true one.
        spurious: estimated landmarks matching no true one.
        association: how estimated and true landmarks were matched.
        gate_m: the association gate (None when matched by id) [m].
    """

    rmse_m: float | None = field(default=None, metadata=metric("landmark_rmse_m", csv=True))
    median_m: float | None = field(default=None, metadata=metric("landmark_median_m"))
    max_m: float | None = field(default=None, metadata=metric("landmark_max_m"))
    estimated: int = field(metadata=metric("landmarks_estimated", csv=True))
    matched: int | None = field(default=None, metadata=metric("landmarks_matched", csv=True))
    truth: int | None = field(default=None, metadata=metric("landmarks_truth"))
    missed: int | None = field(default=None, metadata=metric("landmarks_missed"))
    duplicates: int | None = field(default=None, metadata=metric("landmark_duplicates"))
    spurious: int | None = field(default=None, metadata=metric("landmark_spurious"))
    association: LandmarkAssociation | None = field(
        default=None, metadata=metric("landmark_association")
    )
    gate_m: float | None = field(default=None, metadata=metric("landmark_gate_m"))

    def __post_init__(self) -> None:
        _validate(self)


@dataclass(frozen=True, slots=True, kw_only=True)
class ConsistencyMetrics:
    """NEES of poses and landmarks against the estimator's covariances (Bar-Shalom 2001, 5.4.2).

    None where the estimator gives no covariances (or there is no ground truth).

    Attributes:
        has_pose_covariances: the estimate carries a covariance per pose.
        pose_mean: mean pose NEES (its dof when consistent).
        pose_median: median pose NEES over the poses (robust to the few poses whose covariance
            collapses, which dominate the mean).
        pose_anees: average NEES per degree of freedom.
        pose_dof: degrees of freedom of the pose error.
        pose_within_bounds: fraction of the poses' NEES inside the two-sided chi-square
            interval (``metrics.consistency.NEES_CONFIDENCE``) [0, 1].
        pose_count: poses with a usable covariance (the NEES is computed over them).
        has_landmark_covariances: the estimate carries a covariance per landmark.
        landmark_mean, landmark_anees, landmark_dof, landmark_count: the same for the matched
            landmarks.
    """

    has_pose_covariances: bool
    pose_mean: float | None = field(default=None, metadata=metric("nees_mean", csv=True))
    pose_median: float | None = field(default=None, metadata=metric("nees_median", csv=True))
    pose_anees: float | None = field(default=None, metadata=metric("anees"))
    pose_dof: int | None = field(default=None, metadata=metric("nees_dof"))
    pose_within_bounds: float | None = field(default=None, metadata=metric("nees_within_bounds"))
    pose_count: int | None = field(default=None, metadata=metric("nees_count"))
    has_landmark_covariances: bool
    landmark_mean: float | None = field(default=None, metadata=metric("landmark_nees_mean"))
    landmark_anees: float | None = field(default=None, metadata=metric("landmark_anees"))
    landmark_dof: int | None = field(default=None, metadata=metric("landmark_nees_dof"))
    landmark_count: int | None = field(default=None, metadata=metric("landmark_nees_count"))

    def __post_init__(self) -> None:
        _validate(self)


@dataclass(frozen=True, slots=True, kw_only=True)
class TimingMetrics:
    """Cost of the run: per-step wall time, total, memory (None: no steps).

    Attributes:
        frames: frames processed (one estimator step each).
        step_median_ms, step_p95_ms, step_mean_ms, step_max_ms: wall time per step after the
            warm-up [ms] (``metrics.timing``).
        total_s: wall time of all estimator steps, the warm-up included [s]; None for results
            read from another system's files (not run here).
        warmup_s: wall time of the warm-up steps (compilation, first frame) [s].
        warmup_steps: how many leading steps the warm-up is.
        peak_rss_mb: peak resident memory of the process [MB]; None for results not run here.
    """

    frames: int = field(metadata=metric(csv=True))
    step_median_ms: float | None = field(metadata=metric("step_ms_median", csv=True, measured=True))
    step_p95_ms: float | None = field(metadata=metric("step_ms_p95", csv=True, measured=True))
    step_mean_ms: float | None = field(metadata=metric("step_ms_mean", measured=True))
    step_max_ms: float | None = field(metadata=metric("step_ms_max", measured=True))
    total_s: float | None = field(metadata=metric(csv=True, measured=True))
    peak_rss_mb: float | None = field(metadata=metric(csv=True, measured=True))
    warmup_s: float | None = field(default=None, metadata=metric(csv=True, measured=True))
    warmup_steps: int | None = field(default=None, metadata=metric(measured=True))

    def __post_init__(self) -> None:
        _validate(self)


@dataclass(frozen=True, slots=True, kw_only=True)
class GroundTruthInfo:
    """What the numbers are measured against (reports print it next to every number).

    Attributes:
        alignment: the alignment of the ATE (None without a ground-truth trajectory).
        kind: where the ground truth comes from.
        label: how reports name that kind.
        note: the ground truth's own note (source, caveats).
        reference: name of the reference solution when ``kind`` is REFERENCE (e.g.
            "lm-optimum", ``harness.reference``); None for recorded ground truth.
    """

    alignment: Alignment | None = field(default=None, metadata=metric(csv=True))
    kind: GroundTruthKind = field(metadata=metric("ground_truth", csv=True))
    label: str = field(metadata=metric("ground_truth_label"))
    note: str = field(metadata=metric("ground_truth_note"))
    reference: str | None = field(default=None)

    def __post_init__(self) -> None:
        _validate(self)


@dataclass(frozen=True, slots=True, kw_only=True)
class RunMetrics:
    """Every metric of one run against the ground truth stored with it (``metrics.json``).

    Attributes:
        run: what ran.
        ate: absolute trajectory error.
        rpe: relative pose error.
        landmarks: landmark map error.
        nees: consistency of the estimator's covariances.
        timing: wall time and memory.
        ground_truth: what the numbers are measured against.
    """

    run: RunInfo
    ate: AteMetrics
    rpe: RpeMetrics
    landmarks: LandmarkMetrics
    nees: ConsistencyMetrics
    timing: TimingMetrics
    ground_truth: GroundTruthInfo

    def __post_init__(self) -> None:
        _validate(self)

    def to_json(self) -> dict[str, object]:
        """The metrics.json object: ``schema_version``, then every metric's key (null: None)."""
        out: dict[str, object] = {SCHEMA_KEY: SCHEMA_VERSION}
        for spec in METRIC_FIELDS:
            out[spec.key] = spec.json_value(self)
        return out

    @classmethod
    def from_json(cls, raw: object) -> RunMetrics:
        """Validate a parsed metrics.json object (see the module docstring for the versions).

        Raises:
            DataError: not an object, unsupported ``schema_version``, a key missing or unknown,
                or a value of the wrong type or range (naming the key).
        """
        if not isinstance(raw, Mapping):
            raise DataError(f"expected a JSON object, got {_show(raw)}")
        version = raw.get(SCHEMA_KEY, 1)  # absent: written before version 1
        if type(version) is not int or version not in READABLE_VERSIONS:
            raise DataError(
                f"key {SCHEMA_KEY!r}: this omnislam reads versions "
                f"{', '.join(map(str, READABLE_VERSIONS))}, got {_show(version)}"
            )
        if version == 1:
            raw = {**raw, **{key: None for key in ADDED_IN_2 if key not in raw}}
        return _from_json_object(cls, raw, frozenset({SCHEMA_KEY}))


@dataclass(frozen=True, slots=True)
class MetricField:
    """One metric of RunMetrics: where it lives and its metrics.json key.

    Attributes:
        key: the metrics.json key (also the results.csv column).
        part: attribute of RunMetrics holding it (``"ate"``).
        name: attribute of that part (``"rmse_m"``).
        csv: a column of results.csv.
        measured: wall time or memory (differs between two runs of the same cell).
    """

    key: str
    part: str
    name: str
    csv: bool
    measured: bool

    def value(self, metrics: RunMetrics) -> object:
        """The metric's value in ``metrics`` (enums as enums, None when missing)."""
        return getattr(getattr(metrics, self.part), self.name)

    def json_value(self, metrics: RunMetrics) -> object:
        """The metric's value as metrics.json holds it (enums as their values, None as null)."""
        return _to_json(self.value(metrics))


# --------------------------------------------------------------------------------------------
# Validation (once, in every part's __post_init__)
# --------------------------------------------------------------------------------------------


class _InvalidError(Exception):
    """A value does not fit its field's type (turned into a DataError naming the key)."""


def _key(spec: dataclasses.Field) -> str:
    return spec.metadata.get("key") or spec.name


@functools.cache
def _hints(cls: type) -> dict[str, object]:
    return typing.get_type_hints(cls)


def _show(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _describe(hint: object) -> str:
    if hint is float:
        return "a finite number >= 0"
    if hint is int:
        return "an integer >= 0"
    if hint is bool:
        return "true or false"
    if hint is str:
        return "a string"
    if isinstance(hint, type) and issubclass(hint, enum.Enum):
        return "one of " + ", ".join(repr(m.value) for m in hint)
    if typing.get_origin(hint) is Mapping:
        return "an object of strings"
    if typing.get_origin(hint) is tuple:
        return "a list of objects"
    return f"a {getattr(hint, '__name__', hint)}"


def _convert(value: object, hint: object, key: str) -> object:
    """``value`` as the type ``hint`` (numbers normalised to float/int, strings to enums)."""
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
            raise _InvalidError
        number = float(value)
        if not math.isfinite(number) or number < 0:
            raise _InvalidError
        return number
    if hint is int:
        if isinstance(value, bool | np.bool_) or not isinstance(value, int | np.integer):
            raise _InvalidError
        if value < 0:
            raise _InvalidError
        return int(value)
    if hint is bool:
        if not isinstance(value, bool | np.bool_):
            raise _InvalidError
        return bool(value)
    if hint is str:
        if not isinstance(value, str):
            raise _InvalidError
        return value
    if isinstance(hint, type) and issubclass(hint, enum.Enum):
        if isinstance(value, hint):
            return value
        try:
            return hint(value)
        except ValueError:
            raise _InvalidError from None
    if typing.get_origin(hint) is Mapping:
        if not isinstance(value, Mapping) or not all(
            isinstance(k, str) and isinstance(v, str) for k, v in value.items()
        ):
            raise _InvalidError
        return types.MappingProxyType(dict(value))
    if typing.get_origin(hint) is tuple:
        (item_type, _) = typing.get_args(hint)
        if not isinstance(value, list | tuple):
            raise _InvalidError
        items = []
        for i, item in enumerate(value):
            if isinstance(item, Mapping):
                try:
                    item = _from_json_object(item_type, item)
                except DataError as exc:
                    raise DataError(f"{key}[{i}]: {exc}") from None
            elif not isinstance(item, item_type):
                raise _InvalidError
            items.append(item)
        return tuple(items)
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        if not isinstance(value, hint):
            raise _InvalidError
        return value
    raise TypeError(f"{key}: no conversion to {hint}")  # a field type this module lacks


def _coerce(value: object, hint: object, key: str) -> object:
    """Check ``value`` against the field type ``hint`` (``X | None`` accepts None).

    Raises:
        DataError: naming ``key``, the expected type and the value.
    """
    nullable = typing.get_origin(hint) in (typing.Union, types.UnionType)
    if nullable:
        if value is None:
            return None
        (hint,) = [a for a in typing.get_args(hint) if a is not type(None)]
    try:
        return _convert(value, hint, key)
    except _InvalidError:
        expected = _describe(hint) + (" or null" if nullable else "")
        raise DataError(f"key {key!r}: expected {expected}, got {_show(value)}") from None


def _validate(record: object) -> None:
    """Normalise and check every field of a part in place (its ``__post_init__``)."""
    hints = _hints(type(record))
    for spec in dataclasses.fields(record):
        value = _coerce(getattr(record, spec.name), hints[spec.name], _key(spec))
        object.__setattr__(record, spec.name, value)


def _to_json(value: object) -> object:
    if isinstance(value, enum.Enum):
        return value.value
    if isinstance(value, Mapping):
        return dict(value)
    if dataclasses.is_dataclass(value):
        return {_key(s): _to_json(getattr(value, s.name)) for s in dataclasses.fields(value)}
    if isinstance(value, tuple):
        return [_to_json(v) for v in value]
    return value


def _raw_values(
    cls: type, raw: Mapping[str, object], known: set[str], missing: list[str]
) -> dict[str, object]:
    """Field name -> value in ``raw`` of each field of ``cls``; notes the keys used and lacking."""
    out = {}
    for spec in dataclasses.fields(cls):
        key = _key(spec)
        known.add(key)
        if key in raw:
            out[spec.name] = raw[key]
        else:
            missing.append(key)
    return out


def _from_json_object(
    cls: type, raw: Mapping[str, object], extra: frozenset[str] = frozenset()
) -> typing.Any:
    """Build ``cls`` from a flat JSON object (RunMetrics: its parts' keys, all at one level).

    Raises:
        DataError: keys missing or unknown (``extra`` keys are allowed), or a bad value.
    """
    known, missing = set(extra), []
    if cls is RunMetrics:
        hints = _hints(cls)
        values = {
            spec.name: _raw_values(hints[spec.name], raw, known, missing)
            for spec in dataclasses.fields(cls)
        }
    else:
        values = _raw_values(cls, raw, known, missing)
    unknown = sorted(set(raw) - known)
    for problem, keys in (("missing", missing), ("unknown", unknown)):
        if keys:
            plural = "s" if len(keys) > 1 else ""
            raise DataError(f"{problem} key{plural} " + ", ".join(repr(k) for k in keys))
    if cls is RunMetrics:
        return cls(**{name: hints[name](**part) for name, part in values.items()})
    return cls(**values)


def _metric_fields() -> tuple[MetricField, ...]:
    hints = _hints(RunMetrics)
    fields = tuple(
        MetricField(
            _key(spec),
            part.name,
            spec.name,
            bool(spec.metadata.get("csv")),
            bool(spec.metadata.get("measured")),
        )
        for part in dataclasses.fields(RunMetrics)
        for spec in dataclasses.fields(hints[part.name])
    )
    keys = [f.key for f in fields] + [SCHEMA_KEY]
    if len(set(keys)) != len(keys):
        raise RuntimeError(f"metrics.json keys declared twice: {sorted(keys)}")
    return fields


#: every metric of RunMetrics in metrics.json order (derived from the field declarations above)
METRIC_FIELDS: tuple[MetricField, ...] = _metric_fields()
#: the metrics that are columns of results.csv, in column order
CSV_FIELDS: tuple[MetricField, ...] = tuple(f for f in METRIC_FIELDS if f.csv)
#: keys of the metrics that measure wall time or memory: they differ between two runs of the same
#: cell; every other key is a function of the data, the estimator, its options and the seed
MEASURED_KEYS: frozenset[str] = frozenset(f.key for f in METRIC_FIELDS if f.measured)


# --------------------------------------------------------------------------------------------
# metrics.json
# --------------------------------------------------------------------------------------------


def write_run_metrics(path: str | Path, metrics: RunMetrics) -> None:
    """Write ``metrics`` as a metrics.json file, atomically (temporary file, then rename).

    Args:
        path: the file to write (``RUN_DIR/metrics.json``).
        metrics: the metrics; None values become null.
    """
    atomic_write_text(path, json.dumps(metrics.to_json(), indent=2, allow_nan=False) + "\n")


def read_run_metrics(path: str | Path) -> RunMetrics:
    """Read a metrics.json file written by ``write_run_metrics`` (or before schema_version).

    Args:
        path: the file (``RUN_DIR/metrics.json``).

    Returns:
        The validated metrics.

    Raises:
        DataError: naming the file: unreadable, not JSON (with the position), or a key missing,
            unknown or malformed (naming the key).
    """
    file = Path(path)
    try:
        text = file.read_text()
    except OSError as exc:
        raise DataError(f"cannot read the file ({exc})", file) from exc
    try:
        raw = json.loads(text)
    except json.JSONDecodeError as exc:
        raise DataError(f"not valid JSON ({exc})", file) from exc
    try:
        return RunMetrics.from_json(raw)
    except DataError as exc:
        raise DataError(str(exc), file) from None
