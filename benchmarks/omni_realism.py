"""Rendered omni images against real catadioptric ones: SIFT statistics and their KS distances.

Run: ``PYTHONPATH=. python benchmarks/omni_realism.py [--images 30] [--seed 0] [--data DIR]``
(DIR defaults to ``../shared/data/omni_real``). Prints a Markdown table (docs/results/frontend.md,
"Rendered images against real ones").

Image sets:

* **real**: the ten VMR lab images (``vmr_lab_ocamcalib_samples/VMRImage0..9.jpg``, 1024 x 768,
  one static lab, a checkerboard moved between shots) and the office image
  (``office_ocamcalib/example.jpg``, cropped to the columns its calibration applies to).
  The VMR images come without a calibration: the mirror's image circle is fitted to the edge of
  the bright disc of their median image (threshold 25 after a 3 px Gaussian blur, the outer
  contour's points off the image border, an algebraic circle fit with outliers dropped; the
  disc is cut by the image's top and bottom); its inner radius is the outer one times lab40's
  camera's inner / outer ratio (the same band of elevations left out). The office image's ring
  is its calibration's ROI (235-600 px).
* **clean** and **realistic**: ``--images`` consecutive images of lab40 (seed ``--seed``), after
  the first 10 (the auto-exposure's settling), rendered once and passed through the camera
  sensor model (``datasets.synthetic.sensor``) for the realistic set; the same frames, so the
  sets differ only by the sensor.

Statistics (SIFT of the front end: ``frontend.sift.SiftExtractor`` with ``OMNI_THESIS``, OpenCV's
descriptor, without the keypoint budget, which would cap the density, on the ring eroded by the
front end's margin):

* keypoints per 1000 px of the ring, one value per image;
* radius of each keypoint over the ring's outer radius;
* contrast (detector response |D|) of each keypoint;
* size (diameter) of each keypoint over the ring's outer radius (images of different sizes);
* Lowe's ratio (nearest / second-nearest descriptor distance) of every keypoint of a view
  matched into the next view of the same scene (VMR i -> i + 1; lab40 image k -> k + 1).

Each rendered set's distance to the real one is the two-sample Kolmogorov-Smirnov statistic
(``scipy.stats.ks_2samp``: the largest gap between the two empirical distributions, 0 = same).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from scipy.stats import ks_2samp

from omnislam.camera.ocamcalib import read_ocamcalib
from omnislam.datasets.synthetic.presets import PRESETS
from omnislam.datasets.synthetic.realism import Realism, realism_config
from omnislam.datasets.synthetic.render import Renderer
from omnislam.datasets.synthetic.sensor import CameraSensor
from omnislam.datasets.synthetic.simulate import simulate
from omnislam.frontend.config import OMNI_THESIS
from omnislam.frontend.sift import SiftExtractor, detection_mask

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "omni_real"
#: images of lab40 skipped before the compared ones (the auto-exposure settles)
SETTLE_IMAGES = 10
#: the VMR mirror disc: grey level above which a (blurred) pixel is inside it
VMR_DISC_THRESHOLD = 25
#: the compared SIFT: the front end's omni settings without the keypoint budget
SIFT = dataclasses.replace(OMNI_THESIS, features_per_kpx=0.0)


@dataclass(frozen=True, slots=True)
class ImageSet:
    """Grey images of one kind, their usable rings and which pairs are views of one scene.

    Attributes:
        name: the set's name in the table.
        images: grey uint8 images.
        rings: (H, W) bool usable ring of each image.
        centres_px: (u, v) the ring's centre of each image.
        outer_px: the ring's outer radius of each image.
        pairs: (i, j) indices of consecutive views of the same scene.
    """

    name: str
    images: list[np.ndarray]
    rings: list[np.ndarray]
    centres_px: list[tuple[float, float]]
    outer_px: list[float]
    pairs: list[tuple[int, int]]


@dataclass(frozen=True, slots=True)
class SiftStatistics:
    """The compared distributions of one image set (module docstring)."""

    density_per_kpx: np.ndarray
    radius: np.ndarray
    contrast: np.ndarray
    size: np.ndarray
    ratio: np.ndarray


def ring(shape: tuple[int, int], centre: tuple[float, float], inner: float, outer: float
         ) -> np.ndarray:
    """(H, W) bool pixels whose distance to ``centre`` is within [inner, outer] [px]."""
    v, u = np.mgrid[0:shape[0], 0:shape[1]]
    radius = np.hypot(u - centre[0], v - centre[1])
    return (radius >= inner) & (radius <= outer)


def fit_circle(points: np.ndarray) -> tuple[float, float, float]:
    """(cx, cy, r) of the algebraic least-squares circle through (N, 2) points (Kasa's fit),
    refitted five times without the points farther than 3 median residuals off it."""
    for _ in range(5):
        a = np.column_stack([2.0 * points, np.ones(len(points))])
        solution = np.linalg.lstsq(a, (points**2).sum(axis=1), rcond=None)[0]
        cx, cy = solution[:2]
        r = float(np.sqrt(solution[2] + cx**2 + cy**2))
        residual = np.abs(np.hypot(points[:, 0] - cx, points[:, 1] - cy) - r)
        points = points[residual <= max(3.0 * np.median(residual), 2.0)]
    return float(cx), float(cy), r


def vmr_circle(images: list[np.ndarray]) -> tuple[float, float, float]:
    """The VMR mirror's image circle (module docstring), from the median of the images."""
    median = np.median(np.stack(images), axis=0).astype(np.uint8)
    disc = (cv2.GaussianBlur(median, (0, 0), 3) > VMR_DISC_THRESHOLD).astype(np.uint8)
    contours, _ = cv2.findContours(disc, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    points = max(contours, key=cv2.contourArea)[:, 0, :].astype(float)
    height, width = median.shape
    inside = ((points[:, 0] > 2) & (points[:, 0] < width - 3) & (points[:, 1] > 2)
              & (points[:, 1] < height - 3))
    return fit_circle(points[inside])


def real_set(data: Path) -> ImageSet:
    """The VMR images and the office image (module docstring)."""
    vmr = [cv2.imread(str(data / "vmr_lab_ocamcalib_samples" / f"VMRImage{k}.jpg"),
                      cv2.IMREAD_GRAYSCALE) for k in range(10)]
    cx, cy, outer = vmr_circle(vmr)
    camera = PRESETS["lab40"].rig().camera
    inner = outer * camera.inner_radius_px / camera.outer_radius_px
    rings = [ring(image.shape, (cx, cy), inner, outer) for image in vmr]
    office = read_ocamcalib(data / "office_ocamcalib" / "calib_results.txt")
    full = cv2.imread(str(data / "office_ocamcalib" / "example.jpg"), cv2.IMREAD_GRAYSCALE)
    office_image = np.ascontiguousarray(
        full[:, office.crop_left_px:full.shape[1] - office.crop_right_px])
    return ImageSet(
        name="real",
        images=[*vmr, office_image],
        rings=[*rings, np.asarray(office.mask(), dtype=bool)],
        centres_px=[(cx, cy)] * len(vmr) + [(office.center_col, office.center_row)],
        outer_px=[outer] * len(vmr) + [float(office.roi_max_radius_px)],
        pairs=[(k, k + 1) for k in range(len(vmr) - 1)],
    )


def rendered_sets(n_images: int, seed: int) -> tuple[ImageSet, ImageSet]:
    """lab40's clean and realistic images of the same frames (module docstring)."""
    sim = simulate(PRESETS["lab40"], seed, max_images=SETTLE_IMAGES + n_images)
    renderer = Renderer(sim.world, sim.rig)
    config = realism_config(Realism.REALISTIC).sensor
    sensor = CameraSensor(config, sim.rig, sim.stamps_s, sim.poses_w, seed)
    clean, realistic = [], []
    for count, index in enumerate(sim.image_frames):
        frame = renderer.render(sim.poses_w[index])
        captured = sensor.capture(frame.image, frame.points_w, int(index))
        if count >= SETTLE_IMAGES:
            clean.append(cv2.cvtColor(frame.image, cv2.COLOR_RGB2GRAY))
            realistic.append(cv2.cvtColor(captured, cv2.COLOR_RGB2GRAY))
    camera = sim.rig.camera
    mask = np.asarray(camera.mask(), dtype=bool)
    common = {
        "rings": [mask] * n_images,
        "centres_px": [(camera.cu, camera.cv)] * n_images,
        "outer_px": [camera.outer_radius_px] * n_images,
        "pairs": [(k, k + 1) for k in range(n_images - 1)],
    }
    return (ImageSet("clean", clean, **common), ImageSet("realistic", realistic, **common))


def sift_statistics(images: ImageSet) -> SiftStatistics:
    """The SIFT statistics of an image set (module docstring)."""
    extractor = SiftExtractor(SIFT)
    features, density, radius, contrast, size = [], [], [], [], []
    for image, usable, centre, outer in zip(images.images, images.rings, images.centres_px,
                                            images.outer_px, strict=True):
        mask = detection_mask(usable, image.shape)
        found = extractor.extract(image, mask)
        features.append(found)
        density.append(1000.0 * len(found) / np.count_nonzero(mask))
        radius.append(np.hypot(*(found.pixels - np.asarray(centre)).T) / outer)
        contrast.append(found.contrast)
        size.append(found.sizes_px / outer)
    matcher = cv2.BFMatcher(cv2.NORM_L2)
    ratio = []
    for i, j in images.pairs:
        matches = matcher.knnMatch(features[i].descriptors, features[j].descriptors, k=2)
        ratio.append([m[0].distance / m[1].distance for m in matches
                      if len(m) == 2 and m[1].distance > 0])
    return SiftStatistics(np.array(density), np.concatenate(radius), np.concatenate(contrast),
                          np.concatenate(size), np.concatenate([np.array(r) for r in ratio]))


ROWS = (
    ("keypoints per 1000 ring px (per image)", "density_per_kpx", "{:.2f}"),
    ("keypoint radius / ring's outer radius", "radius", "{:.2f}"),
    ("contrast (detector response)", "contrast", "{:.4f}"),
    ("size / ring's outer radius", "size", "{:.4f}"),
    ("Lowe's ratio, consecutive views", "ratio", "{:.2f}"),
)


def _summary(values: np.ndarray, fmt: str) -> str:
    """``median [p10, p90] (n)``."""
    p10, p50, p90 = np.percentile(values, [10, 50, 90])
    return f"{fmt.format(p50)} [{fmt.format(p10)}, {fmt.format(p90)}] (n={values.size})"


def table(real: SiftStatistics, clean: SiftStatistics, realistic: SiftStatistics) -> str:
    """The Markdown table: each statistic's median [10th, 90th percentile] (n) per set and the
    KS distance of each rendered set to the real one."""
    lines = ["| statistic | real | clean | realistic | KS clean | KS realistic |",
             "|---|---|---|---|---|---|"]
    for label, name, fmt in ROWS:
        values = [getattr(s, name) for s in (real, clean, realistic)]
        ks = [ks_2samp(values[0], v).statistic for v in values[1:]]
        cells = [_summary(v, fmt) for v in values] + [f"{d:.2f}" for d in ks]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--images", type=int, default=30, help="lab40 images compared")
    parser.add_argument("--seed", type=int, default=0, help="lab40's seed")
    parser.add_argument("--data", type=Path, default=DATA, help="the omni_real folder")
    args = parser.parse_args()
    real = real_set(args.data)
    print(f"VMR mirror circle: centre ({real.centres_px[0][0]:.1f}, {real.centres_px[0][1]:.1f})"
          f" px, outer radius {real.outer_px[0]:.1f} px", file=sys.stderr)
    clean, realistic = rendered_sets(args.images, args.seed)
    print(table(*(sift_statistics(s) for s in (real, clean, realistic))))


if __name__ == "__main__":
    main()
