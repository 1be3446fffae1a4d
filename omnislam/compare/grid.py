"""Experiment grids: datasets x estimators x seeds x option overrides, read from YAML.

A grid file::

    name: real                      # optional; the report's title
    datasets:                       # registered names, or paths relative to this file
      - mrclam6-r1
      - {dataset: carmen-intel, label: intel}
      - {dataset: mrclam6-r2, options: {association: unknown}}   # loader options
    estimators:
      - deadreckoning
      - {estimator: fastslam1, label: fs1, options: {particles: 100}}
    seeds: [0, 1]                   # default [0]
    overrides:                      # optional option sets crossed with the estimators
      - {particles: 50, estimators: [fastslam1]}   # `estimators` limits where one applies
    evaluation: {rpe_segment_m: 10, landmark_gate_m: 2}   # optional EvaluationOptions

Every (dataset, estimator, seed, override) is a Cell with a deterministic id
(``DATASET__ESTIMATOR__sSEED[__OVERRIDE]``); an estimator no override applies to runs once with
its own options. ``load_grid`` validates everything up front -- YAML syntax, keys, estimator
names and availability, dataset presence, and every cell's options (loader, harness and
estimator, the latter against the estimator's configuration dataclass without building it:
``compare.execute.check_spec``) -- and raises ConfigError naming the file and the problem, so a
bad grid writes nothing.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from omnislam._files import safe_name, yaml_error_line
from omnislam.compare.evaluation import EvaluationOptions
from omnislam.compare.execute import RunSpec, check_estimator, check_spec
from omnislam.errors import ConfigError, OmnislamError

_TOP_KEYS = {"name", "datasets", "estimators", "seeds", "overrides", "evaluation"}


@dataclass(frozen=True, slots=True)
class Cell:
    """One run of a grid.

    Attributes:
        cell_id: deterministic folder name under ``RESULTS_DIR/cells``.
        dataset_label, estimator_label, override_label: labels for tables ("" = no override).
        spec: what to run.
    """

    cell_id: str
    dataset_label: str
    estimator_label: str
    override_label: str
    spec: RunSpec


@dataclass(frozen=True, slots=True)
class Grid:
    """A validated grid.

    Attributes:
        name: title of the grid.
        path: the YAML file it came from.
        cells: every cell, in dataset, estimator, override, seed order.
        evaluation: metric settings applied to every cell.
        text: the YAML text as given (copied into RESULTS_DIR).
    """

    name: str
    path: Path
    cells: tuple[Cell, ...]
    evaluation: EvaluationOptions = field(default_factory=EvaluationOptions)
    text: str = ""

    @property
    def datasets(self) -> tuple[str, ...]:
        """Dataset labels in grid order."""
        return tuple(dict.fromkeys(c.dataset_label for c in self.cells))

    @property
    def estimators(self) -> tuple[str, ...]:
        """Estimator labels (with override) in grid order."""
        return tuple(dict.fromkeys(column_label(c) for c in self.cells))


def column_label(cell: Cell) -> str:
    """The label of a cell's estimator column: ``estimator`` or ``estimator [override]``."""
    if cell.override_label:
        return f"{cell.estimator_label} [{cell.override_label}]"
    return cell.estimator_label


def _options(raw: object, where: str, path: Path) -> dict[str, str]:
    if raw is None:
        return {}
    if not isinstance(raw, Mapping):
        raise ConfigError(f"{path}: {where}: options must be a mapping, got {raw!r}")
    out = {}
    for key, value in raw.items():
        if isinstance(value, Mapping | list) or value is None:
            raise ConfigError(f"{path}: {where}: option {key!r} must be a scalar, got {value!r}")
        out[str(key)] = str(value).lower() if isinstance(value, bool) else str(value)
    return out


def _entries(raw: object, key: str, path: Path) -> list[dict[str, object]]:
    """``datasets`` / ``estimators``: a list of names or mappings with the name under ``key``."""
    if not isinstance(raw, list) or not raw:
        raise ConfigError(f"{path}: '{key}s' must be a non-empty list")
    out = []
    for i, item in enumerate(raw):
        where = f"{key}s[{i}]"
        if isinstance(item, str):
            item = {key: item}
        if not isinstance(item, Mapping) or not isinstance(item.get(key), str):
            raise ConfigError(f"{path}: {where}: expected a name or a mapping with '{key}'")
        unknown = set(item) - {key, "label", "options"}
        if unknown:
            raise ConfigError(f"{path}: {where}: unknown keys {sorted(unknown)}")
        out.append(
            {
                key: item[key],
                "label": str(item.get("label") or item[key]),
                "options": _options(item.get("options"), where, path),
            }
        )
    return out


