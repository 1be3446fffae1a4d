"""Score a run against its ground truth, or trajectory files against a reference (--ref).

With a RUN_DIR: every metric against the run's ground truth; writes RUN_DIR/metrics.json (null
for what is not computed or has no ground truth) and prints a table, or the JSON with --json.
Every value that is missing says why. A metrics.json computed with other settings
(--rpe-segment, --landmark-gate) is replaced only with --overwrite.

With --ref GT EST [EST ...] (TUM or KITTI files, detected from the number of values per line,
or --format): trajectories from anywhere, as evo_ape and evo_rpe compare them, several
estimates in one table as evo_res shows them. Each estimate is aligned to the reference by
--align: none, origin (first pose anchored; evo's --align_origin), se2 (rotation about z and
x-y translation; evo's -a on planar runs), se3 (evo's -a) or sim3 (evo's -as); then ATE
(position error statistics) and RPE (translation and rotation over segments of --rpe-segment
metres of reference travel, all start poses: evo's --all_pairs --pairs_from_reference --delta M
--delta_unit m; and between consecutive poses: --delta 1 --delta_unit f). Nothing is written
unless --out.

--plot FILE.svg (or .pdf, .png) draws, in either form, the top view of the reference and of
each estimate after its alignment (a RUN_DIR's: se2) and each estimate's translation error over
time.

The RPE segment defaults to 10 m, or to a quarter of the ground truth's travel (rounded down to
1-2-5) when the run travels less than 40 m.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "evaluate",
        help="metrics of a run against its ground truth, or of two trajectory files (--ref)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "paths",
        nargs="+",
        metavar="RUN_DIR | EST",
        help="folder written by `omnislam run`; with --ref, one or more estimated trajectory "
        "files",
    )
    p.add_argument(
        "--ref", default=None, metavar="GT", help="reference trajectory file (TUM or KITTI)"
    )
    p.add_argument(
        "--format",
        choices=("auto", "tum", "kitti"),
        default="auto",
        help="trajectory file format with --ref (default: detected)",
    )
    p.add_argument(
        "--align",
        choices=("none", "origin", "se2", "se3", "sim3"),
        default="se2",
        help="alignment of the estimate with --ref (default se2)",
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument(
        "--rpe-segment",
        type=float,
        default=None,
        metavar="M",
        help="RPE segment length [m] (default: 10 m, shorter for runs under 40 m)",
    )
    p.add_argument(
        "--landmark-gate",
        type=float,
        default=None,
        metavar="M",
        help="landmark association gate for maps without true ids [m]",
    )
    p.add_argument(
        "--out", default=None, metavar="FILE.json", help="with --ref: write the numbers as JSON"
    )
    p.add_argument(
        "--plot",
        default=None,
        metavar="FILE.svg",
        help="draw the aligned trajectories and the translation error over time (.svg, .pdf "
        "or .png)",
    )
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace a metrics.json of other settings (or the file of --out or --plot)",
    )
    p.set_defaults(handler=run)


def _fmt(value: object) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def run(args: argparse.Namespace) -> int:
    from omnislam._files import check_output_location, check_overwrite
    from omnislam.errors import ConfigError
    from omnislam.harness.evaluation import EvaluationOptions
    from omnislam.report.trajectory_figure import plot_format

    EvaluationOptions(rpe_segment_m=args.rpe_segment)  # the one check of its value
    if args.plot is not None:  # before any work
        plot_format(args.plot)
        check_overwrite(args.plot, args.overwrite, "plot")
        check_output_location(args.plot, "plot")
    if args.ref is not None:
        return run_ref(args)
    for flag, given in (
        ("--format", args.format != "auto"),
        ("--align", args.align != "se2"),
        ("--out", args.out is not None),
    ):
        if given:
            raise ConfigError(f"{flag} applies to --ref GT EST; a RUN_DIR is SE(2)-aligned")
    if len(args.paths) > 1:
        raise ConfigError(
            f"one RUN_DIR at a time, got {len(args.paths)} (several trajectory files are "
            "scored against one reference with --ref GT EST1 EST2 ...)"
        )
    return run_run_dir(args)


def run_run_dir(args: argparse.Namespace) -> int:
    import json
    from pathlib import Path

    from omnislam._files import atomic_write_bytes
    from omnislam.errors import ConfigError, DataError
    from omnislam.harness.evaluation import EvaluationOptions, evaluate_run
    from omnislam.harness.layout import METRICS
    from omnislam.harness.rundir import read_run_dir
    from omnislam.metrics.run_metrics import read_run_metrics, write_run_metrics

    defaults = EvaluationOptions()
    options = EvaluationOptions(
        rpe_segment_m=args.rpe_segment,
        landmark_gate_m=(
            defaults.landmark_gate_m if args.landmark_gate is None else args.landmark_gate
        ),
    )
    path = Path(args.paths[0])
    if not path.is_dir():
        raise DataError("no such RUN_DIR", path)
    record = read_run_dir(path)
    metrics = evaluate_run(record, options)
    figure = None if args.plot is None else _run_dir_figure(record, path, args)
    if (path / METRICS).is_file() and not args.overwrite:
        try:
            old = read_run_metrics(path / METRICS)
        except DataError:
            old = None  # unreadable or of an older layout: nothing to keep
        if old is not None and _settings(old) != _settings(metrics):
            raise ConfigError(
                f"{path / METRICS}: the metrics exist with other settings "
                f"({_describe(_settings(old))}, now {_describe(_settings(metrics))}); pass "
                "--overwrite to replace them"
            )
    write_run_metrics(path / METRICS, metrics)
    if figure is not None:
        atomic_write_bytes(args.plot, figure)
    if args.json:
        print(json.dumps(metrics.to_json(), indent=2))
        return 0
    _print_run_metrics(record, metrics, args)
    print(f"-> {path / METRICS}" + (f" and {args.plot}" if figure is not None else ""))
    return 0


def _print_run_metrics(record: Any, metrics: Any, args: argparse.Namespace) -> None:
    """The table of ``evaluate RUN_DIR``: one line per metric, what is missing and why."""
    from omnislam.harness.evaluation import missing_reasons

    config = record.config
    why = missing_reasons(metrics)
    print(f"{config.estimator} on {config.dataset} ({config.frames} frames)")
    if metrics.ate.rmse_m is None:
        print(
            f"no ground truth ({record.ground_truth.kind.value}): "
            f"{record.ground_truth.note or 'nothing to compare against'}"
        )
    else:
        kind, note = record.ground_truth.kind.value, record.ground_truth.note
        # notes usually begin with their kind ("exact: the renderer's own poses ...")
        print(f"ground truth: {note if note.startswith(kind) else f'{kind}: {note}'}")
    ate, rpe, landmarks, timing = metrics.ate, metrics.rpe, metrics.landmarks, metrics.timing
    segment = "" if rpe.segment_m is None else f"{rpe.segment_m:g} m "
    rows: list[tuple[str, object, str | None]] = [
        ("ATE RMSE, SE(2) aligned [m]", ate.rmse_m, "ate"),
        ("ATE max, SE(2) aligned [m]", ate.max_m, "ate"),
        ("ATE RMSE, origin aligned [m]", ate.origin_rmse_m, "ate"),
        ("ATE max, origin aligned [m]", ate.origin_max_m, "ate"),
        (
            "poses compared / coverage",
            None
            if ate.matched is None or ate.coverage is None
            else f"{ate.matched} / {ate.coverage:.1%}",
            "ate",
        ),
        (f"RPE {segment}trans RMSE [m]", rpe.trans_rmse_m, "rpe"),
        (
            f"RPE {segment}rot RMSE [deg]",
            rpe.rot_rmse_deg,
            "rpe_rot" if "rpe_rot" in why else "rpe",
        ),
        ("landmark RMSE [m]", landmarks.rmse_m, "landmarks"),
        (
            "landmarks estimated / matched / true",
            f"{landmarks.estimated} / {_fmt(landmarks.matched)} / {_fmt(landmarks.truth)}",
            None,
        ),
        ("pose NEES mean (dof 3 when consistent)", metrics.nees.pose_mean, "pose_nees"),
        ("landmark NEES mean", metrics.nees.landmark_mean, "landmark_nees"),
        (
            "step median / p95 [ms]",
            f"{_fmt(timing.step_median_ms)} / {_fmt(timing.step_p95_ms)}",
            None,
        ),
        ("total [s]", timing.total_s, None),
        ("peak RSS [MB]", timing.peak_rss_mb, None),
    ]
    width = max(len(name) for name, _, _ in rows)
    for name, value, reason in rows:
        text = _fmt(value)
        if value is None and reason in why:
            text += f"  ({why[reason]})"
        print(f"  {name.ljust(width)}  {text}")
    if rpe.segment_m is not None and args.rpe_segment is None and rpe.travel_m is not None:
        print(
            f"  (RPE segment {rpe.segment_m:g} m chosen for a run of {rpe.travel_m:.3g} m; "
            "set it with --rpe-segment)"
        )


def _run_dir_figure(record: Any, path: Path, args: argparse.Namespace) -> bytes:
    """The ``--plot`` figure of a RUN_DIR: its estimate, SE(2)-aligned, against its ground truth.

    Raises:
        ConfigError: the run has no ground truth to draw against.
    """
    from omnislam.errors import ConfigError
    from omnislam.harness.evaluation import compare_trajectories
    from omnislam.metrics.trajectory import Alignment
    from omnislam.report.trajectory_figure import plot_format, trajectory_figure

    truth = record.ground_truth.trajectory
    if truth is None:
        raise ConfigError(f"{path}: --plot needs ground truth, and this run has none")
    result = compare_trajectories(
        truth, record.estimate.trajectory, Alignment.SE2, args.rpe_segment
    )
    label = record.config.estimator
    return trajectory_figure(
        truth.positions_w[:, :2],
        [_plotted(label, result)],
        plot_format(args.plot),
        f"{label} on {record.config.dataset}, aligned se2",
    )


def _plotted(label: str, result: Any) -> Any:
    """An estimate of the figure: its aligned positions and its ATE errors over time."""
    from omnislam.report.trajectory_figure import PlottedEstimate

    return PlottedEstimate(
        label,
        result.aligned.positions_w[:, :2],
        result.ate.stamps_s,
        result.ate.errors_m,
    )


def _settings(metrics: object) -> tuple[float | None, float | None]:
    """The evaluation settings a RunMetrics was computed with (RPE segment, landmark gate)."""
    return metrics.rpe.segment_m, metrics.landmarks.gate_m  # type: ignore[attr-defined]


def _describe(settings: tuple[float | None, float | None]) -> str:
    segment, gate = settings
    return f"RPE segment {_fmt(segment)} m, landmark gate {_fmt(gate)} m"


def run_ref(args: argparse.Namespace) -> int:
    """``evaluate --ref GT EST [EST ...]``: ATE and RPE of trajectory files, as evo computes
    them; one estimate as a list of statistics, several as one table (evo_res's)."""
    import json
    from pathlib import Path

    from omnislam._files import (
        atomic_write_bytes,
        atomic_write_text,
        check_output_location,
        check_overwrite,
    )
    from omnislam.errors import ConfigError
    from omnislam.harness.evaluation import compare_trajectories
    from omnislam.metrics.trajectory import Alignment

    if args.landmark_gate is not None:
        raise ConfigError("--landmark-gate applies to a RUN_DIR (trajectory files have no map)")
    reference_path, estimate_paths = Path(args.ref), [Path(p) for p in args.paths]
    if args.out is not None:
        check_overwrite(args.out, args.overwrite, "metrics file")
        check_output_location(args.out, "metrics file")
    fmt, reference, estimates = _read_trajectories(reference_path, estimate_paths, args.format)
    alignment = Alignment(args.align)
    results = [compare_trajectories(reference, e, alignment, args.rpe_segment) for e in estimates]
    numbers = [
        {"estimate": str(path), **_ref_numbers(result)}
        for path, result in zip(estimate_paths, results, strict=True)
    ]
    head = {"reference": str(reference_path), "format": fmt, "alignment": alignment.value}
    document = {**head, **numbers[0]} if len(numbers) == 1 else {**head, "estimates": numbers}
    figure = None
    if args.plot is not None:  # made before anything is written
        figure = _ref_figure(reference, estimate_paths, results, args, f"{reference_path}")
    if args.out is not None:
        atomic_write_text(args.out, json.dumps(document, indent=2) + "\n")
    if figure is not None:
        atomic_write_bytes(args.plot, figure)
    if args.json:
        print(json.dumps(document, indent=2))
        return 0
    if len(results) == 1:
        what = f"{estimate_paths[0]} against {reference_path} ({fmt})"
        _print_ref(results[0], {**head, **numbers[0]}, what, args)
    else:
        _print_ref_table(results, numbers, f"against {reference_path} ({fmt})", args)
    for written in (args.out, args.plot):
        if written is not None:
            print(f"-> {written}")
    return 0


def _read_trajectories(
    reference_path: Path, estimate_paths: list[Path], fmt: str
) -> tuple[str, Any, list[Any]]:
    """(format, reference, estimates): trajectory files of one format (``--format``, or
    detected from each file).

    Raises:
        ConfigError: an estimate of another format than the reference, or one given twice.
    """
    from omnislam.datasets.trajectory_io import detect_trajectory_format, read_trajectory
    from omnislam.errors import ConfigError

    seen: set[str] = set()
    for path in estimate_paths:
        if str(path) in seen:
            raise ConfigError(f"{path}: estimate given twice")
        seen.add(str(path))
    paths = [reference_path, *estimate_paths]
    formats = [detect_trajectory_format(p) if fmt == "auto" else fmt for p in paths]
    for path, other in zip(estimate_paths, formats[1:], strict=True):
        if other != formats[0]:
            raise ConfigError(
                f"{path}: a {other} file against a {formats[0]} reference "
                f"({reference_path}); give every file in one format (KITTI files have no stamps)"
            )
    trajectories = [read_trajectory(p, formats[0]) for p in paths]
    return formats[0], trajectories[0], trajectories[1:]


def _ref_figure(
    reference: Any, paths: list[Path], results: list[Any], args: argparse.Namespace, what: str
) -> bytes:
    """The ``--plot`` figure of ``--ref``: every estimate, aligned, against the reference."""
    from omnislam.report.trajectory_figure import plot_format, trajectory_figure

    return trajectory_figure(
        reference.positions_w[:, :2],
        [_plotted(str(p), r) for p, r in zip(paths, results, strict=True)],
        plot_format(args.plot),
        f"against {what}, aligned {args.align}",
    )


def _print_ref_table(
    results: list[Any], numbers: list[dict[str, Any]], what: str, args: argparse.Namespace
) -> None:
    """Several estimates against one reference: one row each (evo_res's table)."""
    import math

    segment = f"{results[0].rpe.delta:g} m"
    header = (
        "estimate", "poses", "coverage", "ATE rmse", "mean", "median", "std", "min", "max",
        f"RPE {segment} trans rmse", "rot rmse [deg]",
    )  # fmt: skip
    rows = []
    for result, row in zip(results, numbers, strict=True):
        ate = row["ate_m"]
        rows.append(
            (
                row["estimate"],
                str(result.ate.matched),
                f"{result.ate.coverage:.1%}",
                *(_fmt(ate[key]) for key in ("rmse", "mean", "median", "std", "min", "max")),
                _fmt(row["rpe_trans_m"]["rmse"]),
                _fmt(row["rpe_rot_deg"]["rmse"]),
            )
        )
    print(f"{len(results)} estimates {what}, aligned {args.align}; ATE and RPE in metres")
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
    for line in (header, *rows):
        print("  " + "  ".join(c.ljust(w) for c, w in zip(line, widths, strict=True)).rstrip())
    for row in numbers:
        if "rpe" in row["missing"]:
            print(f"  {row['estimate']}: RPE -: {row['missing']['rpe']}")
    if args.rpe_segment is None and math.isfinite(results[0].travel_m):
        print(
            f"  (RPE segment {segment} chosen for a reference of {results[0].travel_m:.3g} m; "
            "set it with --rpe-segment)"
        )


def _ref_numbers(result: Any) -> dict[str, object]:
    """The numbers of ``evaluate --ref`` (``harness.evaluation.compare_trajectories``): ATE and
    RPE error statistics, pairs, travel and why what is missing is missing."""
    ate, rpe, frame = result.ate, result.rpe, result.rpe_frame
    return {
        "scale": ate.scale,
        "poses_matched": ate.matched,
        "coverage": ate.coverage,
        "ate_m": _stats(ate.errors_m),
        "rpe_segment_m": rpe.delta,
        "rpe_pairs": rpe.count,
        "rpe_trans_m": _stats(rpe.trans_errors_m),
        "rpe_rot_deg": _stats(_degrees(rpe.rot_errors_rad)),
        "rpe_frame_pairs": frame.count,
        "rpe_frame_trans_m": _stats(frame.trans_errors_m),
        "rpe_frame_rot_deg": _stats(_degrees(frame.rot_errors_rad)),
        "travel_m": result.travel_m,
        "planar": rpe.planar,
        "missing": result.why,
    }


def _stats(values: object) -> dict[str, float | None]:
    """RMSE, mean, median, std, min and max of the values (all None when there are none)."""
    import numpy as np

    x = np.asarray(values, dtype=float)
    if not x.size:
        return dict.fromkeys(("rmse", "mean", "median", "std", "min", "max"))
    return {
        "rmse": float(np.sqrt(np.mean(x**2))),
        "mean": float(np.mean(x)),
        "median": float(np.median(x)),
        "std": float(np.std(x)),
        "min": float(np.min(x)),
        "max": float(np.max(x)),
    }


def _degrees(radians: object) -> object:
    """The angles in degrees ([] for None: no rotation errors)."""
    import numpy as np

    return [] if radians is None else np.degrees(np.asarray(radians, dtype=float))


def _print_ref(result: Any, numbers: dict[str, Any], what: str, args: argparse.Namespace) -> None:
    """The table of ``evaluate --ref``: one line per statistic, what is missing and why."""
    import math

    from omnislam.metrics.trajectory import Alignment

    ate, rpe, frame = result.ate, result.rpe, result.rpe_frame
    alignment = Alignment(args.align)
    print(
        f"{what}: {ate.matched} poses matched ({ate.coverage:.1%} of the estimate), aligned "
        f"{alignment.value}" + (f", scale {ate.scale:.6g}" if alignment is Alignment.SIM3 else "")
    )
    width = 34

    def row(name: str, values: dict[str, float | None], why: str | None = None) -> None:
        if values["rmse"] is None:
            print(f"  {name.ljust(width)}  -" + (f"  ({why})" if why else ""))
            return
        text = "  ".join(
            f"{key} {value:.6g}" for key, value in values.items() if value is not None
        )
        print(f"  {name.ljust(width)}  {text}")

    row("ATE [m]", numbers["ate_m"])
    segment = f"{rpe.delta:g} m"
    why_not = result.why.get("rpe")
    row(f"RPE {segment} trans [m] ({rpe.count} pairs)", numbers["rpe_trans_m"], why_not)
    row(f"RPE {segment} rot [deg]", numbers["rpe_rot_deg"], why_not)
    row(f"RPE 1 frame trans [m] ({frame.count} pairs)", numbers["rpe_frame_trans_m"])
    row("RPE 1 frame rot [deg]", numbers["rpe_frame_rot_deg"])
    if args.rpe_segment is None and math.isfinite(result.travel_m):
        print(
            f"  (RPE segment {rpe.delta:g} m chosen for a reference of {result.travel_m:.3g} m; "
            "set it with --rpe-segment)"
        )
