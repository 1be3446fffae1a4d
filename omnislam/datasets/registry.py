"""Registry of datasets: registered names, on-disk formats, and format detection.

``omnislam run DATASET`` accepts a registered name (``mrclam6-r1``, ``victoria-park``, ...) or a
path to any file or folder in one of the formats below; the format is detected from the files.
Loader options come from ``--set key=value``: each format declares the keys it accepts (e.g.
``robot`` for MR.CLAM), the remaining keys belong to the estimator.

Loaders are imported lazily (``module:function`` strings), so listing datasets costs nothing and
a missing optional part (gtsam, the synthetic renderer) only matters when it is used.
"""

from __future__ import annotations

import enum
import importlib
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from omnislam.datasets._common import DATA_ENV, Association, data_root
from omnislam.datasets.sequence import GroundTruthKind, Sequence
from omnislam.errors import ConfigError, DataError, did_you_mean

if TYPE_CHECKING:
    from omnislam.datasets.synthetic.presets import Preset


def _bool(text: str) -> bool:
    lowered = text.strip().lower()
    if lowered not in {"true", "false", "1", "0", "yes", "no"}:
        raise ValueError(f"expected true/false, got {text!r}")
    return lowered in {"true", "1", "yes"}


def _positive_float(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise ValueError("must be positive")
    return value


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError("must be a finite number")
    return value


def _sigma(text: str) -> float:
    """A standard deviation: positive and finite (an infinite one reaches the estimators as
    NaN information)."""
    value = _finite_float(text)
    if not value > 0:
        raise ValueError("must be positive")
    return value


def _carmen_odometry_noise(text: str) -> object:
    from omnislam.datasets.carmen import parse_odometry_noise

    return parse_odometry_noise(text)


#: The odometry noise of the two corrected CARMEN logs between keyframes (alphas of thesis eq.
#: 4.41, then the floors of the translation [m] and rotation [rad] stds), fitted to the
#: corrected poses by maximum likelihood with squared Mahalanobis distances capped at 25
#: (median frame-to-frame NEES 2.2 and 2.3 under them, 3 dof: 2.37 expected; under the shared
#: default 95 and 10.5: its 0.1 mm floor gives a keyframe step that is mostly a turn almost no
#: translation uncertainty, where these logs have 3-4 cm). Not stated by default: with it
#: (``--set odometry_noise=...``, ``benchmarks/ekfslam_accuracy.py --stated-odometry``) the
#: wider gates let the unknown association of the laser landmarks go wrong more often: aces
#: gets worse for graphslam and EKF-SLAM (FastSLAM samples its own motion model and ignores a
#: stated covariance); docs/results/ekfslam.md.
CARMEN_ODOMETRY_NOISE = {
    "carmen-intel": "0.0313,0.0438,0.0028,0.0721,0.0373,0.0024",
    "carmen-aces": "0.0575,0.005,0.0039,0.1308,0.0302,0.0018",
}


class DatasetFormat(enum.Enum):
    """The on-disk formats omnislam reads."""

    MRCLAM = "mrclam"
    VICTORIA_PARK = "victoria-park"
    GTSAM_GRAPH = "gtsam-graph"
    CARMEN = "carmen"
    SYNTHETIC = "synthetic"
    FOLDER = "omnislam-folder"


@dataclass(frozen=True, slots=True)
class FormatSpec:
    """How to detect and load one format.

    Attributes:
        detect: ``"module:function"``, ``function(path) -> bool``.
        load: ``"module:function"``, ``function(path, **options) -> Sequence``.
        options: option name -> parser from the ``--set`` string to the loader's keyword value.
    """

    detect: str
    load: str
    options: Mapping[str, Callable[[str], object]] = field(default_factory=dict)


FORMATS: dict[DatasetFormat, FormatSpec] = {
    DatasetFormat.MRCLAM: FormatSpec(
        "omnislam.datasets.mrclam:is_mrclam_folder",
        "omnislam.datasets.mrclam:load_mrclam",
        {
            "robot": int,
            "association": Association.parse,
            "sigma_range_m": _sigma,
            "sigma_bearing_rad": _sigma,
            "depth_ranges": _bool,
            "command_delay_s": _finite_float,
            "odometry_noise": _bool,
            "max_step_s": _positive_float,
            "same_image_s": float,
        },
    ),
    DatasetFormat.VICTORIA_PARK: FormatSpec(
        "omnislam.datasets.victoria_park:is_victoria_park_folder",
        "omnislam.datasets.victoria_park:load_victoria_park",
        {"sigma_range_m": _sigma, "sigma_bearing_rad": _sigma},
    ),
    DatasetFormat.GTSAM_GRAPH: FormatSpec(
        "omnislam.datasets.gtsam_victoria:is_gtsam_graph_file",
        "omnislam.datasets.gtsam_victoria:load_gtsam_victoria",
        {
            "association": Association.parse,
            "sigma_range_m": _sigma,
            "sigma_bearing_rad": _sigma,
            "odometry_sigma_theta_rad": _sigma,
        },
    ),
    DatasetFormat.CARMEN: FormatSpec(
        "omnislam.datasets.carmen:is_carmen_log",
        "omnislam.datasets.carmen:load_carmen",
        {"odometry_noise": _carmen_odometry_noise},
    ),
    DatasetFormat.SYNTHETIC: FormatSpec(
        "omnislam.datasets.synthetic:is_synthetic_folder",
        "omnislam.datasets.synthetic:load_synthetic",
        {"association": Association.parse},
    ),
    DatasetFormat.FOLDER: FormatSpec(
        "omnislam.datasets.folder:is_folder",
        "omnislam.datasets.folder:load_folder",
        {"association": Association.parse},
    ),
}

#: detection order (most specific first)
DETECTION_ORDER = (
    DatasetFormat.FOLDER,
    DatasetFormat.SYNTHETIC,
    DatasetFormat.MRCLAM,
    DatasetFormat.VICTORIA_PARK,
    DatasetFormat.CARMEN,
    DatasetFormat.GTSAM_GRAPH,
)


@dataclass(frozen=True, slots=True)
class DatasetEntry:
    """A registered real dataset.

    Attributes:
        name: registry name used on the command line.
        format: its on-disk format.
        relative_path: path under the data root (``$OMNISLAM_DATA`` or ``../shared/data``);
            empty for gtsam's file, which is found through gtsam.
        source: citation, one line.
        sensors: what it provides, one line.
        ground_truth: the kind of ground truth.
        options: loader options fixed by the entry (e.g. the robot).
    """

    name: str
    format: DatasetFormat
    relative_path: str
    source: str
    sensors: str
    ground_truth: GroundTruthKind
    options: Mapping[str, str] = field(default_factory=dict)

    def location(self) -> Path | None:
        """Where this dataset is looked for (None when gtsam is not installed)."""
        if self.format is DatasetFormat.GTSAM_GRAPH and not self.relative_path:
            from omnislam.datasets.gtsam_victoria import find_gtsam_file

            return find_gtsam_file()
        return data_root() / self.relative_path

    def found(self) -> bool:
        """True when the data is present at ``location()``."""
        where = self.location()
        return where is not None and where.exists()


_MRCLAM_SOURCE = "Leung, Halpern, Barfoot, Liu, IJRR 2011 (UTIAS MR.CLAM), dataset 6"
_MRCLAM_SENSORS = "odometry (v, omega); range-bearing to 15 barcoded landmarks (ids)"

REGISTRY: dict[str, DatasetEntry] = {
    **{
        f"mrclam6-r{robot}": DatasetEntry(
            f"mrclam6-r{robot}",
            DatasetFormat.MRCLAM,
            "mrclam/MRCLAM_Dataset6",
            f"{_MRCLAM_SOURCE}, robot {robot}",
            _MRCLAM_SENSORS,
            GroundTruthKind.MOTION_CAPTURE,
            {"robot": str(robot)},
        )
        for robot in range(1, 6)
    },
    "victoria-park": DatasetEntry(
        "victoria-park",
        DatasetFormat.VICTORIA_PARK,
        "victoria_park",
        "Guivant & Nebot, IEEE T-RA 2001 (ACFR Victoria Park)",
        "speed + steering (Ackermann); laser tree range-bearing (no ids)",
        GroundTruthKind.GPS_PARTIAL,
    ),
    "victoria-park-gtsam": DatasetEntry(
        "victoria-park-gtsam",
        DatasetFormat.GTSAM_GRAPH,
        "",
        "gtsam example data victoria_park.txt (from Guivant & Nebot 2001)",
        "odometry steps; landmark sightings with ids",
        GroundTruthKind.REFERENCE,
    ),
    "carmen-intel": DatasetEntry(
        "carmen-intel",
        DatasetFormat.CARMEN,
        "carmen/intel-corrected.log.gz",
        "Intel Research Lab (Haehnel), Radish; corrected log (Kuemmerle et al. 2009)",
        "wheel odometry; 180-beam laser",
        GroundTruthKind.PSEUDO,
    ),
    "carmen-aces": DatasetEntry(
        "carmen-aces",
        DatasetFormat.CARMEN,
        "carmen/aces-corrected.log.gz",
        "ACES building, UT Austin (Beeson), Radish; corrected log (Kuemmerle et al. 2009)",
        "wheel odometry; 180-beam laser",
        GroundTruthKind.PSEUDO,
    ),
}


#: how the provenance of a run names a format (``path_source``)
FORMAT_TITLES = {
    DatasetFormat.MRCLAM: "MR.CLAM",
    DatasetFormat.VICTORIA_PARK: "Victoria Park",
    DatasetFormat.GTSAM_GRAPH: "gtsam graph",
    DatasetFormat.CARMEN: "CARMEN log",
    DatasetFormat.SYNTHETIC: "omnislam synthetic",
    DatasetFormat.FOLDER: "omnislam folder",
}
#: formats whose files state their own source (a render its preset and seed, an omnislam folder
#: its dataset.json): a path in them keeps it
SELF_DESCRIBED = frozenset({DatasetFormat.SYNTHETIC, DatasetFormat.FOLDER})


@dataclass(frozen=True, slots=True)
class ResolvedDataset:
    """A dataset argument turned into a format, a path, a name and fixed options.

    Attributes:
        registered: the argument was a registered name (the published dataset, credited to
            its authors); False for a path, whatever data it holds.
    """

    name: str
    format: DatasetFormat
    path: Path
    options: Mapping[str, str] = field(default_factory=dict)
    registered: bool = False

    def option_names(self) -> frozenset[str]:
        """The ``--set`` keys the loader of this format accepts."""
        return frozenset(FORMATS[self.format].options)


def _function(spec: str) -> Callable[..., object]:
    module_name, attribute = spec.split(":")
    module = importlib.import_module(module_name)
    return getattr(module, attribute)


def detect_format(path: Path) -> DatasetFormat | None:
    """The format of a file or folder, or None when no loader recognises it."""
    for fmt in DETECTION_ORDER:
        try:
            detect = _function(FORMATS[fmt].detect)
        except (ImportError, AttributeError):  # an optional part not installed / not written
            continue
        if detect(path):
            return fmt
    if path.is_dir():  # a folder holding exactly one CARMEN log
        logs = [p for p in path.iterdir() if p.name.endswith((".log", ".log.gz"))]
        if len(logs) == 1:
            return DatasetFormat.CARMEN
    return None


def resolve(dataset: str) -> ResolvedDataset:
    """Turn a registered name or a path into a ResolvedDataset.

    Raises:
        DataError: a registered dataset whose files are missing (naming where it looked), or a
            path no loader recognises.
        ConfigError: neither a registered name nor an existing path.
    """
    entry = REGISTRY.get(dataset)
    if entry is not None:
        where = entry.location()
        if where is None:
            raise DataError(
                f"dataset {dataset!r} needs gtsam's example data: install the 'graph' extra"
            )
        if not where.exists():
            raise DataError(
                f"dataset {dataset!r} not found: looked in {where} "
                f"(set {DATA_ENV} to the folder holding the real data)"
            )
        return ResolvedDataset(entry.name, entry.format, where, entry.options, registered=True)
    path = Path(dataset).expanduser()
    if not path.exists():
        raise ConfigError(_unknown_dataset_message(dataset))
    fmt = detect_format(path)
    if fmt is None:
        raise DataError(
            "no loader recognises this file or folder (expected an omnislam folder with a "
            "dataset.json, an MR.CLAM folder, a Victoria Park folder, a CARMEN .log[.gz], a "
            "gtsam graph file or a synthetic folder)",
            path,
        )
    if fmt is DatasetFormat.CARMEN and path.is_dir():
        path = next(p for p in path.iterdir() if p.name.endswith((".log", ".log.gz")))
    name = path.name.removesuffix(".gz").removesuffix(".log") if path.is_file() else path.name
    return ResolvedDataset(name, fmt, path)


def path_source(fmt: DatasetFormat, path: Path) -> str:
    """The provenance of data read from a path: what it is and where, crediting no one (a folder
    in MR.CLAM format need not be the published MR.CLAM dataset)."""
    kind = "folder" if path.is_dir() else "file"
    return f"a {kind} in {FORMAT_TITLES[fmt]} format at {path}"


def preset_names() -> tuple[str, ...]:
    """The synthetic presets' names (none when the synthetic package cannot be imported)."""
    try:
        from omnislam.datasets.synthetic import PRESETS
    except (ImportError, AttributeError):
        return ()
    return tuple(str(name) for name in PRESETS)


def _unknown_dataset_message(dataset: str) -> str:
    """The one line for a dataset argument that names nothing, with the nearest names."""
    presets = preset_names()
    hint = did_you_mean(dataset, [*REGISTRY, *presets])
    where = f"a registered name ({', '.join(REGISTRY)})"
    if presets:
        where += f", a synthetic preset ({', '.join(presets)})"
    return f"unknown dataset {dataset!r}{hint}: not {where} nor an existing file or folder"


def parse_options(fmt: DatasetFormat, options: Mapping[str, str]) -> dict[str, object]:
    """Convert ``--set`` strings to the loader's keyword arguments.

    Raises:
        ConfigError: an option the format does not accept, or a value that does not parse.
    """
    parsers = FORMATS[fmt].options
    out: dict[str, object] = {}
    for key, text in options.items():
        if key not in parsers:
            known = ", ".join(sorted(parsers)) or "none"
            raise ConfigError(f"{fmt.value} datasets take no option {key!r} (options: {known})")
        try:
            out[key] = parsers[key](text)
        except (ValueError, ConfigError) as exc:
            raise ConfigError(f"option {key}={text!r}: {exc}") from None
    return out


def load_dataset(
    dataset: str | ResolvedDataset, options: Mapping[str, str] | None = None
) -> Sequence:
    """Load a registered dataset or a path, with loader options.

    Args:
        dataset: a registered name, a path, or the result of ``resolve``.
        options: loader options (``--set`` strings); they override the entry's fixed ones.

    Returns:
        The Sequence; its ``source`` credits a registered dataset's authors, and names what
        and where the data is for a path (``path_source``).
    """
    resolved = resolve(dataset) if isinstance(dataset, str) else dataset
    merged = {**resolved.options, **(options or {})}
    kwargs = parse_options(resolved.format, merged)
    try:
        load = _function(FORMATS[resolved.format].load)
    except (ImportError, AttributeError) as exc:
        raise DataError(
            f"the {resolved.format.value} loader is not available ({exc})", resolved.path
        ) from exc
    if resolved.format is not DatasetFormat.SYNTHETIC:
        kwargs.setdefault("name", resolved.name)
    sequence = load(resolved.path, **kwargs)
    if not isinstance(sequence, Sequence):  # pragma: no cover - defensive
        raise DataError("loader did not return a Sequence", resolved.path)
    if not resolved.registered and resolved.format not in SELF_DESCRIBED:
        sequence = replace(sequence, source=path_source(resolved.format, resolved.path))
    return sequence


@dataclass(frozen=True, slots=True)
class ListedDataset:
    """One row of ``omnislam dataset list``."""

    name: str
    kind: str  # "real" or "synthetic preset"
    source: str
    sensors: str
    ground_truth: str
    found: bool
    location: str


def list_datasets() -> list[ListedDataset]:
    """Every registered real dataset (found or not, and where) and the synthetic presets."""
    rows = []
    for entry in REGISTRY.values():
        where = entry.location()
        rows.append(
            ListedDataset(
                entry.name,
                "real",
                entry.source,
                entry.sensors,
                entry.ground_truth.value,
                entry.found(),
                str(where) if where is not None else "gtsam not installed",
            )
        )
    try:
        from omnislam.datasets.synthetic import PRESETS
    except (ImportError, AttributeError):
        PRESETS = {}
    for name, preset in PRESETS.items():
        rows.append(
            ListedDataset(
                str(name),
                "synthetic preset",
                "omnislam synthetic omni world",
                _synthetic_sensors(preset),
                GroundTruthKind.EXACT.value,
                True,
                f"rendered by: omnislam run {name} (cached) or dataset synth {name} --out DIR",
            )
        )
    return rows


def _synthetic_sensors(preset: Preset) -> str:
    """What a synthetic preset's folder provides, one line for ``dataset list``."""
    from omnislam.datasets.synthetic.presets import CameraKind

    if preset.camera is CameraKind.NONE:
        ids = " without ids" if preset.association is Association.UNKNOWN else ""
        return f"laser pole sightings{ids}, laser scans, no images; true/noisy odometry"
    return "rendered omni images; true/noisy odometry"
