"""The graph at real-time cost: iSAM2 replaying a cached front-end log, timed, with its accuracy.

For each dataset (``lab40`` by default; ``demo`` and ``loop150`` with ``--dataset``) the script
takes a rendered folder (rendering the preset into it first when it is missing), the shared
front end's log (``--dataset NAME DIR LOG``, or the one ``harness.execute.frontend_log_for``
computes once and caches), and replays the log ``--runs`` times through each graph variant and
once through the other estimators. The replay mirrors ``omnislam run`` (``harness.execute``:
same loading, registry, SequenceInfo and ground truth) with one addition: every step is timed
in CPU time (``time.process_time``: all threads of the process) beside wall-clock, because on a
shared 2-core machine wall-clock mostly measures the neighbours.

Printed per variant (medians over the runs): wall and CPU seconds of the replay including the
final ``estimate()``, ATE (SE(2)-aligned, cm), landmark RMSE and median against the true points
of the front end's tracks (by id, cm), landmarks estimated, peak RSS of the process (MB), and the
per-step flatness: the 95th percentile of the CPU time of the *image* steps over images 100-200
and over the last 100 images, and their ratio (goal <= 2). Dead reckoning's ATE is printed
beside. After the bar: ATE and landmark median with a similarity alignment (SIM3, its scale):
bearings carry no scale, so the graph's scale is the odometry's, and a systematic wheel-scale
error (the synthetic presets' realistic odometry) shows as a scale, not as a graph error.
``--frames N`` replays only the first N frames (to compare the slow variants on a
prefix)::

    .venv/bin/python benchmarks/realtime_lab40.py --runs 3
    .venv/bin/python benchmarks/realtime_lab40.py --dataset lab40 runs/lab40 LOG \\
        --dataset demo runs/demo/demo-seed0 --dataset loop150 runs/loop150 \\
        --runs 3 --others
    .venv/bin/python benchmarks/realtime_lab40.py --frames 1000 --variants all

Variants (``--variants``, comma-separated, or ``all``): ``default`` (the estimator's defaults),
``images`` (a pose per image, every track), ``images-budget`` (a pose per image, 40 landmarks
per image), ``spacing`` (key frames 0.2 m apart, every track), ``frames`` (a pose per
odometry step, every track), ``batch`` (``graphslam-batch`` with the defaults),
``whole`` (iSAM2 over the whole graph at every key frame instead of the default fixed-lag
smoother), ``wheel-scale`` (the odometry's scale, without the floor points'), ``online-scale``
(each odometry factor at the floor scale known when it was added, also in the final estimate),
``raw-pairs-scale`` (the final floor scale from the floor pairs over the raw odometry, not
re-estimated over the graph's trajectory),
``true-scale`` (the odometry at its true scale from the first frame, computed from the ground
truth: a diagnostic of how much of the error is the floor scale's), ``lm-tight`` (the final LM
run to a relative error decrease of 1e-10 instead of the default 1e-6).
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from harness_cells import add_set_option, set_options

from omnislam.core.se import se2_between
from omnislam.core.sequence_info import SequenceInfo
from omnislam.core.types import Trajectory
from omnislam.datasets.registry import load_dataset
from omnislam.estimators import make_estimator
from omnislam.harness.cache import cache_dir
from omnislam.harness.execute import frontend_log_for, peak_rss_mb, reset_peak_rss
from omnislam.harness.frames import (
    frames_for_estimator,
    load_log,
    own_sighting_ids,
    sequence_info,
)
from omnislam.harness.layout import LOGS
from omnislam.harness.track_truth import with_track_truth
from omnislam.metrics.landmarks import LandmarkAssociation, landmark_error
from omnislam.metrics.trajectory import Alignment, ate

#: the option the ``true-scale`` variant sets to the truth's scale
TRUE_SCALE_OPTION = "floor.known_odometry_scale"
#: graph variants: label -> (estimator, --set options)
VARIANTS: dict[str, tuple[str, dict[str, str]]] = {
    "default": ("graphslam", {}),
    "images": (
        "graphslam",
        {"poses.keyframe_spacing_m": "0", "landmarks.per_image": "0"},
    ),
    "images-budget": (
        "graphslam",
        {"poses.keyframe_spacing_m": "0", "landmarks.per_image": "40"},
    ),
    "spacing": ("graphslam", {"landmarks.per_image": "0"}),
    "frames": (
        "graphslam",
        {
            "poses.pose_variables": "frames",
            "poses.keyframe_spacing_m": "0",
            "landmarks.per_image": "0",
        },
    ),
    "batch": ("graphslam-batch", {}),
    "whole": ("graphslam", {"solver.online_lag_key_frames": "none"}),
    "wheel-scale": ("graphslam", {"floor.scale": "false"}),
    "online-scale": ("graphslam", {"floor.scale_final": "false"}),
    "raw-pairs-scale": ("graphslam", {"floor.scale_refine": "false"}),
    # the odometry's true translation scale from the first frame (a diagnostic: the graph's
    # error without the floor scale's; ``true_odometry_scale``)
    "true-scale": ("graphslam", {"floor.known_odometry_scale": "truth"}),
    # the final LM solved to a relative error decrease of 1e-10 (the default: 1e-6)
    "lm-tight": ("graphslam", {"batch.relative_error_tol": "1e-10"}),
}
#: the other estimators timed on the same log (omni options as in benchmarks/fastslam_lab40.py)
#: (EKF-SLAM and the UKF take their default streams: on a synthetic log EKF-SLAM the poles'
#: range-bearing sightings, the UKF localiser the vertical lines in the world's prior map)
OTHERS: dict[str, tuple[str, dict[str, str]]] = {
    "deadreckoning": ("deadreckoning", {}),
    "fastslam1": ("fastslam1", {"modality": "bearings-3d"}),
    "fastslam2": ("fastslam2", {"modality": "bearings-3d"}),
    "ekfslam": ("ekfslam", {}),
    "ukf": ("ukf", {}),
}
#: the flatness windows: image steps [100, 200) against the last 100
EARLY = slice(100, 200)
LATE = 100


@dataclass(frozen=True, slots=True)
class Replay:
    """One dataset ready to replay: its frames, the estimators' SequenceInfo, ground truth."""

    name: str
    frames: list
    info: SequenceInfo
    truth: object
    images: np.ndarray  # (N,) bool: frame carries bearings
    floor_ids_from: int | None  # the log's floor tracks (``ObservationLog.floor_ids_from``)


