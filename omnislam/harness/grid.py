"""Experiment grids: datasets x estimators x seeds x option overrides, read from YAML.

A grid file::

    name: real                      # optional; the report's title
    datasets:                       # registered names, or paths relative to this file
      - mrclam6-r1
      - {dataset: carmen-intel, label: intel}
      - {dataset: mrclam6-r2, options: {association: unknown}}   # loader options
      - {synthetic: lab40, seeds: [0, 1, 2]}    # a synthetic preset, rendered per seed
      - {synthetic: lab40, realism: realistic, label: lab40-real}   # through a camera sensor
      - {dataset: victoria-park, estimators: [deadreckoning, fs1]}   # only these run on it
    estimators:
      - deadreckoning
      - {estimator: fastslam1, label: fs1, options: {particles.n_particles: 100}, seeds: [0, 1, 2]}
      - {estimator: ukf, label: ukf-on-graph, options: {prior_map: {from: graphslam}}}
      - {estimator: external, label: mysys, files: "results/{dataset}/{seed}.tum"}
    seeds: [0, 1]                   # default [0]; an estimator's own `seeds` win
    overrides:                      # optional option sets crossed with the estimators
      - {particles.n_particles: 50, estimators: [fastslam1]}   # `estimators`: where it applies
    evaluation: {rpe_segment_m: 10, landmark_gate_m: 2}   # optional EvaluationOptions

Every (dataset, estimator, seed, override) is a Cell with a deterministic id
(``DATASET__ESTIMATOR__sSEED[__OVERRIDE]``); an estimator no override applies to runs once with
its own options. ``load_grid`` validates everything up front -- YAML syntax, keys, estimator
names and availability, dataset presence, and every cell's options (loader, harness and
estimator, the latter against the estimator's configuration dataclass without building it:
``harness.execute.check_spec``) -- and raises ConfigError naming the file and the problem, so a
bad grid writes nothing.

Seeds: a cell's seed seeds its estimator. An estimator runs on the grid's ``seeds`` unless its
entry has its own. On data on disk a deterministic estimator (``EstimatorEntry.stochastic``
False: the graph, the Kalman filters, dead reckoning) runs once, with the first of its seeds,
since every seed would repeat the same run; it runs per seed when the harness draws with the
seed (``wrong_id_fraction``, ``clutter_per_frame``) or its prior map comes from a cell that
runs per seed. A synthetic dataset (``synthetic: PRESET``, optional ``images: N`` to stop after
N images and ``realism: clean|realistic``, default clean, ``datasets.synthetic.realism``) is a
different world and noise draw per seed: it is rendered once per seed of its ``seeds`` (default
the grid's) into the cache (``harness.renders``), and *every* estimator runs on it once per
seed, that seed seeding both the render and the estimator -- so the spread over seeds of a
synthetic row is over worlds too. Unlabelled, a render that is not clean is labelled
``PRESET-REALISM``.

``estimator: external`` is another system's results, read from files instead of run
(``harness.external``): ``files`` names its trajectory for each cell, ``{dataset}`` (the
dataset's label) and ``{seed}`` filled in, relative to the grid file (TUM, or KITTI with one
pose per frame; ``format: tum|kitti|auto``, default auto); ``landmarks`` optionally names its
map the same way (``id,x,y,z`` CSV), ``true_landmark_ids: true`` when the map's ids are the
dataset's landmark ids. Every file must exist when the grid is read. It takes no ``options``,
and overrides do not apply to it: it runs once per dataset and seed.

``prior_map: {from: LABEL}`` gives a localiser the map of another cell of the grid: the RUN_DIR
of estimator LABEL on the same dataset with the same seed (the same override if it has one),
whose landmarks become the prior map (``harness.prior``). The runner computes that cell first;
the dependent cell is computed again whenever its map is.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import yaml

from omnislam._files import safe_name, yaml_error_line
from omnislam.errors import ConfigError, OmnislamError
from omnislam.harness.evaluation import EvaluationOptions
from omnislam.harness.execute import RunSpec, check_estimator, check_spec
from omnislam.harness.external import (
    EXTERNAL,
    PLACEHOLDERS,
    ExternalResult,
    TrajectoryFormat,
    fill_pattern,
    pattern_fields,
)
from omnislam.harness.perturb import CLUTTER_OPTION, WRONG_ID_OPTION
from omnislam.harness.prior import PRIOR_MAP_OPTION
from omnislam.harness.renders import RenderSpec, render_spec

_TOP_KEYS = {"name", "datasets", "estimators", "seeds", "overrides", "evaluation"}
_DATASET_KEYS = {
    "dataset", "synthetic", "label", "options", "seeds", "images", "realism", "estimators"
}
_ESTIMATOR_KEYS = {"estimator", "label", "options", "seeds"}
#: the keys of an ``estimator: external`` entry besides ``estimator``, ``label`` and ``seeds``
_EXTERNAL_KEYS = {"files", "landmarks", "format", "true_landmark_ids"}
#: the key of ``prior_map: {from: LABEL}``
FROM_KEY = "from"


@dataclass(frozen=True, slots=True)
class Cell:
    """One run of a grid.

    Attributes:
        cell_id: deterministic folder name under ``RESULTS_DIR/cells``.
        dataset_label, estimator_label, override_label: labels for tables ("" = no override).
        spec: what to run.
        render: the synthetic render ``spec.dataset`` names (rendered by the runner when it is
            not in the cache yet); None for data on disk.
        prior_from: the cell whose RUN_DIR is this cell's prior map (``prior_map: {from:}``);
            the runner fills ``spec.options["prior_map"]`` with its folder. None otherwise.
        external: the files of another system's results (``estimator: external``,
            ``harness.external``): the cell reads them instead of running an estimator. None
            for a cell that runs one.
    """

    cell_id: str
    dataset_label: str
    estimator_label: str
    override_label: str
    spec: RunSpec
    render: RenderSpec | None = None
    prior_from: str | None = None
    external: ExternalResult | None = None


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


def _options(
    raw: object, where: str, path: Path, prior_from: list[str] | None = None
) -> dict[str, str]:
    """Option strings; with ``prior_from``, ``prior_map: {from: LABEL}`` is taken out into it."""
    if raw is None:
        return {}
    if not isinstance(raw, Mapping):
        raise ConfigError(f"{path}: {where}: options must be a mapping, got {raw!r}")
    out = {}
    for key, value in raw.items():
        if prior_from is not None and key == PRIOR_MAP_OPTION and isinstance(value, Mapping):
            label = value.get(FROM_KEY)
            if set(value) != {FROM_KEY} or not isinstance(label, str):
                raise ConfigError(
                    f"{path}: {where}: option {PRIOR_MAP_OPTION!r} takes a RUN_DIR or "
                    f"{{{FROM_KEY}: ESTIMATOR_LABEL}}, got {dict(value)!r}"
                )
            prior_from.append(label)
            continue
        if isinstance(value, Mapping | list) or value is None:
            raise ConfigError(f"{path}: {where}: option {key!r} must be a scalar, got {value!r}")
        out[str(key)] = str(value).lower() if isinstance(value, bool) else str(value)
    return out


def _seeds(raw: object, where: str, path: Path) -> list[int]:
    if (
        not isinstance(raw, list)
        or not raw
        or not all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in raw)
    ):
        raise ConfigError(f"{path}: {where}'seeds' must be a non-empty list of integers >= 0")
    if len(set(raw)) != len(raw):
        raise ConfigError(f"{path}: {where}'seeds' has duplicates")
    return list(raw)


def _names(raw: object, where: str, what: str, path: Path) -> list[str]:
    if not isinstance(raw, list) or not all(isinstance(e, str) for e in raw):
        raise ConfigError(f"{path}: {where}: '{what}' must be a list of names")
    return list(raw)


def _entries(raw: object, key: str, path: Path) -> list[dict[str, object]]:
    """``datasets`` / ``estimators``: a list of names or mappings with the name under ``key``
    (a dataset may be ``synthetic: PRESET`` instead)."""
    if not isinstance(raw, list) or not raw:
        raise ConfigError(f"{path}: '{key}s' must be a non-empty list")
    allowed = _DATASET_KEYS if key == "dataset" else _ESTIMATOR_KEYS | _EXTERNAL_KEYS
    out = []
    for i, item in enumerate(raw):
        where = f"{key}s[{i}]"
        if isinstance(item, str):
            item = {key: item}
        name_key = (
            "synthetic"
            if key == "dataset" and isinstance(item, Mapping) and "synthetic" in item
            else key
        )
        if (
            not isinstance(item, Mapping)
            or not isinstance(item.get(name_key), str)
            or (name_key == "synthetic" and key in item)
        ):
            expected = f"'{key}'" + (" or 'synthetic'" if key == "dataset" else "")
            raise ConfigError(f"{path}: {where}: expected a name or a mapping with {expected}")
        unknown = set(item) - allowed
        if unknown:
            raise ConfigError(f"{path}: {where}: unknown keys {sorted(unknown)}")
        if (name_key != "synthetic" and ({"seeds", "images", "realism"} & set(item))
                and key == "dataset"):
            raise ConfigError(
                f"{path}: {where}: 'seeds', 'images' and 'realism' apply to synthetic datasets "
                "only"
            )
        label = item.get("label")
        if label is not None and (not isinstance(label, str) or not label.strip()):
            raise ConfigError(f"{path}: {where}: 'label' must be text, got {label!r}")
        images = item.get("images")
        if images is not None and (
            not isinstance(images, int) or isinstance(images, bool) or images < 1
        ):
            raise ConfigError(f"{path}: {where}: 'images' must be a positive integer")
        prior_from: list[str] = []
        entry: dict[str, object] = {
            key: item[name_key],
            "synthetic": name_key == "synthetic",
            "label": str(item.get("label") or _default_label(item, name_key)),
            "options": _options(
                item.get("options"), where, path, prior_from if key == "estimator" else None
            ),
            "prior_from": prior_from[0] if prior_from else None,
            "seeds": _seeds(item["seeds"], f"{where}: ", path) if "seeds" in item else None,
            "images": images,
            "realism": item.get("realism", "clean"),
            "estimators": (
                _names(item["estimators"], where, "estimators", path)
                if "estimators" in item
                else None
            ),
            "external": _external(item, where, path) if key == "estimator" else None,
            "where": where,
        }
        out.append(entry)
    return out


def _default_label(item: Mapping[str, object], name_key: str) -> str:
    """An entry's label when it gives none: its name, a render's realism appended unless
    clean (``lab40-realistic``)."""
    realism = item.get("realism", "clean")
    return f"{item[name_key]}-{realism}" if realism != "clean" else str(item[name_key])


def _external(item: Mapping[str, object], where: str, path: Path) -> dict[str, object] | None:
    """The keys of an ``estimator: external`` entry, checked (None for any other estimator).

    Raises:
        ConfigError: naming the grid file, the entry and the key.
    """
    given = _EXTERNAL_KEYS & set(item)
    if item["estimator"] != EXTERNAL:
        if given:
            raise ConfigError(
                f"{path}: {where}: {sorted(given)} apply to 'estimator: {EXTERNAL}' only"
            )
        return None
    if "options" in item:
        raise ConfigError(f"{path}: {where}: an external estimator takes no 'options'")
    out: dict[str, object] = {}
    for key in ("files", "landmarks"):
        pattern = item.get(key)
        if pattern is None and key == "landmarks":
            continue
        if not isinstance(pattern, str) or not pattern.strip():
            raise ConfigError(
                f"{path}: {where}: '{key}' must be a file pattern such as "
                f"'results/{{dataset}}/{{seed}}.tum', got {pattern!r}"
            )
        try:
            unknown = pattern_fields(pattern) - PLACEHOLDERS
        except ConfigError as exc:
            raise ConfigError(f"{path}: {where}: '{key}': {exc}") from None
        if unknown:
            raise ConfigError(
                f"{path}: {where}: '{key}': unknown placeholders {sorted(unknown)}; "
                f"known: {{dataset}}, {{seed}}"
            )
        out[key] = pattern
    try:
        out["format"] = TrajectoryFormat(item.get("format", "auto"))
    except ValueError:
        known = ", ".join(f.value for f in TrajectoryFormat)
        raise ConfigError(
            f"{path}: {where}: 'format' must be one of {known}, got {item['format']!r}"
        ) from None
    ids = item.get("true_landmark_ids", False)
    if not isinstance(ids, bool):
        raise ConfigError(f"{path}: {where}: 'true_landmark_ids' must be true or false")
    out["true_landmark_ids"] = ids
    return out


def _external_result(
    estimator: Mapping[str, object], dataset: str, seed: int, path: Path
) -> ExternalResult:
    """The files of one external cell, each of which must exist.

    Raises:
        ConfigError: a missing file, naming the grid file, the entry, the key and the cell.
    """
    keys: Mapping[str, object] = estimator["external"]  # type: ignore[assignment]
    files: dict[str, str | None] = {"landmarks": None}
    for key in ("files", "landmarks"):
        if key not in keys:
            continue
        file = fill_pattern(str(keys[key]), path.parent, dataset, seed)
        if not file.is_file():
            raise ConfigError(
                f"{path}: {estimator['where']}: '{key}': {file} not found (dataset "
                f"{dataset}, seed {seed})"
            )
        files[key] = str(file)
    return ExternalResult(
        str(files["files"]),
        keys["format"],  # type: ignore[arg-type]
        files["landmarks"],
        bool(keys["true_landmark_ids"]),
    )


def _dataset_argument(name: str, path: Path) -> tuple[str, str]:
    """(argument for ``resolve``, default label): a registered name, else an absolute path
    (relative ones are relative to the grid file; workers of a cluster run elsewhere)."""
    from omnislam.datasets.registry import REGISTRY, resolve

    if name in REGISTRY:
        argument = name
    else:
        candidate = Path(name).expanduser()
        argument = str(
            (candidate if candidate.is_absolute() else path.parent / candidate).absolute()
        )
    try:
        resolved = resolve(argument)
    except OmnislamError as exc:
        raise ConfigError(f"{path}: dataset {name!r}: {exc}") from None
    return argument, resolved.name if name not in REGISTRY else name


@dataclass(frozen=True, slots=True)
class _Dataset:
    """A dataset entry resolved: one (argument, render) per seed, or one for every seed."""

    label: str
    options: dict[str, str]
    estimators: list[str] | None
    # seed -> (dataset argument, render) for a synthetic dataset; None for data on disk
    renders: dict[int, tuple[str, RenderSpec]] | None = None
    argument: str = ""


def _resolve_datasets(
    entries: list[dict[str, object]], seeds: list[int], path: Path
) -> list[_Dataset]:
    out = []
    for i, entry in enumerate(entries):
        options = dict(entry["options"])  # type: ignore[arg-type]
        only = entry["estimators"]  # type: ignore[assignment]
        if entry["synthetic"]:
            preset = str(entry["dataset"])
            renders = {}
            for seed in entry["seeds"] or seeds:  # type: ignore[union-attr]
                try:
                    spec = render_spec(
                        preset, seed, entry["images"], entry["realism"]  # type: ignore[arg-type]
                    )
                except (ConfigError, ImportError) as exc:
                    raise ConfigError(f"{path}: datasets[{i}]: {exc}") from None
                renders[seed] = (str(spec.path().absolute()), spec)
            label = str(entry["label"])
            out.append(_Dataset(label, options, only, renders))  # type: ignore[arg-type]
        else:
            argument, default_label = _dataset_argument(str(entry["dataset"]), path)
            label = str(entry["label"]) if entry["label"] != entry["dataset"] else default_label
            out.append(_Dataset(label, options, only, argument=argument))  # type: ignore[arg-type]
    return out


def parse_grid(text: str, path: Path) -> Grid:
    """Validate a grid's YAML text (``path`` names it in errors and anchors relative paths).

    Raises:
        ConfigError: malformed YAML, unknown keys, a name or label that is not text, unknown
            or unavailable estimators, missing datasets or presets, bad seeds or options,
            duplicate cells, a prior map from an estimator that has no cell on the same dataset
            and seed.
    """
    raw = _top_level(text, path)
    dataset_entries = _entries(raw.get("datasets"), "dataset", path)
    estimators = _entries(raw.get("estimators"), "estimator", path)
    seeds = _seeds(raw.get("seeds", [0]), "", path)
    overrides = _overrides(raw.get("overrides") or [], path)
    evaluation = _evaluation(raw.get("evaluation") or {}, path)
    _check_labels(dataset_entries, estimators, overrides, path)
    datasets = _resolve_datasets(dataset_entries, seeds, path)
    cells = _link_prior_maps(_cells(datasets, estimators, overrides, seeds, path), path)
    _check_specs(cells, path)
    return Grid(str(raw.get("name") or path.stem), path, tuple(cells), evaluation, text)


#: an override: its options, and the estimator names or labels it applies to (None: all)
Override = tuple[dict[str, str], set[str] | None]


def _top_level(text: str, path: Path) -> Mapping[str, object]:
    """The grid's YAML as a mapping of known keys, its ``name`` text if given."""
    try:
        raw = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: {yaml_error_line(exc)}") from None
    if not isinstance(raw, Mapping):
        raise ConfigError(f"{path}: expected a mapping with 'datasets' and 'estimators'")
    unknown = set(raw) - _TOP_KEYS
    if unknown:
        raise ConfigError(f"{path}: unknown keys {sorted(unknown)}; known: {sorted(_TOP_KEYS)}")
    name = raw.get("name")
    if name is not None and (not isinstance(name, str) or not name.strip()):
        raise ConfigError(f"{path}: 'name' must be text (the report's title), got {name!r}")
    return raw