def _dataset_argument(name: str, path: Path) -> tuple[str, str]:
    """(argument for ``resolve``, default label): a registered name, else a path near the file."""
    from omnislam.datasets.registry import REGISTRY, resolve

    if name in REGISTRY:
        argument = name
    else:
        candidate = Path(name).expanduser()
        argument = str(candidate if candidate.is_absolute() else path.parent / candidate)
    try:
        resolved = resolve(argument)
    except OmnislamError as exc:
        raise ConfigError(f"{path}: dataset {name!r}: {exc}") from None
    return argument, resolved.name if name not in REGISTRY else name


def parse_grid(text: str, path: Path) -> Grid:
    """Validate a grid's YAML text (``path`` names it in errors and anchors relative paths).

    Raises:
        ConfigError: malformed YAML, unknown keys, unknown or unavailable estimators, missing
            datasets, bad seeds or options, duplicate cells.
    """
    try:
        raw = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: {yaml_error_line(exc)}") from None
    if not isinstance(raw, Mapping):
        raise ConfigError(f"{path}: expected a mapping with 'datasets' and 'estimators'")
    unknown = set(raw) - _TOP_KEYS
    if unknown:
        raise ConfigError(f"{path}: unknown keys {sorted(unknown)}; known: {sorted(_TOP_KEYS)}")
    datasets = _entries(raw.get("datasets"), "dataset", path)
    estimators = _entries(raw.get("estimators"), "estimator", path)
    seeds = raw.get("seeds", [0])
    if (
        not isinstance(seeds, list)
        or not seeds
        or not all(isinstance(s, int) and not isinstance(s, bool) for s in seeds)
    ):
        raise ConfigError(f"{path}: 'seeds' must be a non-empty list of integers")
    if len(set(seeds)) != len(seeds):
        raise ConfigError(f"{path}: 'seeds' has duplicates")
    overrides_raw = raw.get("overrides") or []
    if not isinstance(overrides_raw, list):
        raise ConfigError(f"{path}: 'overrides' must be a list of option mappings")
    overrides: list[tuple[dict[str, str], set[str] | None]] = []
    for i, item in enumerate(overrides_raw):
        if not isinstance(item, Mapping):
            raise ConfigError(f"{path}: overrides[{i}]: expected a mapping")
        only = item.get("estimators")
        if only is not None and (
            not isinstance(only, list) or not all(isinstance(e, str) for e in only)
        ):
            raise ConfigError(f"{path}: overrides[{i}]: 'estimators' must be a list of names")
        options = _options({k: v for k, v in item.items() if k != "estimators"}, "overrides", path)
        overrides.append((options, set(only) if only is not None else None))
    evaluation_raw = raw.get("evaluation") or {}
    if not isinstance(evaluation_raw, Mapping):
        raise ConfigError(f"{path}: 'evaluation' must be a mapping")
    try:
        evaluation = EvaluationOptions(**evaluation_raw)
    except (TypeError, ConfigError) as exc:
        raise ConfigError(f"{path}: evaluation: {exc}") from None

    names = {str(e["estimator"]) for e in estimators} | {str(e["label"]) for e in estimators}
    for i, (_, only) in enumerate(overrides):
        if only and not only <= names:
            raise ConfigError(
                f"{path}: overrides[{i}]: estimators {sorted(only - names)} are not in the grid"
            )
    for entry in estimators:
        try:
            check_estimator(str(entry["estimator"]))
        except ConfigError as exc:
            raise ConfigError(f"{path}: {exc}") from None
    resolved = [_dataset_argument(str(d["dataset"]), path) for d in datasets]

    cells: list[Cell] = []
    for dataset, (argument, default_label) in zip(datasets, resolved, strict=True):
        d_label = str(dataset["label"]) if dataset["label"] != dataset["dataset"] else default_label
        for estimator in estimators:
            name, e_label = str(estimator["estimator"]), str(estimator["label"])
            applicable = [
                options for options, only in overrides if only is None or {name, e_label} & only
            ] or [{}]
            for override in applicable:
                o_label = ",".join(f"{k}={v}" for k, v in sorted(override.items()))
                for seed in seeds:
                    options = {**dataset["options"], **estimator["options"], **override}
                    cell_id = "__".join(
                        [safe_name(d_label), safe_name(e_label), f"s{seed}"]
                        + ([safe_name(o_label)] if o_label else [])
                    )
                    cells.append(
                        Cell(
                            cell_id,
                            d_label,
                            e_label,
                            o_label,
                            RunSpec(argument, name, seed, options),
                        )
                    )
    ids = [c.cell_id for c in cells]
    duplicates = sorted({i for i in ids if ids.count(i) > 1})
    if duplicates:
        raise ConfigError(f"{path}: cells with the same id {duplicates} (give them labels)")
    checked: set[tuple[str, str, tuple[tuple[str, str], ...]]] = set()
    for cell in cells:  # every cell's options, before any work starts
        key = (cell.spec.dataset, cell.spec.estimator, tuple(sorted(cell.spec.options.items())))
        if key in checked:
            continue
        checked.add(key)
        try:
            check_spec(cell.spec)
        except OmnislamError as exc:
            raise ConfigError(f"{path}: cell {cell.cell_id}: {exc}") from None
    return Grid(str(raw.get("name") or path.stem), path, tuple(cells), evaluation, text)