@dataclass(frozen=True, slots=True)
class Result:
    """One replay: times, accuracy, size, flatness."""

    wall_s: float
    cpu_s: float
    ate_cm: float
    landmark_rmse_cm: float | None
    landmark_median_cm: float | None
    ate_sim3_cm: float
    scale: float
    landmark_median_sim3_cm: float | None
    landmark_rmse_sim3_cm: float | None
    landmarks: int
    peak_rss_mb: float
    p95_early_ms: float | None
    p95_late_ms: float | None


def prepare(name: str, folder: str, log: str | None, frames: int | None) -> Replay:
    """Render the preset into ``folder`` if missing, get its log, load everything once."""
    path = Path(folder)
    if not (path / "meta.json").is_file():
        from omnislam.datasets.synthetic import cli_synth

        print(f"rendering {name} into {path} ...", file=sys.stderr, flush=True)
        render = argparse.Namespace(preset=name, out=str(path), seed=0, frames=None, backend=None)
        cli_synth(render)  # what `omnislam dataset synth NAME --out DIR` runs
    sequence = load_dataset(str(path))
    if log is None:
        log = str(frontend_log_for(sequence, str(path), cache_dir() / LOGS, progress=True))
    replay = load_log(sequence, log)
    inputs = own_sighting_ids(sequence, list(sequence.frame_inputs(replay.frames)), log)
    if frames is not None:
        inputs = inputs[:frames]
    truth, _ = with_track_truth(sequence, replay, Path(log))
    info = sequence_info(sequence, inputs)  # what `omnislam run` tells the estimator
    images = np.array([f.bearings is not None and len(f.bearings) > 0 for f in inputs])
    return Replay(name, inputs, info, truth, images, replay.floor_ids_from)


