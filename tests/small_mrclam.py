"""A small MR.CLAM folder written into a test folder: robot 1 drives a circle among 4 landmarks.

Odometry (v, omega at 10 Hz), sightings of every landmark within 6 m and the camera's field of
view (2 Hz, seeded noise; the "range" column is the camera's optical-axis depth, as in
MR.CLAM), Vicon-style ground truth and the surveyed landmarks: what the MR.CLAM loader reads, so
EKF-SLAM and FastSLAM build maps with covariances without the real data.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from omnislam.datasets.mrclam import DEPTH_BIAS_M

#: half the camera's field of view [rad] (MR.CLAM's: about 0.575)
FIELD_OF_VIEW_RAD = 0.55

#: landmark barcode -> (x, y) [m]
LANDMARKS = {63: (2.0, 0.5), 27: (-1.5, 2.0), 45: (0.5, -2.5), 81: (-2.0, -1.0)}


def write_small_mrclam(folder: Path, seconds: float = 30.0, seed: int = 0) -> Path:
    """Write the folder (see the module docstring) and return it."""
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True, exist_ok=True)
    v, omega = 0.3, 0.2  # a circle of radius 1.5 m
    stamps = np.arange(0.0, seconds + 1e-9, 0.1)
    theta = omega * stamps
    x = v / omega * np.sin(theta)
    y = v / omega * (1.0 - np.cos(theta))
    odometry = "".join(f"{t:.3f} {v} {omega}\n" for t in stamps)
    truth = "".join(
        f"{t:.3f} {a:.6f} {b:.6f} {c:.6f}\n" for t, a, b, c in zip(stamps, x, y, theta, strict=True)
    )
    sightings = []
    for k in range(5, len(stamps), 5):
        for barcode, (lx, ly) in LANDMARKS.items():
            dx, dy = lx - x[k], ly - y[k]
            r = float(np.hypot(dx, dy))
            if r > 6.0:
                continue
            b = float(np.arctan2(dy, dx) - theta[k])
            b = float(np.arctan2(np.sin(b), np.cos(b)))
            if abs(b) > FIELD_OF_VIEW_RAD:
                continue
            # the camera's column: the optical-axis depth with its bias (``mrclam.DEPTH_BIAS_M``)
            depth = (r + rng.normal(0, 0.02)) * np.cos(b) + DEPTH_BIAS_M
            sightings.append(
                f"{stamps[k]:.3f} {barcode} {depth:.4f} {b + rng.normal(0, 0.01):.4f}\n"
            )
    subjects = {1: 5, **{6 + i: code for i, code in enumerate(LANDMARKS)}}
    files = {
        "Barcodes.dat": "# subject barcode\n" + "".join(f"{s} {c}\n" for s, c in subjects.items()),
        "Landmark_Groundtruth.dat": "# subject x y sx sy\n"
        + "".join(
            f"{6 + i} {lx} {ly} 0.001 0.001\n" for i, (lx, ly) in enumerate(LANDMARKS.values())
        ),
        "Robot1_Odometry.dat": "# time v omega\n" + odometry,
        "Robot1_Measurement.dat": "# time barcode range bearing\n" + "".join(sightings),
        "Robot1_Groundtruth.dat": "# time x y theta\n" + truth,
    }
    for name, text in files.items():
        (folder / name).write_text(text)
    return folder
