"""How a report was made: omnislam version and commit, date, command line, machine.

``provenance_rows`` is the report's provenance block: those, the results folder and its grid,
the omnislam versions that made the runs, the seeds, each dataset (source, frames, images, path
length, loader options) and each estimator column's options. Everything here is best effort and
never raises: a value that cannot be found is "unknown".
"""

from __future__ import annotations

import datetime
import hashlib
import os
import platform
import shlex
import subprocess
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from omnislam.errors import OmnislamError
from omnislam.harness.layout import GRID_COPY
from omnislam.harness.rundir import RunConfig, read_run_config, read_run_dir
from omnislam.report.options import ReportOptions
from omnislam.report.results import BASELINE, ReportCell, columns

UNKNOWN = "unknown"


def package_commit(source: Path | None = None) -> str:
    """``git rev-parse HEAD`` of the folder holding the omnislam package when that folder is a
    git checkout (" (uncommitted changes)" appended when tracked files differ), else "unknown".
    """
    try:
        if source is None:
            source = Path(__file__).resolve().parents[2]  # omnislam/report/provenance.py
        if not (source / ".git").exists():
            return UNKNOWN
        head = subprocess.run(
            ["git", "-C", str(source), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        ).stdout.strip()
        if len(head) != 40:
            return UNKNOWN
        dirty = subprocess.run(
            ["git", "-C", str(source), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=10,
        )
        if dirty.returncode == 0 and dirty.stdout.strip():
            return head + " (uncommitted changes)"
        return head
    except Exception:
        return UNKNOWN


def cpu_model(cpuinfo: Path = Path("/proc/cpuinfo")) -> str:
    """The CPU model from /proc/cpuinfo when present, else platform's guess, else "unknown"."""
    try:
        for line in cpuinfo.read_text(errors="replace").splitlines():
            key, _, value = line.partition(":")
            if (
                key.strip() in ("model name", "Hardware", "Processor", "cpu model")
                and value.strip()
            ):
                return value.strip()
    except OSError:
        pass
    try:
        return platform.processor() or platform.machine() or UNKNOWN
    except Exception:
        return UNKNOWN


def file_digest(path: Path) -> str | None:
    """First 12 hex digits of the file's SHA-256 (None when unreadable)."""
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()[:12]
    except OSError:
        return None


def path_length_m(positions: np.ndarray) -> float:
    """Length of a polyline of positions [m] (NaN rows skipped)."""
    p = np.asarray(positions, dtype=float)
    p = p[np.all(np.isfinite(p), axis=1)]
    if len(p) < 2:
        return 0.0
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


@dataclass(frozen=True, slots=True)
class Machine:
    cpu: str
    cores: int | None
    python: str
    platform: str


def machine() -> Machine:
    try:
        plat = platform.platform()
    except Exception:
        plat = UNKNOWN
    return Machine(cpu_model(), os.cpu_count(), platform.python_version(), plat)


def now_utc() -> str:
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")


def shown_path(path: str | Path, cwd: Path | None = None, cache: Path | None = None) -> str:
    """A path as a report shows it, without this machine's folders: relative to the working
    folder when inside it, ``$OMNISLAM_CACHE/...`` when inside the cache, else ``.../NAME``
    (its last component); a relative path or a registered dataset name as given.

    Args:
        path: the path (or any string: only absolute paths are rewritten).
        cwd: the working folder (default: the current one).
        cache: the cache folder (default: ``harness.cache.cache_dir()``).
    """
    text = str(path)
    if not os.path.isabs(text):
        return text
    try:
        from omnislam.harness.cache import CACHE_ENV, cache_dir

        resolved = Path(text).resolve()
        for base, prefix in (
            ((cwd or Path.cwd()).resolve(), ""),
            ((cache or cache_dir()).resolve(), f"${CACHE_ENV}/"),
        ):
            if resolved == base or base in resolved.parents:
                relative = resolved.relative_to(base).as_posix()
                return f"{prefix}{relative}" if prefix or relative != "." else "."
        return f".../{resolved.name}"
    except Exception:
        return f".../{Path(text).name}"


def command_line(argv: Sequence[str] | None = None) -> str:
    """``argv`` (default ``sys.argv``) as a shell-quoted line, absolute paths as
    ``shown_path`` shows them."""
    args = list(sys.argv if argv is None else argv)
    try:
        return shlex.join(shown_path(a) for a in args) if args else UNKNOWN
    except Exception:
        return UNKNOWN


def _config(cell: ReportCell) -> RunConfig | None:
    try:
        return read_run_config(cell.run_dir) if cell.run_dir is not None else None
    except OmnislamError:
        return None


def _dataset_source(config: RunConfig) -> str:
    """The dataset a run was given and who to credit: a registered name with its citation, a
    path as the run describes it ("a folder in MR.CLAM format at PATH", crediting no one; a
    synthetic preset with its seed), paths as ``shown_path`` shows them."""
    from omnislam.datasets.registry import REGISTRY

    shown = shown_path(config.dataset)
    if not config.source:
        return shown
    if config.dataset in REGISTRY:
        return f"{config.dataset}: {config.source}"
    if config.dataset_path and config.dataset_path in config.source:
        return config.source.replace(config.dataset_path, shown_path(config.dataset_path))
    return f"{shown} ({config.source})"


def _options_text(options: Mapping[str, str]) -> str:
    return ", ".join(f"{k}={v}" for k, v in sorted(options.items())) or "defaults"


def _images_text(configs: Sequence[RunConfig]) -> str:
    """The camera images of a dataset's runs ("unknown" for runs that predate the count)."""
    counts = sorted({cfg.images for cfg in configs if cfg.images is not None})
    if not counts:
        return UNKNOWN
    return ", ".join(map(str, counts))


def _path_length(cells: Sequence[ReportCell]) -> str:
    """Path length of the dataset's ground truth, else of dead reckoning."""
    ok = sorted((c for c in cells if c.ok), key=lambda c: (c.seed is None, c.seed or 0))
    if not ok:
        return UNKNOWN
    try:
        record = read_run_dir(ok[0].run_dir)  # type: ignore[arg-type]
        truth = record.ground_truth.trajectory
        if truth is not None and len(truth) > 1:
            return f"{path_length_m(truth.positions_w):.1f} m (ground truth)"
        dead = [c for c in ok if c.estimator == BASELINE]
        if dead:
            estimate = read_run_dir(dead[0].run_dir).estimate.trajectory  # type: ignore[arg-type]
            return f"{path_length_m(estimate.positions_w):.1f} m (dead reckoning)"
    except OmnislamError:
        return UNKNOWN
    return "unknown (no ground truth, no dead-reckoning run)"


def provenance_rows(
    results_dir: Path, title: str, cells: Sequence[ReportCell], options: ReportOptions
) -> list[tuple[str, str]]:
    """(field, value) of the provenance block; never raises."""
    from omnislam._version import __version__

    rows = [
        ("omnislam version", __version__),
        ("git commit", package_commit()),
        ("date (UTC)", now_utc()),
        ("command line", command_line(options.command)),
        ("results", shown_path(Path(results_dir).resolve())),
    ]
    grid = Path(results_dir) / GRID_COPY
    if grid.is_file():
        digest = file_digest(grid)
        rows.append(
            (
                "grid",
                f"{shown_path(grid.resolve())} ({title!r}"
                + (f", sha256 {digest})" if digest else ")"),
            )
        )
    configs = {c.cell_id: _config(c) for c in cells}
    made_with = sorted({cfg.omnislam_version for cfg in configs.values() if cfg is not None})
    if made_with:
        rows.append(("runs made with omnislam", ", ".join(made_with)))
    seeds = sorted({c.seed for c in cells if c.seed is not None})
    rows.append(("seeds", ", ".join(map(str, seeds)) if seeds else "none given"))
    ok, failed = sum(c.ok for c in cells), sum(not c.ok for c in cells)
    rows.append(("runs", f"{ok} successful" + (f", {failed} failed" if failed else "")))
    for dataset in dict.fromkeys(c.dataset for c in cells):
        group = [c for c in cells if c.dataset == dataset]
        group_configs = [configs[c.cell_id] for c in group if configs[c.cell_id] is not None]
        frames = sorted({cfg.frames for cfg in group_configs})  # type: ignore[union-attr]
        source = _dataset_source(group_configs[0]) if group_configs else UNKNOWN  # type: ignore[arg-type]
        text = f"{source}; frames {', '.join(map(str, frames)) or UNKNOWN}"
        text += f"; images {_images_text(group_configs)}"
        text += f"; path length {_path_length(group)}"
        loader = {_options_text(cfg.dataset_options) for cfg in group_configs}  # type: ignore[union-attr]
        if loader - {"defaults"}:
            text += f"; loader options {' / '.join(sorted(loader))}"
        rows.append((f"dataset {dataset}", text))
    for column in columns(cells):
        group = [c for c in cells if c.column == column]
        group_configs = [configs[c.cell_id] for c in group if configs[c.cell_id] is not None]
        estimator = group[0].estimator
        external = sorted({cfg.external for cfg in group_configs if cfg.external})  # type: ignore[union-attr]
        if external:  # another system's results (harness.external)
            rows.append((f"estimator {column}", " / ".join(external)))
            continue
        chosen = sorted({_options_text(cfg.estimator_options) for cfg in group_configs})  # type: ignore[union-attr]
        rows.append(
            (f"estimator {column}", f"{estimator}; options: {' / '.join(chosen) or 'unknown'}")
        )
    host = machine()
    rows.append(
        (
            "machine",
            f"{host.cpu}; {host.cores or UNKNOWN} cores (os.cpu_count); "
            f"Python {host.python}; {host.platform}",
        )
    )
    return rows