def _overrides(raw: object, path: Path) -> list[Override]:
    """``overrides``: option sets, each limited to some estimators when it names them."""
    if not isinstance(raw, list):
        raise ConfigError(f"{path}: 'overrides' must be a list of option mappings")
    overrides: list[Override] = []
    for i, item in enumerate(raw):
        if not isinstance(item, Mapping):
            raise ConfigError(f"{path}: overrides[{i}]: expected a mapping")
        only = item.get("estimators")
        if only is not None:
            only = _names(only, f"overrides[{i}]", "estimators", path)
        options = _options({k: v for k, v in item.items() if k != "estimators"}, "overrides", path)
        overrides.append((options, set(only) if only is not None else None))
    return overrides


def _evaluation(raw: object, path: Path) -> EvaluationOptions:
    """``evaluation``: the EvaluationOptions of every cell."""
    if not isinstance(raw, Mapping):
        raise ConfigError(f"{path}: 'evaluation' must be a mapping")
    try:
        return EvaluationOptions(**raw)
    except (TypeError, ConfigError) as exc:
        raise ConfigError(f"{path}: evaluation: {exc}") from None


def _check_labels(
    datasets: list[dict[str, object]],
    estimators: list[dict[str, object]],
    overrides: list[Override],
    path: Path,
) -> None:
    """Every estimator an override or a dataset names is in the grid, every prior map comes
    from another estimator's label, every estimator is available."""
    names = {str(e["estimator"]) for e in estimators} | {str(e["label"]) for e in estimators}
    labels = {str(e["label"]) for e in estimators}
    for i, (_, only) in enumerate(overrides):
        if only and not only <= names:
            raise ConfigError(
                f"{path}: overrides[{i}]: estimators {sorted(only - names)} are not in the grid"
            )
    for i, entry in enumerate(datasets):
        only = set(entry["estimators"] or ())  # type: ignore[arg-type]
        if not only <= labels:
            raise ConfigError(
                f"{path}: datasets[{i}]: estimators {sorted(only - labels)} are not in the grid"
            )
    for i, entry in enumerate(estimators):
        if entry["external"] is not None:
            continue
        source = entry["prior_from"]
        if source is not None and (source not in labels or source == entry["label"]):
            raise ConfigError(
                f"{path}: estimators[{i}]: prior_map from {source!r}: no other estimator of "
                f"the grid has that label (labels: {', '.join(sorted(labels))})"
            )
        try:
            check_estimator(str(entry["estimator"]))
        except ConfigError as exc:
            raise ConfigError(f"{path}: {exc}") from None


