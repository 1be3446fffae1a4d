"""How precise are the front end's bearings? Keypoint localisation against the renderer's truth.

Runs the front end on a synthetic render and, for every sighting of a consistent track (all
its sightings see true points within 5 cm of their median), measures

* the pixel residual: the keypoint against the projection of the track's true point (the mean
  of its sightings' true points) from the true pose, per keypoint size (SIFT's diameter,
  2 sigma): the data of ``TrackConfig``'s pixel-noise model ``sigma_px = a + b * size``, fitted
  here by least squares on the per-size RMS;
* the angular residual against the log's own sigma: ``evaluation.noise_ratio`` (1 =
  calibrated, RMS over all but the 1 % largest) and ``noise_ratio_median``.

Residual variances are corrected for the true point being the mean of the track's own n
sightings (factor n / (n - 1)).

    .venv/bin/python benchmarks/bearing_noise.py --dataset runs/lab40 \
        [--images N] [--set tracks.sigma_px=1.0 ...]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

from omnislam.datasets.synthetic.loader import SyntheticFolder, load_synthetic
from omnislam.frontend import evaluation
from omnislam.frontend.config import FrontendConfig, LaserLandmarkConfig, VerticalEdgeConfig
from omnislam.frontend.pipeline import run_frontend
from omnislam.frontend.sift import SiftExtractor, detection_mask

#: keypoint-size bins [px] of the table
SIZE_EDGES = (0.0, 2.5, 3.2, 4.0, 5.0, 6.5, 8.5, 11.0, 15.0, 25.0, 200.0)
#: the largest normalised residuals left out of RMS figures (gross errors)
TRIM = 0.01


def _override(config: FrontendConfig, assignment: str) -> FrontendConfig:
    """``section.field=value`` (value parsed as JSON) on the front-end config.

    Raises:
        ValueError: a malformed assignment, a value that is not JSON or an unknown setting.
    """
    key, sep, value = assignment.partition("=")
    section, dot, field = key.partition(".")
    if not sep or not dot or not section or not field:
        raise ValueError(f"--set takes SECTION.FIELD=JSON, got {assignment!r}")
    try:
        parsed = json.loads(value)
    except json.JSONDecodeError:
        raise ValueError(f"--set {key}: {value!r} is not JSON") from None
    part = getattr(config, section, None)
    if not dataclasses.is_dataclass(part) or field not in {
        f.name for f in dataclasses.fields(part)
    }:
        raise ValueError(f"--set {key}: no such front-end setting")
    return dataclasses.replace(config, **{section: dataclasses.replace(part, **{field: parsed})})


def keypoint_sizes(sequence, log, config: FrontendConfig) -> list[np.ndarray | None]:
    """The SIFT size of every logged sighting (re-extracted; extraction is deterministic)."""
    camera = sequence.calibration.camera
    mask = detection_mask(camera.mask(), (camera.height, camera.width))
    extractor = SiftExtractor(config.sift)
    out: list[np.ndarray | None] = []
    for frame, px in zip(log.frames, log.pixels, strict=True):
        if frame.bearings is None or px is None:
            out.append(None)
            continue
        features = extractor.extract(sequence.image(frame.index), mask)
        lookup = {tuple(p): k for k, p in enumerate(features.pixels.tolist())}
        out.append(features.sizes_px[[lookup[tuple(p)] for p in px.tolist()]])
    return out


def pixel_residuals(log, s, sizes, folder: SyntheticFolder, rig):
    """(K, 2) keypoint minus projected true point [px], (K,) sizes, (K,) dof factors."""
    flat_sizes = np.concatenate([z for z in sizes if z is not None and z.size])
    flat_px = np.concatenate([p for f, p in zip(log.frames, log.pixels, strict=True)
                              if f.bearings is not None and p is not None and len(p)])
    known = np.flatnonzero(np.all(np.isfinite(s.points_w), axis=1))
    order = known[np.argsort(s.track[known], kind="stable")]
    bounds = np.flatnonzero(np.diff(s.track[order])) + 1
    wTr = folder.groundtruth.poses_w
    residual, size, dof = [], [], []
    for rows in np.split(order, bounds):
        p = s.points_w[rows]
        if rows.size < 2 or np.any(np.linalg.norm(p - np.median(p, axis=0), axis=1) > 0.05):
            continue
        centre = p.mean(axis=0)
        pose = wTr[s.frame[rows]]
        point_r = np.einsum("nji,nj->ni", pose[:, :3, :3], centre - pose[:, :3, 3])
        projected, valid = rig.project_r(point_r)
        residual.append((flat_px[rows] - projected)[valid])
        size.append(flat_sizes[rows][valid])
        dof.append(np.full(int(valid.sum()), rows.size / (rows.size - 1.0)))
    return np.concatenate(residual), np.concatenate(size), np.concatenate(dof)


def trimmed_rms(values: np.ndarray, dof: np.ndarray) -> float:
    """Per-axis RMS of (K, 2) residuals without the ``TRIM`` largest (dof-corrected)."""
    r2 = dof * np.sum(values**2, axis=1)
    r2 = np.sort(r2)[: max(1, int(np.ceil((1 - TRIM) * r2.size)))]
    return float(np.sqrt(np.mean(r2) / 2.0))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", required=True, type=Path, help="synthetic omni folder")
    parser.add_argument("--images", type=int, default=None, help="process the first N images")
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.FIELD=JSON",
                        help="override a front-end setting, e.g. tracks.sigma_px=1.0")
    parser.add_argument("--json", type=Path, help="write the results here")
    args = parser.parse_args()

    config = FrontendConfig(laser=LaserLandmarkConfig(enabled=False),
                            vertical_edges=VerticalEdgeConfig(enabled=False))
    for assignment in args.set:
        try:
            config = _override(config, assignment)
        except ValueError as error:
            parser.error(str(error))
    sequence = load_synthetic(args.dataset)
    folder = SyntheticFolder(args.dataset)
    log = run_frontend(sequence, config, max_images=args.images, progress=True)
    print(f"{args.dataset}: the true points of every sighting ...", file=sys.stderr, flush=True)
    s = evaluation.true_sightings(log, lambda i: folder.ground_truth_maps(i).points_w)
    angular = evaluation.bearing_residuals(log, s, folder.groundtruth.poses_w,
                                           sequence.calibration.viewpoint_r)
    print(f"{args.dataset}: SIFT again for the keypoints' sizes ...", file=sys.stderr, flush=True)
    sizes = keypoint_sizes(sequence, log, config)
    residual, size, dof = pixel_residuals(log, s, sizes, folder, sequence.calibration)

    rows = []
    bins = np.digitize(size, SIZE_EDGES) - 1
    for b in range(len(SIZE_EDGES) - 1):
        sel = bins == b
        if sel.sum() < 50:
            continue
        rows.append({
            "size_px": [SIZE_EDGES[b], SIZE_EDGES[b + 1]],
            "sightings": int(sel.sum()),
            "size_median_px": float(np.median(size[sel])),
            "rms_px": trimmed_rms(residual[sel], dof[sel]),
            "mad_sigma_px": float(1.4826 * np.median(np.abs(residual[sel]))),
        })
    # sigma_px = a + b size, least squares on the per-bin RMS weighted by the bins' counts
    weights = np.sqrt([r["sightings"] for r in rows])
    design = np.column_stack([np.ones(len(rows)), [r["size_median_px"] for r in rows]])
    fit, *_ = np.linalg.lstsq(design * weights[:, None],
                              np.array([r["rms_px"] for r in rows]) * weights, rcond=None)
    results = {
        "dataset": str(args.dataset),
        "images": args.images,
        "overrides": args.set,
        "consistent_sightings": int(angular.angle_rad.size),
        "noise_ratio": evaluation.noise_ratio(angular, TRIM),
        "noise_ratio_median": evaluation.noise_ratio_median(angular),
        "pixel_rms_px": trimmed_rms(residual, dof),
        "by_size": rows,
        "fit_sigma_px": {"a_px": float(fit[0]), "b_per_px": float(fit[1])},
    }
    text = json.dumps(results, indent=2)
    print(text)
    if args.json:
        args.json.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