def load_grid(path: str | Path) -> Grid:
    """Read and validate a grid YAML file.

    Raises:
        ConfigError: the file is missing or unreadable, or ``parse_grid`` rejects it.
    """
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the grid file ({exc.strerror or exc})") from None
    return parse_grid(text, path)


#: the template's comment on each EvaluationOptions field (a test keeps the two in step)
EVALUATION_COMMENTS = {
    "rpe_segment_m": "RPE segment [m]; null: 10 m, shorter for runs under 40 m",
    "landmark_gate_m": "landmark association gate of maps without true ids [m]",
    "curve_lengths": "segment lengths of the error-over-distance curve",
}


def grid_template() -> str:
    """A commented grid file with every key ``parse_grid`` reads (``omnislam compare
    --template``); the ``evaluation`` keys, defaults and meanings come from EvaluationOptions.
    """
    import dataclasses

    evaluation = []
    for f in dataclasses.fields(EvaluationOptions):
        default = f.default
        value = "null" if default is None else yaml.safe_dump(default).splitlines()[0]
        evaluation.append(f"  {f.name}: {value}".ljust(32) + f"# {EVALUATION_COMMENTS[f.name]}")
    evaluation_text = "\n".join(evaluation)
    return f"""\
# omnislam grid: datasets x estimators x seeds x overrides, one run (cell) each.
# Run it:     omnislam compare GRID.yaml --out RESULTS_DIR [--workers N | --scheduler ADDRESS]
# Continue:   omnislam compare GRID.yaml --out RESULTS_DIR --resume   (finished cells are kept)
# Report it:  omnislam report RESULTS_DIR --out reports/NAME
# Every key but `datasets` and `estimators` is optional. The whole grid is checked before any
# cell runs (names, datasets, every option against the estimator's configuration).

name: my comparison             # the report's title (default: the file's name)

datasets:                       # a registered name (`omnislam dataset list`) or a path
  - mrclam6-r1                  #   (relative to this file): a synthetic or folder dataset
  - {{dataset: mrclam6-r2, label: r2-no-ids, options: {{association: unknown}}}}
                                #   label: its name in the report; options: loader options
                                #   (`omnislam estimators` lists them per dataset format)
  # - renders/lab40             # e.g. `omnislam dataset synth lab40 --out renders/lab40`

estimators:                     # names from `omnislam estimators`, with their --set options
  - deadreckoning               #   (the baseline; not ranked in the verdict)
  - graphslam
  - {{estimator: fastslam1, label: fs1, options: {{resampling: stratified}}}}
  - ekfslam

seeds: [0, 1, 2]                # one run per seed (default [0]); the verdict uses their spread

overrides:                      # option sets: an estimator they apply to runs once per
  - {{n_particles: 30, estimators: [fs1]}}    #   override (on top of its own options) instead
  - {{n_particles: 300, estimators: [fs1]}}   #   of once; `estimators` limits where one applies
  # - {{wrong_id_fraction: 0.05}}             # (names or labels); harness options apply to all

evaluation:                     # how every cell is scored (optional)
{evaluation_text}
"""
