"""How many floor keypoints a keypoint budget keeps: the whole ring's strongest vs shared out.

The graph takes the odometry's scale from floor points (``graphslam/floor_scale.py``), which are
low-contrast: a budget that keeps the strongest keypoints of the whole ring drops most of them.
For every ``--every``-th image of a rendered omni dataset this counts the SIFT keypoints (the
omni preset) whose ray points at least ``floor_scale.FLOOR_MIN_DEPRESSION_DEG`` below the
horizon, without a budget, with the budget going to the ring's strongest (1 x 1 buckets) and
with it shared out over rings x sectors (the preset's, and ``--buckets`` more)::

    PYTHONPATH=. .venv/bin/python benchmarks/floor_keypoints.py runs/lab40 --every 45
"""

from __future__ import annotations

import argparse
import dataclasses
import sys

import numpy as np

from omnislam.datasets.registry import load_dataset
from omnislam.frontend.config import OMNI_THESIS
from omnislam.frontend.sift import SiftExtractor, detection_mask
from omnislam.graphslam.floor_scale import FLOOR_MIN_DEPRESSION_DEG


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", help="rendered omni folder")
    parser.add_argument("--every", type=int, default=45, help="every N-th image")
    parser.add_argument("--buckets", nargs="*", default=["6x8", "3x12"], metavar="RxS",
                        help="more rings x sectors to count")
    args = parser.parse_args()
    sequence = load_dataset(args.dataset, {})
    rig = sequence.calibration
    mask = detection_mask(rig.camera.mask(), rig.camera.mask().shape)
    density = OMNI_THESIS.features_per_kpx or 1.2
    flat = "ring's strongest"
    variants = {"no budget": dataclasses.replace(OMNI_THESIS, features_per_kpx=0.0),
                flat: dataclasses.replace(
                    OMNI_THESIS, features_per_kpx=density, budget_bands=1, budget_sectors=1)}
    for spec in [f"{OMNI_THESIS.budget_bands}x{OMNI_THESIS.budget_sectors}", *args.buckets]:
        rings, sectors = (int(v) for v in spec.split("x"))
        variants[f"{rings} x {sectors} buckets"] = dataclasses.replace(
            OMNI_THESIS, features_per_kpx=density, budget_bands=rings, budget_sectors=sectors)
    extractors = {name: SiftExtractor(config) for name, config in variants.items()}
    totals = dict.fromkeys(variants, 0)
    images = sequence.image_frames[:: args.every]
    print(f"{args.dataset}: {len(images)} images, budget {density} per 1000 px "
          f"({extractors[flat].budget(mask.shape, mask)} keypoints); "
          f"floor keypoints (>= {FLOOR_MIN_DEPRESSION_DEG:g} deg below the horizon) / all, "
          f"for {', '.join(variants)}:")
    print(
        f"{args.dataset}: SIFT with {len(extractors)} budgets on {len(images)} images ...",
        file=sys.stderr,
        flush=True,
    )
    for frame in images.tolist():
        image = sequence.image(frame)
        row = []
        for name, extractor in extractors.items():
            features = extractor.extract(image, mask)
            rays = rig.rays_r(features.pixels)
            floor = int(np.count_nonzero(
                rays[:, 2] <= -np.sin(np.radians(FLOOR_MIN_DEPRESSION_DEG))))
            totals[name] += floor
            row.append(f"{floor}/{len(features)}")
        print(f"  frame {frame}: " + "  ".join(row), flush=True)
    print("total floor keypoints: " + ", ".join(f"{n} {v}" for n, v in totals.items()))


if __name__ == "__main__":
    main()
