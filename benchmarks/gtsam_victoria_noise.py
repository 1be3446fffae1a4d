"""The stated noise of gtsam's victoria_park.txt against its residuals at the LM optimum.

Why does association without ids fail on ``victoria-park-gtsam`` when it works on the raw
Victoria Park log? This prints the measurements behind the answer in docs/results/association.md:

* the residuals of every factor at the warm-started LM optimum with ids
  (``omnislam.harness.reference``, the runs' reference): odometry per axis, range, bearing --
  against the sigmas the file states (gtsam's ``load2D`` conversion, ``datasets.gtsam_victoria``);
* the heading error the odometry accumulates over n steps, ``sum_{i<n} e_theta,i`` (the
  optimum's heading minus the composed odometry's), against the ``sqrt(n) sigma_theta`` a
  white-noise model with the stated sigma predicts, and the per-step sigma a white model would
  need to cover it;
* the gaps between consecutive sightings of one tree (a revisit's gap decides how far the pose
  has drifted when the association meets the tree again);
* the frame structure (sightings per frame, ranges) next to the raw ``victoria-park`` log.

::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/gtsam_victoria_noise.py
        [--no-raw]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from omnislam.core.se import wrap_angle
from omnislam.datasets.gtsam_victoria import find_gtsam_file, read_gtsam_graph
from omnislam.datasets.registry import load_dataset, resolve
from omnislam.harness.reference import lm_reference

#: step counts over which the accumulated heading error is measured
WINDOWS = (1, 3, 10, 30, 100, 300, 1000)


def relative_poses(wTa: np.ndarray, wTb: np.ndarray) -> np.ndarray:
    """(N, 3) ``aTb`` of N pose pairs [x, y, theta] (b seen from a)."""
    c, s = np.cos(wTa[:, 2]), np.sin(wTa[:, 2])
    d = wTb[:, :2] - wTa[:, :2]
    return np.column_stack(
        [c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1], wrap_angle(wTb[:, 2] - wTa[:, 2])]
    )


def accumulated_rms(errors: np.ndarray, n: int) -> float:
    """RMS over every window of n consecutive steps of the summed per-step error."""
    total = np.concatenate([[0.0], np.cumsum(errors)])
    return float(np.sqrt(np.mean((total[n:] - total[:-n]) ** 2)))


def _sightings_per_frame(name: str) -> tuple[np.ndarray, np.ndarray]:
    frames = list(load_dataset(resolve(name), {}).frame_inputs())
    seen = [f.range_bearing for f in frames]
    counts = np.array([0 if rb is None else len(rb.ranges_m) for rb in seen])
    ranges = np.concatenate([rb.ranges_m for rb in seen if rb is not None])
    return counts, ranges


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-raw", action="store_true", help="skip the raw victoria-park log")
    args = parser.parse_args()

    path = find_gtsam_file()
    if path is None:
        raise SystemExit("gtsam's victoria_park.txt not found (install the 'graph' extra)")
    edges, deltas, sigmas, sightings = read_gtsam_graph(path)
    print(
        f"{path.name}: the LM optimum with ids (from the cache, else iSAM2 + LM: ~35 s) ...",
        file=sys.stderr,
        flush=True,
    )
    reference = lm_reference(path)
    wTr = reference.poses_w
    frame_of = {int(p): k for k, p in enumerate(np.append(edges[:, 0], edges[-1, 1]))}

    e = relative_poses(wTr[:-1], wTr[1:]) - deltas
    e[:, 2] = wrap_angle(e[:, 2])
    stated = np.median(sigmas, axis=0)
    trees = len(reference.landmark_ids)
    print(f"{path.name}: {len(wTr)} poses, {len(sightings)} sightings, {trees} trees")
    print("odometry residuals at the LM optimum (per step):")
    for axis, name, unit in ((0, "x", "mm"), (1, "y", "mm"), (2, "theta", "mrad")):
        rms = np.sqrt(np.mean(e[:, axis] ** 2))
        print(
            f"  {name:5s} stated sigma {stated[axis] * 1e3:6.2f} {unit}; residual rms "
            f"{rms * 1e3:6.3f}, mean {e[:, axis].mean() * 1e3:+.3f}"
        )
    print("heading error accumulated over n steps (rms over all windows):")
    for n in WINDOWS:
        rms = accumulated_rms(e[:, 2], n)
        print(
            f"  n={n:5d}: {rms * 1e3:7.1f} mrad, white model with the stated sigma "
            f"{np.sqrt(n) * stated[2] * 1e3:6.1f} mrad -> needs "
            f"{rms / np.sqrt(n) * 1e3:5.1f} mrad/step"
        )
    centred = e[:, 2] - e[:, 2].mean()
    lags = (1, 10, 30, 100, 300)
    corr = [float(np.mean(centred[:-lag] * centred[lag:]) / centred.var()) for lag in lags]
    print(
        "  autocorrelation of the heading residual at lags",
        dict(zip(lags, np.round(corr, 2).tolist(), strict=True)),
    )

    lid_w = dict(zip(reference.landmark_ids.tolist(), reference.landmarks_w, strict=True))
    k = np.array([frame_of[int(p)] for p in sightings[:, 0]])
    pose = wTr[k]
    diff = np.array([lid_w[int(lid)] for lid in sightings[:, 1]]) - pose[:, :2]
    range_res = sightings[:, 2] - np.hypot(diff[:, 0], diff[:, 1])
    bearing_res = wrap_angle(sightings[:, 3] - (np.arctan2(diff[:, 1], diff[:, 0]) - pose[:, 2]))
    print("sighting residuals at the LM optimum:")
    print(
        f"  range   stated {np.median(sightings[:, 4]):.3f} m; "
        f"rms {np.sqrt(np.mean(range_res**2)):.3f}, "
        f"|r| p50/p90/p99 {np.round(np.percentile(np.abs(range_res), [50, 90, 99]), 3)}"
    )
    print(
        f"  bearing stated {np.median(sightings[:, 5]):.3f} rad; "
        f"rms {np.sqrt(np.mean(bearing_res**2)):.4f}, "
        f"|r| p50/p90/p99 {np.round(np.percentile(np.abs(bearing_res), [50, 90, 99]), 4)}"
    )

    gaps = []
    for lid in np.unique(sightings[:, 1]):
        gaps.extend(np.diff(np.unique(k[sightings[:, 1] == lid])).tolist())
    gaps = np.asarray(gaps)
    revisits = gaps[gaps > 50]
    print(
        f"gaps between consecutive sightings of one tree [frames]: median {np.median(gaps):.0f}; "
        f"{len(revisits)} revisits (> 50 frames), gap p10/p50/p90 "
        f"{np.percentile(revisits, [10, 50, 90]).astype(int)}"
    )
    xy = reference.landmarks_w
    nearest = np.sort(np.hypot(*(xy[:, None] - xy[None]).transpose(2, 0, 1)), axis=1)[:, 1]
    print(
        f"nearest other tree [m]: p5/p25/p50 {np.round(np.percentile(nearest, [5, 25, 50]), 2)}, "
        f"{int(np.sum(nearest < 1.5))} trees with one within 1.5 m"
    )

    names = ["victoria-park-gtsam"] + ([] if args.no_raw else ["victoria-park"])
    for name in names:
        counts, ranges = _sightings_per_frame(name)
        seen = counts > 0
        print(
            f"{name}: {len(counts)} frames, {seen.sum()} with sightings, {counts.sum()} sightings, "
            f"{counts[seen].mean():.2f} per frame with any; range p50/p95/max "
            f"{np.round(np.percentile(ranges, [50, 95, 100]), 1)} m"
        )


if __name__ == "__main__":
    main()