def true_odometry_scale(data: Replay) -> float:
    """What the wheel odometry's translations must be multiplied by to be true: the distance
    truly driven over the distance the odometry says (lab40: 1 / 1.0092; the steps' own
    direction noise is not scale)."""
    true = data.truth.trajectory.se2
    logged = np.array([f.odometry.delta[:2] for f in data.frames[1:]])
    steps = se2_between(true[:-1], true[1:])[:, :2]
    return float(np.hypot(*steps.T).sum() / np.hypot(*logged.T).sum())


def _p95_ms(values: np.ndarray) -> float | None:
    return float(np.percentile(values, 95) * 1e3) if len(values) else None


def replay_once(data: Replay, estimator_name: str, options: dict[str, str], seed: int) -> Result:
    """Build the estimator through the registry and feed it every frame, timing each step."""
    reset_peak_rss()
    frames = frames_for_estimator(estimator_name, data.frames, data.floor_ids_from)
    estimator = make_estimator(estimator_name, data.info, options, np.random.default_rng(seed))
    cpu = np.zeros(len(frames))
    process, clock = time.process_time, time.perf_counter
    wall0, cpu0 = clock(), process()
    for i, frame in enumerate(frames):
        start = process()
        estimator.step(frame)
        cpu[i] = process() - start
    estimate = estimator.estimate()
    wall_s, cpu_s = clock() - wall0, process() - cpu0
    truth = data.truth.trajectory
    keep = np.isin(truth.stamps_s, estimate.trajectory.stamps_s)
    truth = Trajectory(truth.stamps_s[keep], truth.poses_w[keep])
    result = ate(estimate.trajectory, truth)
    similar = ate(estimate.trajectory, truth, Alignment.SIM3)
    lm_rmse = lm_median = lm_median_sim3 = lm_rmse_sim3 = None
    if len(estimate.landmark_ids):
        lm, lm_sim3 = (
            landmark_error(
                estimate.landmark_ids,
                estimate.landmarks_w,
                data.truth.landmark_ids,
                data.truth.landmarks_w,
                aligned.gtTest,
                LandmarkAssociation.BY_ID,
            )
            for aligned in (result, similar)
        )
        if lm.matched:
            lm_rmse, lm_median = lm.rmse_m * 100, lm.median_m * 100
            lm_rmse_sim3, lm_median_sim3 = lm_sim3.rmse_m * 100, lm_sim3.median_m * 100
    image_cpu = cpu[data.images]
    late = image_cpu[-LATE:] if len(image_cpu) > EARLY.stop else image_cpu[:0]
    return Result(
        wall_s=wall_s,
        cpu_s=cpu_s,
        ate_cm=result.rmse_m * 100,
        landmark_rmse_cm=lm_rmse,
        landmark_median_cm=lm_median,
        ate_sim3_cm=similar.rmse_m * 100,
        scale=similar.scale,
        landmark_median_sim3_cm=lm_median_sim3,
        landmark_rmse_sim3_cm=lm_rmse_sim3,
        landmarks=len(estimate.landmark_ids),
        peak_rss_mb=peak_rss_mb(),
        p95_early_ms=_p95_ms(image_cpu[EARLY]),
        p95_late_ms=_p95_ms(late),
    )


def _median(values: list[float | None]) -> float | None:
    kept = [v for v in values if v is not None]
    return float(np.median(kept)) if kept else None


def _fmt(value: float | None, width: int, digits: int) -> str:
    return f"{'-':>{width}s}" if value is None else f"{value:{width}.{digits}f}"