def _cells(
    datasets: list[_Dataset],
    estimators: list[dict[str, object]],
    overrides: list[Override],
    seeds: list[int],
    path: Path,
) -> list[Cell]:
    """Every (dataset, estimator, override, seed) cell, in that order; ids must be unique."""
    cells: list[Cell] = []
    for dataset in datasets:
        for estimator in estimators:
            name, e_label = str(estimator["estimator"]), str(estimator["label"])
            if dataset.estimators is not None and e_label not in dataset.estimators:
                continue
            applicable = [
                options for options, only in overrides if only is None or {name, e_label} & only
            ] or [{}]
            if estimator["external"] is not None:
                applicable = [{}]  # results read from files: no option changes them
            for override in applicable:
                o_label = ",".join(f"{k}={v}" for k, v in sorted(override.items()))
                options = {**dataset.options, **estimator["options"], **override}
                if dataset.renders is not None:
                    runs = list(dataset.renders.items())
                else:
                    own = estimator["seeds"] or seeds
                    if not _seed_dependent(estimator, options, estimators):
                        own = own[:1]
                    runs = [(seed, (dataset.argument, None)) for seed in own]
                for seed, (argument, render) in runs:
                    cell_id = _cell_id(dataset.label, e_label, seed, o_label)
                    external = (
                        None
                        if estimator["external"] is None
                        else _external_result(estimator, dataset.label, seed, path)
                    )
                    cells.append(
                        Cell(
                            cell_id,
                            dataset.label,
                            e_label,
                            o_label,
                            RunSpec(argument, name, seed, options),
                            render,
                            estimator["prior_from"],  # a label until resolved below
                            external,
                        )
                    )
    ids = [c.cell_id for c in cells]
    duplicates = sorted({i for i in ids if ids.count(i) > 1})
    if duplicates:
        raise ConfigError(f"{path}: cells with the same id {duplicates} (give them labels)")
    return cells


