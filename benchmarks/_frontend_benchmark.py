"""Benchmark of the shared front end: speed and quality against the renderer's ground truth.

Usage (render the datasets first with ``omnislam dataset synth PRESET --out DIR``):

    .venv/bin/python benchmarks/frontend.py --dataset runs/lab40 [--images N] \
        [--repeat 3] [--sequential] [--unverified] [--variants] [--corridor DIR] [--real] \
        [--json results.json]
    .venv/bin/python benchmarks/frontend.py --dataset runs/lab40 --log LOG  # quality only
    .venv/bin/python benchmarks/frontend.py --dataset runs/lab40 --config budget.yaml  # overrides

Reports, on the synthetic omni dataset, with the default configuration (vertical edges on, as
``omnislam frontend`` runs; no laser):

- speed of the whole image loop (load, SIFT, groups, vertical edges, matching, verification,
  tracks), pipelined as ``omnislam frontend`` runs it: images/s wall-clock and CPU ms per
  image (this process and its worker processes, every thread), and wall and CPU ms per image
  of every stage (the preparation's stages in the workers, each CPU figure its own
  process's), medians of ``--repeat`` runs, with the machine's load average; for reference,
  omnislam's SIFT alone (with and without its compiled kernels) and bare OpenCV SIFT
  (``cv2.SIFT_create()`` defaults: a measure of the host's speed that does not change with
  omnislam's code); ``--sequential``: one run without the workers;
- quality: track precision (two sightings of one track see true points within 5 cm; without
  geometric verification too with ``--unverified``); tracks kept, median verified sightings
  per image, median track length; re-association after a return (>= 60 s); the landmark
  error the bearings allow (every consistent track of >= 3 sightings triangulated from the
  true poses: median, 90th percentile, RMS, and for tracks with >= 3 deg of parallax); the
  bearings' noise ratio (``evaluation.noise_ratio``: RMS residual / logged sigma, 1 =
  calibrated);
- ``--variants``: the same quality and CPU figures (per stage) for the scale-space choices of
  ``SiftConfig.first_octave`` (doubled with OpenCV's default upscale, doubled with the exact
  one, native, halved, none), for native with 2 layers per octave, without the keypoint budget
  (``SiftConfig.features_per_kpx``) or with it going to the whole ring's strongest instead of
  being shared out over rings x sectors, and for the general
  8-point RANSAC instead of the planar one, sequentially, one run each (``--variant NAME``
  picks some; ``--repeat 0`` runs only them);
and optionally vertical-edge recall / bearing error on corridor21 and verified matches per
image pair on the real OCamCalib VMR lab images.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from omnislam._files import read_yaml
from omnislam._optional import require
from omnislam.datasets.synthetic.loader import SyntheticFolder, load_synthetic
from omnislam.frontend import evaluation
from omnislam.frontend.config import (
    FirstOctave,
    FrontendConfig,
    LaserLandmarkConfig,
    VerificationConfig,
    VerticalEdgeConfig,
    frontend_config_from_dict,
)
from omnislam.frontend.observation_log import load_observation_log
from omnislam.frontend.pipeline import run_frontend
from omnislam.frontend.scale_space import use_kernels
from omnislam.frontend.sift import SiftExtractor, detection_mask
from omnislam.frontend.vertical_edges import extract_vertical_lines

STAGES = ("load", "extract", "group", "vertical_edges", "match", "match_map", "verify", "track",
          "map")
#: parallax above which a triangulated landmark counts as constrained [rad]
PARALLAX_RAD = np.deg2rad(3.0)


def variants(config: FrontendConfig) -> dict[str, FrontendConfig]:
    """The scale-space choices measured side by side (``SiftConfig.first_octave``)."""
    sift = config.sift
    return {
        "doubled, OpenCV's default upscale": dataclasses.replace(config, sift=dataclasses.replace(
            sift, first_octave=FirstOctave.DOUBLED, precise_upscale=False)),
        "doubled, exact upscale": dataclasses.replace(config, sift=dataclasses.replace(
            sift, first_octave=FirstOctave.DOUBLED, precise_upscale=True)),
        "native (default)": dataclasses.replace(config, sift=dataclasses.replace(
            sift, first_octave=FirstOctave.NATIVE)),
        "halved": dataclasses.replace(config, sift=dataclasses.replace(
            sift, first_octave=FirstOctave.HALVED)),
        "none": dataclasses.replace(config, sift=dataclasses.replace(
            sift, first_octave=FirstOctave.NONE)),
        "native, 2 layers per octave": dataclasses.replace(config, sift=dataclasses.replace(
            sift, first_octave=FirstOctave.NATIVE, n_octave_layers=2)),
        "native, no keypoint budget": dataclasses.replace(
            config, sift=dataclasses.replace(sift, first_octave=FirstOctave.NATIVE,
                                             features_per_kpx=0.0)),
        "native, budget to the whole ring's strongest": dataclasses.replace(
            config, sift=dataclasses.replace(sift, first_octave=FirstOctave.NATIVE,
                                             budget_bands=1, budget_sectors=1)),
        "native, 8-point RANSAC": dataclasses.replace(config, verification=dataclasses.replace(
            config.verification, planar_motion=False)),
    }


class Truth:
    """The renderer's world point of every pixel, per frame (cached)."""

    def __init__(self, folder: SyntheticFolder) -> None:
        self.folder = folder
        self._cache: dict[int, np.ndarray] = {}

    def __call__(self, i: int) -> np.ndarray:
        if i not in self._cache:
            self._cache[i] = self.folder.ground_truth_maps(i).points_w
        return self._cache[i]


