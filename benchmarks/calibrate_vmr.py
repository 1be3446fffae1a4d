"""Calibration accuracy and time on the VMR samples: toolbox points vs detected corners.

Run: ``PYTHONPATH=. OPENBLAS_NUM_THREADS=1 python benchmarks/calibrate_vmr.py [FOLDER]`` (FOLDER
defaults to ``../shared/data/omni_real/vmr_lab_ocamcalib_samples``; BLAS pinned
to one thread, as ``omnislam calibrate`` does). Prints, per model and corner source, the
overall reprojection RMS, the residual sigma, outliers and seconds; then the largest distance
between detected corners and the toolbox's.
"""

import sys
import time
from pathlib import Path

import numpy as np

from omnislam.camera.calibration import Board, Model, calibrate, read_points
from omnislam.camera.calibration.detect import detect_views

FOLDER = Path(__file__).resolve().parents[2] / "shared" / "data" / "omni_real"
FOLDER = FOLDER / "vmr_lab_ocamcalib_samples"


def main():
    folder = Path(sys.argv[1]) if len(sys.argv) > 1 else FOLDER
    images = sorted(folder.glob("VMRImage*.jpg"))
    toolbox, _ = read_points(folder / "VMRImagePts.mat", names=[p.name for p in images])
    start = time.perf_counter()
    detected, skipped, size = detect_views(images, Board(6, 7, 0.03))
    print(
        f"detection: {len(detected)} boards, {len(skipped)} skipped, "
        f"{time.perf_counter() - start:.1f} s"
    )
    by_name = {v.name: v for v in detected}
    worst = max(
        np.linalg.norm(v.pixels[:, None] - by_name[v.name].pixels[None], axis=2).min(1).max()
        for v in toolbox
    )
    print(f"largest detected-vs-toolbox corner distance: {worst:.4f} px")
    print(f"{'model':<11} {'corners':<9} {'rms_px':>8} {'sigma_px':>9} {'outliers':>8} {'s':>6}")
    for model in Model:
        for label, views in (("toolbox", toolbox), ("detected", detected)):
            start = time.perf_counter()
            result = calibrate(views, model, *size)
            seconds = time.perf_counter() - start
            print(
                f"{model.value:<11} {label:<9} {result.rms_px:>8.4f} {result.sigma_px:>9.4f} "
                f"{result.outliers:>8} {seconds:>6.1f}"
            )


if __name__ == "__main__":
    main()