def _seed_dependent(
    estimator: Mapping[str, object],
    options: Mapping[str, str],
    estimators: list[dict[str, object]],
) -> bool:
    """Whether a run of ``estimator`` on data on disk changes with the seed.

    It does when the estimator draws from its generator (``EstimatorEntry.stochastic``), when
    the harness draws with it (``wrong_id_fraction`` or ``clutter_per_frame`` set), or when its
    prior map comes from a cell that does; otherwise every seed would repeat the same run.
    """
    from omnislam.estimators import ESTIMATORS

    entry = ESTIMATORS.get(str(estimator["estimator"]))
    if entry is None or entry.stochastic:
        return True
    if any(_nonzero(options.get(key)) for key in (WRONG_ID_OPTION, CLUTTER_OPTION)):
        return True
    source = next((e for e in estimators if e["label"] == estimator["prior_from"]), None)
    return source is not None and source is not estimator and _seed_dependent(
        source, {**options, **source["options"]}, estimators
    )


def _nonzero(text: str | None) -> bool:
    """An option value that is set and not zero (an unparsable one counts as set)."""
    if text is None:
        return False
    try:
        return float(text) != 0.0
    except ValueError:
        return True


def _check_specs(cells: list[Cell], path: Path) -> None:
    """Every cell's options, before any work starts (each distinct run once)."""
    checked: set[tuple[str, str, tuple[tuple[str, str], ...]]] = set()
    for cell in cells:
        key = (cell.spec.dataset, cell.spec.estimator, tuple(sorted(cell.spec.options.items())))
        if key in checked or cell.external is not None:  # external: files checked when read
            continue
        checked.add(key)
        try:
            check_spec(cell.spec, rendered=cell.render is None)
        except OmnislamError as exc:
            raise ConfigError(f"{path}: cell {cell.cell_id}: {exc}") from None