def quality(log, sequence, truth: Truth) -> dict[str, float]:
    s = evaluation.true_sightings(log, truth)
    precision, pairs = evaluation.track_precision(s)
    rate, returns = evaluation.reassociation_rate(s)
    wTr = truth.folder.groundtruth.poses_w
    viewpoint = sequence.calibration.viewpoint_r
    tri = evaluation.triangulation_errors(log, s, wTr, viewpoint)
    wide = tri.parallax_rad >= PARALLAX_RAD
    res = evaluation.bearing_residuals(log, s, wTr, viewpoint)
    return {
        "track_precision": precision,
        "pairs": pairs,
        "tracks": int(evaluation.track_lengths(log).size),
        "sightings_per_image_median": float(np.median(evaluation.sightings_per_image(log))),
        "track_length_median": float(np.median(evaluation.track_lengths(log))),
        "reassociated_after_return": rate,
        "returns": returns,
        "triangulated_tracks": int(tri.error_m.size),
        "triangulation_error_median_cm": 100 * float(np.median(tri.error_m)),
        "triangulation_error_p90_cm": 100 * float(np.percentile(tri.error_m, 90)),
        "triangulation_error_rms_cm": 100 * float(np.sqrt(np.mean(tri.error_m**2))),
        "triangulated_tracks_3deg": int(wide.sum()),
        "triangulation_error_3deg_median_cm": 100 * float(np.median(tri.error_m[wide])),
        "triangulation_error_3deg_p90_cm": 100 * float(np.percentile(tri.error_m[wide], 90)),
        "bearing_noise_ratio": evaluation.noise_ratio(res),
        "bearing_noise_ratio_median": evaluation.noise_ratio_median(res),
    }


def per_stage(log) -> dict[str, float]:
    """Wall and CPU ms per image of every stage (CPU exact for a sequential run)."""
    images = max(log.stats["images_processed"], 1.0)
    out = {}
    for k in STAGES:
        out[f"ms_{k}"] = 1e3 * log.stats.get(f"seconds_{k}", 0.0) / images
        out[f"cpu_ms_{k}"] = 1e3 * log.stats.get(f"cpu_seconds_{k}", 0.0) / images
    return out


