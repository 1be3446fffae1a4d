"""Benchmark of the shared front end: speed and quality against the renderer's ground truth.

Usage (render the datasets first with ``omnislam dataset synth PRESET --out DIR``):

    .venv/bin/python benchmarks/frontend.py --dataset /tmp/lab40 [--images N] \
        [--corridor /tmp/corridor21] [--real] [--json results.json]

Reports, on the synthetic omni dataset:
- images/s of the whole front end (extract, group, match, verify, track, map), with the
  per-stage breakdown in ms per image, and SIFT alone on the same images for reference;
- track precision (two sightings of one track see true points within 5 cm) with and without
  geometric verification, side by side; median verified sightings per image; median track
  length; the fraction of landmarks visible again after a return (>= 60 s) that keep their
  original track id;
and optionally vertical-edge recall / bearing error on corridor21 and verified matches per
image pair on the real OCamCalib VMR lab images.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

from omnislam.datasets.synthetic.loader import SyntheticFolder, load_synthetic
from omnislam.frontend import evaluation
from omnislam.frontend.config import (
    FrontendConfig,
    LaserLandmarkConfig,
    VerificationConfig,
    VerticalEdgeConfig,
)
from omnislam.frontend.pipeline import run_frontend
from omnislam.frontend.sift import SiftExtractor, detection_mask
from omnislam.frontend.vertical_edges import extract_vertical_lines

STAGES = ("extract", "group", "match", "verify", "track", "map")


def quality(log, folder: SyntheticFolder) -> dict[str, float]:
    cache: dict[int, np.ndarray] = {}

    def points_w_of(i: int) -> np.ndarray:
        if i not in cache:
            cache[i] = folder.ground_truth_maps(i).points_w
        return cache[i]

    s = evaluation.true_sightings(log, points_w_of)
    precision, pairs = evaluation.track_precision(s)
    rate, returns = evaluation.reassociation_rate(s)
    return {
        "track_precision": precision,
        "pairs": pairs,
        "sightings_per_image_median": float(np.median(evaluation.sightings_per_image(log))),
        "track_length_median": float(np.median(evaluation.track_lengths(log))),
        "tracks": int(evaluation.track_lengths(log).size),
        "reassociated_after_return": rate,
        "returns": returns,
    }


def speed(log) -> dict[str, float]:
    images = max(log.stats["images_processed"], 1.0)
    ms = {k: 1e3 * log.stats.get(f"seconds_{k}", 0.0) / images for k in STAGES}
    total = sum(ms.values())
    return {"ms_per_image": total, "images_per_s": 1e3 / total,
            **{f"ms_{k}": v for k, v in ms.items()}}


def sift_alone(sequence, frames: np.ndarray, config: FrontendConfig) -> float:
    """ms per image of SIFT alone on the same images (a load reference for this machine)."""
    camera = sequence.calibration.camera
    mask = detection_mask(camera.mask(), (camera.height, camera.width))
    extractor = SiftExtractor(config.sift)
    images = [sequence.image(int(i)) for i in frames]
    start = time.perf_counter()
    for image in images:
        extractor.extract(image, mask)
    return 1e3 * (time.perf_counter() - start) / len(images)


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
    parser.add_argument("--corridor", type=Path, help="corridor21 folder (vertical edges)")
    parser.add_argument("--real", action="store_true", help="real VMR lab image pairs")
    parser.add_argument("--json", type=Path, help="write the results here")
    args = parser.parse_args()

    sequence = load_synthetic(args.dataset)
    folder = SyntheticFolder(args.dataset)
    config = FrontendConfig(laser=LaserLandmarkConfig(enabled=False))
    results: dict[str, object] = {"dataset": str(args.dataset), "images": args.images}
    log = run_frontend(sequence, config, max_images=args.images, progress=True)
    results["speed"] = speed(log)
    frames = log.image_frames
    results["speed"]["ms_sift_alone"] = sift_alone(sequence, frames[: min(30, frames.size)],
                                                   config)
    results["verified"] = quality(log, folder)
    unverified = dataclasses.replace(config, verification=VerificationConfig(enabled=False))
    results["unverified"] = quality(run_frontend(sequence, unverified, max_images=args.images,
                                                 progress=True), folder)
    if args.corridor:
        results["vertical_edges"] = vertical_edges(args.corridor)
    if args.real:
        results["real_vmr_pairs"] = real_pairs()
    text = json.dumps(results, indent=2)
    print(text)
    if args.json:
        args.json.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