def _cell_id(dataset: str, estimator: str, seed: int, override: str) -> str:
    return "__".join(
        [safe_name(dataset), safe_name(estimator), f"s{seed}"]
        + ([safe_name(override)] if override else [])
    )


def _link_prior_maps(cells: list[Cell], path: Path) -> list[Cell]:
    """Turn each ``prior_from`` label into the id of the cell whose map it reads: that estimator
    on the same dataset with the same seed, the same override if it has one, else none."""
    by_key = {(c.dataset_label, c.estimator_label, c.spec.seed, c.override_label): c for c in cells}
    out = []
    for cell in cells:
        if cell.prior_from is None:
            out.append(cell)
            continue
        source = by_key.get(
            (cell.dataset_label, cell.prior_from, cell.spec.seed, cell.override_label)
        ) or by_key.get((cell.dataset_label, cell.prior_from, cell.spec.seed, ""))
        if source is None:
            raise ConfigError(
                f"{path}: cell {cell.cell_id}: prior_map from {cell.prior_from!r}, which has no "
                f"cell on {cell.dataset_label} with seed {cell.spec.seed}"
            )
        if source.prior_from is not None:
            raise ConfigError(
                f"{path}: cell {cell.cell_id}: prior_map from {source.cell_id}, which itself "
                "reads another cell's map (one level only)"
            )
        out.append(replace(cell, prior_from=source.cell_id))
    return out


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
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: cannot read the grid file (not a text file)") from None
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
  # - {{synthetic: lab40, seeds: [0, 1, 2]}}   # a preset rendered on demand, once per seed,
                                #   into the cache; every estimator runs on each seed's world
                                #   with that seed (`images: N` stops after N images)
  # - {{dataset: victoria-park, estimators: [deadreckoning, fs1]}}   # only these run on it