HEADER = (
    f"{'dataset':8s} {'variant':14s} {'runs':>4s} {'wall [s]':>8s} {'CPU [s]':>8s} "
    f"{'ATE [cm]':>8s} {'lm RMSE':>7s} {'lm med':>6s} {'lms':>5s} {'RSS MB':>6s} "
    f"{'p95 100-200':>11s} {'p95 last':>8s} {'ratio':>5s} | {'ATE sim3':>8s} {'scale':>6s} "
    f"{'lm RMSE/med sim3':>16s}"
)


def report(dataset: str, label: str, results: list[Result]) -> None:
    """One line of medians over the runs."""
    early = _median([r.p95_early_ms for r in results])
    late = _median([r.p95_late_ms for r in results])
    ratio = late / early if early and late else None
    print(
        f"{dataset:8s} {label:14s} {len(results):4d} "
        f"{_median([r.wall_s for r in results]):8.2f} {_median([r.cpu_s for r in results]):8.2f} "
        f"{_median([r.ate_cm for r in results]):8.2f} "
        f"{_fmt(_median([r.landmark_rmse_cm for r in results]), 7, 2)} "
        f"{_fmt(_median([r.landmark_median_cm for r in results]), 6, 2)} "
        f"{int(np.median([r.landmarks for r in results])):5d} "
        f"{_median([r.peak_rss_mb for r in results]):6.0f} "
        f"{_fmt(early, 11, 1)} {_fmt(late, 8, 1)} {_fmt(ratio, 5, 2)} | "
        f"{_median([r.ate_sim3_cm for r in results]):8.2f} "
        f"{_median([r.scale for r in results]):6.4f} "
        f"{_fmt(_median([r.landmark_rmse_sim3_cm for r in results]), 8, 2)}/"
        f"{_fmt(_median([r.landmark_median_sim3_cm for r in results]), 7, 2)}",
        flush=True,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--dataset",
        nargs="+",
        action="append",
        metavar="NAME DIR [LOG]",
        help="preset name, its rendered folder (rendered when missing) and optionally its "
        "front-end log (default: lab40 runs/lab40, log cached)",
    )
    parser.add_argument("--runs", type=int, default=3, help="replays per graph variant")
    parser.add_argument("--frames", type=int, default=None, help="replay only the first N")
    parser.add_argument("--variants", default="default", help="comma-separated, or 'all'")
    parser.add_argument("--others", action="store_true", help="also " + ", ".join(OTHERS))
    parser.add_argument("--seed", type=int, default=0)
    add_set_option(parser, "extra graph option for every graph variant (repeatable)")
    args = parser.parse_args()
    datasets = args.dataset or [["lab40", "runs/lab40"]]
    names = list(VARIANTS) if args.variants == "all" else args.variants.split(",")
    unknown = [n for n in names if n not in VARIANTS]
    if unknown:
        parser.error(f"unknown variants {unknown}; known: {', '.join(VARIANTS)}")
    extra = set_options(parser, args.options)
    print(HEADER)
    for entry in datasets:
        if len(entry) not in (2, 3):
            parser.error("--dataset takes NAME DIR [LOG]")
        name, folder, log = entry[0], entry[1], entry[2] if len(entry) == 3 else None
        data = prepare(name, folder, log, args.frames)
        for label in names:
            estimator, options = VARIANTS[label]
            if options.get(TRUE_SCALE_OPTION) == "truth":
                options = {**options, TRUE_SCALE_OPTION: repr(true_odometry_scale(data))}
                print(f"{name}: the odometry's true scale {options[TRUE_SCALE_OPTION]}",
                      file=sys.stderr)
            results = [
                replay_once(data, estimator, {**options, **extra}, args.seed)
                for _ in range(args.runs)
            ]
            report(name, label, results)
        if args.others:
            for label, (estimator, options) in OTHERS.items():
                report(name, label, [replay_once(data, estimator, options, args.seed)])
        else:
            estimator, options = OTHERS["deadreckoning"]
            report(name, "deadreckoning", [replay_once(data, estimator, options, args.seed)])


if __name__ == "__main__":
    main()
