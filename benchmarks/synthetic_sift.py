"""SIFT keypoints on synthetic presets, measured against the per-pixel ground truth.

    .venv/bin/python benchmarks/synthetic_sift.py lab40 [--every 1]
    .venv/bin/python benchmarks/synthetic_sift.py campus1500 --blind

``lab40``: the fraction of frames with >= 300 SIFT keypoints (goal: >= 95 %).
``campus1500 --blind``: renders only the frames on the corridor with no landmarks and counts,
per frame, the keypoints whose ground-truth surface is a textured landmark (poster, box, door,
pole, pillar); goal: < 20 per frame over >= 30 m of corridor.
Frames are rendered in memory (nothing written).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from omnislam._optional import require
from omnislam.datasets.synthetic.presets import PRESETS
from omnislam.datasets.synthetic.render import Renderer
from omnislam.datasets.synthetic.simulate import simulate

#: the blind stretch of campus1500 (x range of its top corridor) [m]
BLIND_X_M = (40.0, 110.0)


def longest_stretch_m(xy: np.ndarray, ok: np.ndarray) -> float:
    """Longest path length [m] over consecutive frames that all satisfy ``ok``."""
    best, start = 0.0, None
    steps = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))]
    for i, good in enumerate(np.append(ok, False)):
        if good and start is None:
            start = i
        elif not good and start is not None:
            best = max(best, steps[i - 1] - steps[start])
            start = None
    return float(best)


def keypoints(cv2, sift, frame, mask) -> list:
    gray = cv2.cvtColor(frame.image, cv2.COLOR_RGB2GRAY)
    return sift.detect(gray, mask)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("preset", choices=sorted(PRESETS))
    parser.add_argument("--every", type=int, default=1, help="use every n-th image")
    parser.add_argument("--blind", action="store_true", help="only the landmark-free corridor")
    args = parser.parse_args()
    cv2 = require("cv2")
    print(f"{args.preset}: simulating the route ...", file=sys.stderr, flush=True)
    sim = simulate(PRESETS[args.preset], 0)
    renderer = Renderer(sim.world, sim.rig)
    landmark_surface = sim.world.landmark_surface_mask()
    mask = sim.rig.camera.mask().astype(np.uint8)
    sift = cv2.SIFT_create()
    frames = sim.image_frames[:: args.every]
    if args.blind:
        xy = sim.poses_w[frames, :2]
        top = xy[:, 1] > np.max(sim.poses_w[:, 1]) - 1.0
        inside = top & (xy[:, 0] > BLIND_X_M[0]) & (xy[:, 0] < BLIND_X_M[1])
        first_lap = np.cumsum(np.r_[0, np.diff(inside.astype(int)) < 0]) == 0
        frames = frames[inside & first_lap]
    counts, on_landmarks = [], []
    print(
        f"{args.preset}: rendering {frames.size} frames and detecting SIFT ...",
        file=sys.stderr,
        flush=True,
    )
    for index in frames:
        frame = renderer.render(sim.poses_w[index])
        kps = keypoints(cv2, sift, frame, mask)
        counts.append(len(kps))
        if kps:
            px = np.array([k.pt for k in kps])
            ids = frame.surface_ids[np.round(px[:, 1]).astype(int), np.round(px[:, 0]).astype(int)]
            on_landmarks.append(int(np.sum((ids >= 0) & landmark_surface[np.maximum(ids, 0)])))
        else:
            on_landmarks.append(0)
    counts, on_landmarks = np.array(counts), np.array(on_landmarks)
    print(f"{args.preset}: {frames.size} frames; keypoints per frame median {np.median(counts):.0f}"
          f" (min {counts.min()}, max {counts.max()}); on textured landmarks median "
          f"{np.median(on_landmarks):.0f} (max {on_landmarks.max()})")
    if args.blind:
        span = np.ptp(sim.poses_w[frames, 0]) if frames.size else 0.0
        print(f"blind corridor: {span:.1f} m covered; frames with < 20 landmark keypoints: "
              f"{np.mean(on_landmarks < 20):.1%}")
        print(f"longest stretch with < 20 landmark keypoints in every frame: "
              f"{longest_stretch_m(sim.poses_w[frames, :2], on_landmarks < 20):.1f} m")
    else:
        print(f"frames with >= 300 keypoints: {np.mean(counts >= 300):.1%}")


if __name__ == "__main__":
    main()