estimators:                     # names from `omnislam estimators`, with their --set options
  - deadreckoning               #   (the baseline; not ranked in the verdict)
  - graphslam
  - {{estimator: fastslam1, label: fs1, options: {{resampling.scheme: stratified}}}}
  - ekfslam
  # - {{estimator: ukf, label: ukf-on-graph, options: {{prior_map: {{from: graphslam}}}}}}
                                #   a localiser in the map of the graphslam cell of the same
                                #   dataset and seed (computed first; recomputed with it)
  # - {{estimator: fastslam2, seeds: [0, 1, 2, 3, 4]}}   # its own seeds instead of the grid's
  # - {{estimator: external, label: mysys, files: "mysys/{{dataset}}/{{seed}}.tum"}}
                                #   another system's results (TUM or KITTI; `landmarks:` an
                                #   id,x,y,z CSV), scored and ranked beside the others

seeds: [0, 1, 2]                # one run per seed (default [0]); the verdict uses their spread
                                #   (a deterministic estimator runs once on data on disk)

overrides:                      # option sets: an estimator they apply to runs once per
  - {{particles.n_particles: 30, estimators: [fs1]}}    #   override (on top of its own options)
  - {{particles.n_particles: 300, estimators: [fs1]}}   #   instead of once; `estimators` limits
  # - {{wrong_id_fraction: 0.05}}                       #   where one applies (names or labels);
  # - {{clutter_per_frame: 0.5}}                        #   harness options apply to all (false
                                                      #   detections per frame, without ids)

