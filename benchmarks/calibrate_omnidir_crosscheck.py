"""Cross-check of the unified (Mei) fit with OpenCV's ``cv2.omnidir.calibrate`` on the VMR points.

``cv2.omnidir`` is in ``opencv-contrib-python-headless``, which replaces the project's
``opencv-python-headless``; so it lives in a throwaway venv, never the project's::

    python3 -m venv /tmp/omnidir-venv
    /tmp/omnidir-venv/bin/pip install opencv-contrib-python-headless numpy scipy
    PYTHONPATH=. OPENBLAS_NUM_THREADS=1 python benchmarks/calibrate_omnidir_crosscheck.py \\
        --omnidir-python /tmp/omnidir-venv/bin/python [MAT]

Run with the project's interpreter, the script fits the package's unified model in-process and
OpenCV's in a subprocess of ``--omnidir-python`` (this file again with ``--opencv-only``, which
needs only numpy, scipy and cv2 and prints JSON); when ``cv2.omnidir`` is importable in the
running interpreter, it is used directly. MAT defaults to
``../shared/data/omni_real/vmr_lab_ocamcalib_samples/VMRImagePts.mat``.

Both fits read the same points with the same conventions (``points_io``): MATLAB pixels
``- 1`` (``(0, 0)`` at the centre of the top-left pixel, as OpenCV), board points in metres.
Both are Mei's model with ``k1, k2, p1, p2``; OpenCV is run twice, with skew fixed to 0 (as the
package) and free. The RMS is computed the same way for both, ``sqrt(mean(du^2 + dv^2))``
over every corner of the images each fit used (OpenCV's initialisation may drop images: its
``idx`` is printed).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

MAT = Path(__file__).resolve().parents[2] / "shared" / "data" / "omni_real"
MAT = MAT / "vmr_lab_ocamcalib_samples" / "VMRImagePts.mat"
#: image size of the VMR samples [px]
SIZE = (1024, 768)
HOW_TO = __doc__.split("::\n\n")[1].split("\n\n")[0]


def read_mat(path: Path) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """(N, 2) pixels (package convention) and (N, 3) board points [m] per image, scipy only."""
    import scipy.io

    grid = scipy.io.loadmat(str(path), squeeze_me=False)["gridInfo"][0, 0]
    xs, Xs = grid["x"].ravel(), grid["X"].ravel()
    pixels = [np.asarray(x, float).T - 1.0 for x in xs]
    board = [np.asarray(X, float).T * 1e-3 for X in Xs]
    return pixels, board


def opencv_fit(path: Path, fix_skew: bool) -> dict:
    """``cv2.omnidir.calibrate`` on the file's points; its parameters and our RMS definition."""
    import cv2

    pixels, board = read_mat(path)
    object_points = [b.reshape(1, -1, 3).astype(np.float64) for b in board]
    image_points = [p.reshape(1, -1, 2).astype(np.float64) for p in pixels]
    flags = cv2.omnidir.CALIB_FIX_SKEW if fix_skew else 0
    criteria = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 1000, 1e-12)
    rms_cv, K, xi, D, rvecs, tvecs, idx = cv2.omnidir.calibrate(
        object_points, image_points, SIZE, None, None, None, flags, criteria
    )
    used = [int(i) for i in np.asarray(idx).ravel()]
    squares = []
    for k, i in enumerate(used):
        projected, _ = cv2.omnidir.projectPoints(
            object_points[i], rvecs[k], tvecs[k], K, float(np.ravel(xi)[0]), D
        )
        squares.append(np.sum((projected.reshape(-1, 2) - pixels[i]) ** 2, axis=1))
    d = np.ravel(D)
    return {
        "xi": float(np.ravel(xi)[0]),
        "gamma1": float(K[0, 0]),
        "gamma2": float(K[1, 1]),
        "cu": float(K[0, 2]),
        "cv": float(K[1, 2]),
        "skew": float(K[0, 1]),
        "k1": float(d[0]),
        "k2": float(d[1]),
        "p1": float(d[2]),
        "p2": float(d[3]),
        "rms_px": float(np.sqrt(np.mean(np.concatenate(squares)))),
        "opencv_returned_rms": float(rms_cv),
        "images_used": used,
    }


def opencv_both(path: Path) -> dict[str, dict]:
    """OpenCV's fits with skew fixed to 0 and free."""
    return {"opencv fix_skew": opencv_fit(path, True), "opencv skew": opencv_fit(path, False)}


def opencv_fits(path: Path, python: str | None) -> dict[str, dict] | None:
    """OpenCV's fits (skew fixed and free), here or in ``python``; None when unavailable."""
    try:
        import cv2

        if hasattr(cv2, "omnidir"):
            return opencv_both(path)
    except ImportError:
        pass
    if python is None:
        return None
    done = subprocess.run(
        [python, __file__, "--opencv-only", str(path)],
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        sys.exit(f"{python} --opencv-only failed:\n{done.stderr}")
    return json.loads(done.stdout)


def ours(path: Path) -> dict:
    """The package's unified fit of the same points, with its standard deviations."""
    from omnislam.camera.calibration import Model, calibrate, read_points

    views, _ = read_points(path)
    result = calibrate(views, Model.UNIFIED, *SIZE)
    out = dict(result.values)
    out["skew"] = 0.0
    out["rms_px"] = result.rms_px
    out["images_used"] = list(range(len(views)))
    out["std"] = result.std
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mat", nargs="?", type=Path, default=MAT)
    parser.add_argument("--omnidir-python", help="an interpreter with cv2.omnidir (contrib)")
    parser.add_argument("--opencv-only", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.opencv_only:
        print(json.dumps(opencv_both(args.mat)))
        return
    opencv = opencv_fits(args.mat, args.omnidir_python)
    if opencv is None:
        sys.exit(
            "cv2.omnidir is not importable here (the project installs opencv-python-headless, "
            "not contrib); run in a separate venv:\n" + HOW_TO
        )
    fits = {"omnislam": ours(args.mat), **opencv}
    names = ("xi", "gamma1", "gamma2", "cu", "cv", "skew", "k1", "k2", "p1", "p2", "rms_px")
    print(f"{'':<10}" + "".join(f"{label:>17}" for label in fits) + f"{'omnislam std':>14}")
    std = fits["omnislam"]["std"]
    for name in names:
        row = "".join(f"{fit[name]:>17.6g}" for fit in fits.values())
        print(f"{name:<10}{row}{std.get(name, float('nan')):>14.3g}")
    for label, fit in fits.items():
        print(f"{label}: images used {fit['images_used']}")
    reference = fits["omnislam"]
    for label in opencv:
        sigmas = {n: (opencv[label][n] - reference[n]) / std[n] for n in std}
        print(
            f"{label} - omnislam, in omnislam std: "
            + " ".join(f"{n} {s:+.1e}" for n, s in sigmas.items())
        )


if __name__ == "__main__":
    main()