def totals(log) -> dict[str, float]:
    images = max(log.stats["images_processed"], 1.0)
    wall = log.stats["seconds_images_total"]
    result = {"images": int(images), "seconds_wall": wall,
              "images_per_s_wall": images / wall,
              "cpu_ms_per_image": 1e3 * log.stats["cpu_seconds_images_total"] / images}
    if "seconds_workers_start" in log.stats:  # pipelined: until the workers were up
        result["seconds_workers_start"] = log.stats["seconds_workers_start"]
        result["images_prepared_here"] = images - log.stats["images_prepared_in_workers"]
    return result


def sift_alone(sequence, frames: np.ndarray, config: FrontendConfig) -> dict[str, float]:
    """ms per image of SIFT alone on the same images (a load reference for this machine)."""
    camera = sequence.calibration.camera
    mask = detection_mask(camera.mask(), (camera.height, camera.width))
    extractor = SiftExtractor(config.sift)
    images = [sequence.image(int(i)) for i in frames]
    extractor.extract(images[0], mask)  # loads the compiled kernels (numba) outside the clock
    start, cpu = time.perf_counter(), time.process_time()
    for image in images:
        extractor.extract(image, mask)
    result = {"ms_sift_alone": 1e3 * (time.perf_counter() - start) / len(images),
              "cpu_ms_sift_alone": 1e3 * (time.process_time() - cpu) / len(images)}
    # the same without the compiled kernels (numpy / OpenCV path: the same features)
    previous = use_kernels(False)
    try:
        start, cpu = time.perf_counter(), time.process_time()
        for image in images:
            extractor.extract(image, mask)
        result |= {"ms_sift_alone_numpy": 1e3 * (time.perf_counter() - start) / len(images),
                   "cpu_ms_sift_alone_numpy": 1e3 * (time.process_time() - cpu) / len(images)}
    finally:
        use_kernels(previous)
    # bare OpenCV SIFT (its defaults, doubled first octave, OpenCV's threads) on the same
    # images: a reference of the host's speed that does not change with omnislam's code (~68 ms
    # per lab40 image with 2 threads on the reference host)
    cv2 = require("cv2")
    sift = cv2.SIFT_create()
    greys = [cv2.cvtColor(image, cv2.COLOR_RGB2GRAY) for image in images]
    start, cpu = time.perf_counter(), time.process_time()
    for grey in greys:
        sift.detectAndCompute(grey, mask)
    return result | {"ms_opencv_sift": 1e3 * (time.perf_counter() - start) / len(images),
                     "cpu_ms_opencv_sift": 1e3 * (time.process_time() - cpu) / len(images)}


def vertical_edges(path: Path) -> dict[str, float]:
    sequence = load_synthetic(path)
    folder = SyntheticFolder(path)
    lines_w = np.array([(v.x_m, v.y_m) for v in folder.world.vertical_lines])
    config = VerticalEdgeConfig(enabled=True)
    errors, per_image, seconds = [], [], 0.0
    for i in sequence.image_frames:
        image = sequence.image(i)
        start = time.perf_counter()
        lines = extract_vertical_lines(image, sequence.calibration, config)
        seconds += time.perf_counter() - start
        per_image.append(len(lines))
        truth = evaluation.visible_line_bearings(lines_w, folder.groundtruth.poses_w[i],
                                                 sequence.calibration,
                                                 folder.ground_truth_maps(i).points_w)
        errors.append(evaluation.bearing_errors(lines.bearings_rad, truth))
    e = np.concatenate(errors)
    found = e < np.deg2rad(1.0)
    return {
        "door_frame_edges_in_view": int(e.size),
        "detected_fraction": float(found.mean()),
        "bearing_error_median_deg": float(np.rad2deg(np.median(e[found]))),
        "lines_per_image_median": float(np.median(per_image)),
        "ms_per_image": 1e3 * seconds / len(per_image),
    }