evaluation:                     # how every cell is scored (optional)
{evaluation_text}
"""


def check_datasets(grid: Grid) -> None:
    """Load every dataset on disk of ``grid`` once, before a results folder is written.

    ``parse_grid`` found each dataset's files; this reads them, so that a corrupt file is bad
    input of ``omnislam compare`` (one line, exit code 2, no results folder) rather than a
    failed cell in every column of its row. Synthetic presets (``Cell.render``) are skipped:
    they are rendered later, by the runner. Each dataset is loaded with the loader options of
    its first cell (options choose how the files are read, not which). The loaders' warnings
    are left to the cells, which load the datasets again.

    Raises:
        DataError: naming the dataset's malformed file (and line).
    """
    import logging

    from omnislam._progress import Progress
    from omnislam.datasets.registry import load_dataset, resolve

    first: dict[str, Cell] = {}
    for cell in grid.cells:
        if cell.render is None:
            first.setdefault(cell.spec.dataset, cell)
    if not first:
        return
    loaders = logging.getLogger("omnislam.datasets")
    level = loaders.level
    loaders.setLevel(logging.ERROR)
    try:
        with Progress(f"compare: checking {len(first)} dataset(s)") as progress:
            for dataset, cell in first.items():
                progress.update(doing=dataset)
                resolved = resolve(dataset)
                names = resolved.option_names()
                load_dataset(resolved, {k: v for k, v in cell.spec.options.items() if k in names})
    finally:
        loaders.setLevel(level)