def real_pairs() -> list[dict[str, int]]:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "frontend"))
    from test_real_images import verified_matches_per_pair

    return [{"ratio_test": m, "verified_essential": e, "verified_rotation": r}
            for m, e, r in verified_matches_per_pair(pairs=None)]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", required=True, type=Path, help="synthetic omni folder")
    parser.add_argument("--images", type=int, default=None, help="process the first N images")
    parser.add_argument("--repeat", type=int, default=3,
                        help="pipelined speed runs (median); 0: no speed or default-quality runs")
    parser.add_argument("--variants", action="store_true", help="scale-space choices table")
    parser.add_argument("--variant", action="append", default=None, metavar="NAME",
                        help="with --variants: only these (repeatable); with --repeat 0 only "
                             "the variants run")
    parser.add_argument("--speed-only", action="store_true",
                        help="no quality figures after the speed runs")
    parser.add_argument("--sequential", action="store_true",
                        help="also one run without the worker processes")
    parser.add_argument("--unverified", action="store_true",
                        help="also the quality without geometric verification")
    parser.add_argument("--log", type=Path, default=None,
                        help="only the quality of this log of the dataset (no speed runs)")
    parser.add_argument("--corridor", type=Path, help="corridor21 folder (vertical edges)")
    parser.add_argument("--real", action="store_true", help="real VMR lab image pairs")
    parser.add_argument("--json", type=Path, help="write the results here")
    parser.add_argument("--config", type=Path, default=None,
                        help="YAML of front-end overrides (as `omnislam frontend --config`), "
                             "e.g. `sift: {features_per_kpx: 1.2}` for the keypoint budget")
    args = parser.parse_args()

    sequence = load_synthetic(args.dataset)
    truth = Truth(SyntheticFolder(args.dataset))
    config = FrontendConfig(laser=LaserLandmarkConfig(enabled=False))
    if args.config is not None:
        overrides = read_yaml(args.config) or {}
        config = frontend_config_from_dict({**overrides, "laser": {"enabled": False}})
    results: dict[str, object] = {"dataset": str(args.dataset), "images": args.images,
                                  "cpus": os.cpu_count(), "load_average_before": os.getloadavg()}
    if args.log is not None:  # the quality of a log written before (omnislam frontend / run)
        results["log"] = str(args.log)
        results["verified"] = quality(load_observation_log(args.log), sequence, truth)
    elif args.repeat > 0:
        runs = []
        for _ in range(args.repeat):
            log = run_frontend(sequence, config, max_images=args.images, progress=True,
                               pipelined=True)
            runs.append(totals(log) | per_stage(log))
        results["pipelined"] = {k: float(np.median([r[k] for r in runs])) for k in runs[0]}
        results["pipelined_runs"] = runs
        frames = log.image_frames
        results["sift_alone"] = sift_alone(sequence, frames[: min(30, frames.size)], config)
        if args.sequential:
            sequential = run_frontend(sequence, config, max_images=args.images, progress=True,
                                      pipelined=False)
            results["sequential"] = totals(sequential) | per_stage(sequential)
        results["load_average_after_speed"] = os.getloadavg()
        if not args.speed_only:
            results["verified"] = quality(log, sequence, truth)
        if args.unverified:
            unverified = dataclasses.replace(config,
                                             verification=VerificationConfig(enabled=False))
            results["unverified"] = quality(run_frontend(sequence, unverified,
                                                         max_images=args.images, progress=True),
                                            sequence, truth)
    if args.variants:
        table = {}
        for name, variant in variants(config).items():
            if args.variant and name not in args.variant:
                continue
            run = run_frontend(sequence, variant, max_images=args.images, progress=True,
                               pipelined=False)
            cpu = {k: v for k, v in per_stage(run).items() if k.startswith("cpu_ms_")}
            table[name] = totals(run) | cpu | quality(run, sequence, truth)
        results["variants"] = table
    if args.corridor:
        results["vertical_edges"] = vertical_edges(args.corridor)
    if args.real:
        results["real_vmr_pairs"] = real_pairs()
    results["load_average_after"] = os.getloadavg()
    text = json.dumps(results, indent=2)
    print(text)
    if args.json:
        args.json.write_text(text + "\n")
    return 0

