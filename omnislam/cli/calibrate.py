"""Fit an omnidirectional camera model to checkerboard images.

Corners come from OpenCV's detector on each image (refined to sub-pixel on the original) or
from a points file (--points FILE.mat or FILE.csv; the board then comes from the file when it
holds it). The chosen model is initialised and fitted jointly with every board pose. Writes the
camera YAML atomically (with reprojection_rms_px) and a report folder (report.json, report.md,
and residuals.png when matplotlib is installed); prints the per-image table and, last,
rms_px: X. Existing outputs are replaced only with --overwrite. An image whose board is not
found or whose points disagree with the board is named in a warning with the problem and left
out; fewer than three usable images stop the command with exit code 2 (the one error line names
the first image left out and why). The stage lines on stderr are progress (omnislam --quiet
silences them).
"""

from __future__ import annotations

import argparse
import os

#: BLAS threads of this command: the problem is small, and threaded BLAS on a loaded machine
#: slowed each SVD of the solver 100-300x (measured 99 s vs 4.0 s for the VMR fit)
BLAS_THREADS = "1"
#: default sub-pixel half-window of the corner refinement (``--window``) [px]
WINDOW_PX = 4


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "calibrate", help="fit a camera model to checkerboard images", description=__doc__
    )
    p.add_argument("images", nargs="*", metavar="IMAGE", help="images of the board")
    p.add_argument(
        "--model",
        choices=("unified", "ocamcalib", "hyperbolic"),
        default="unified",
        help="camera model to fit (default unified)",
    )
    p.add_argument("--board", default=None, metavar="COLSxROWS", help="inner corners, e.g. 6x7")
    p.add_argument("--square", type=float, default=None, metavar="M", help="square side [m]")
    p.add_argument(
        "--points",
        default=None,
        metavar="FILE",
        help="corner points (.mat of the MATLAB toolboxes, or .csv image,u,v,x_m,y_m) "
        "instead of detection; IMAGES, when given, name the file's images in order",
    )
    p.add_argument("--out", required=True, metavar="YAML", help="camera file to write")
    p.add_argument(
        "--report",
        default=None,
        metavar="DIR",
        help="report folder (default: next to --out, named after it with _report)",
    )
    p.add_argument(
        "--image-size",
        default=None,
        metavar="WxH",
        help="image size when no image is given (points file only)",
    )
    p.add_argument(
        "--mask-radii",
        nargs=2,
        type=float,
        default=None,
        metavar=("INNER", "OUTER"),
        help="detect only on the ring between these radii about the image centre [px] "
        "(detection only, not with --points)",
    )
    p.add_argument(
        "--window",
        type=int,
        default=None,
        help=f"sub-pixel half-window [px] ({WINDOW_PX}; detection only, not with --points)",
    )
    p.add_argument("--ocam-degree", type=int, default=4, help="OCamCalib pol degree (4)")
    p.add_argument("--save-points", default=None, metavar="CSV", help="write the corners used")
    p.add_argument(
        "--overwrite", action="store_true", help="replace an existing camera file and report"
    )
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    for variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(variable, BLAS_THREADS)
    import logging
    import sys
    from pathlib import Path

    from omnislam._files import check_overwrite
    from omnislam._progress import Progress, enabled
    from omnislam.camera.calibration import (
        MIN_VIEWS,
        Board,
        Model,
        calibrate,
        read_points,
        write_points_csv,
    )
    from omnislam.errors import ConfigError, DataError

    out = Path(args.out)
    report = Path(args.report) if args.report else out.with_name(out.stem + "_report")
    check_overwrite(out, args.overwrite, "camera file")
    check_overwrite(
        report, args.overwrite, "calibration report", lambda p: (p / "report.json").is_file()
    )
    if args.save_points:
        check_overwrite(args.save_points, args.overwrite, "points file")

    def say(line: str) -> None:
        if enabled():
            print(f"omnislam calibrate: {line}", file=sys.stderr, flush=True)

    if args.points is not None:  # options of the detection that a points file would ignore
        for flag, given in (("--window", args.window), ("--mask-radii", args.mask_radii)):
            if given is not None:
                raise ConfigError(f"{flag} applies to corner detection, not to --points")
    elif args.image_size is not None:
        raise ConfigError("--image-size applies to --points (detection reads the images' size)")
    window = WINDOW_PX if args.window is None else args.window
    if window < 1:
        raise ConfigError(f"--window must be a positive number of pixels, got {window}")
    if args.ocam_degree < 2:
        raise ConfigError(f"--ocam-degree must be at least 2, got {args.ocam_degree}")

    board = None
    if args.board is not None:
        if args.square is None and args.points is None:
            raise ConfigError("--board needs --square (the side of a square in metres)")
        board = Board.parse(args.board, args.square if args.square is not None else 1.0)
    if args.points is None:
        if board is None:
            raise ConfigError("give --board COLSxROWS and --square M, or --points FILE")
        if len(args.images) == 0:
            raise ConfigError("no images given")
        from omnislam.camera.calibration.detect import detect_views

        mask = None
        if args.mask_radii is not None:  # sized after the first image that can be read
            size = _first_image_size(args.images)
            mask = _ring_mask(size, *args.mask_radii) if size is not None else None
        detecting = f"calibrate: detecting the {board.cols}x{board.rows} board"
        with Progress(detecting, len(args.images), "img"):  # quiet when quick (bad input)
            views, skipped, size = detect_views(args.images, board, mask, window)
    else:
        names = [Path(image).name for image in args.images] or None
        views, skipped = read_points(
            args.points, board, names, check_square=args.square is not None
        )
        size = _parse_size(args.image_size) if args.image_size else None
        if size is None and args.images:
            size = _common_image_size(args.images)
        if size is None:
            raise ConfigError(f"{args.points}: give IMAGES or --image-size WxH")
    for problem in skipped:  # held back by the CLI unless the command succeeds
        logging.getLogger(__name__).warning("%s", problem)
    first_skipped = f" (first left out: {skipped[0]})" if skipped else ""
    if size is None:
        raise DataError(f"no readable image{first_skipped}")
    if len(views) < MIN_VIEWS:
        raise DataError(
            f"{len(views)} usable image(s) left; a calibration needs at least {MIN_VIEWS}"
            f"{first_skipped}"
        )
    if args.save_points:
        write_points_csv(views, args.save_points)
    say(f"fitting the {args.model} model to {len(views)} image(s)")
    calibration = calibrate(
        views, Model(args.model), size[0], size[1], ocam_degree=args.ocam_degree, progress=say
    )
    _write_outputs(calibration, out, report, args, skipped)
    print(_table(calibration))
    print(f"camera: {out}; report: {report}")
    print(f"rms_px: {calibration.rms_px:.4f}")
    return 0


def _parse_size(text: str) -> tuple[int, int]:
    """``--image-size WxH`` as ``(width, height)``.

    Raises:
        ConfigError: naming the option: not ``WxH`` or a size that is not positive.
    """
    from omnislam.errors import ConfigError

    width, sep, height = text.lower().partition("x")
    if not sep or not width.isdigit() or not height.isdigit():
        raise ConfigError(f"--image-size must be WxH, got {text!r}")
    if int(width) < 1 or int(height) < 1:
        raise ConfigError(f"--image-size must be positive pixel counts, got {text!r}")
    return int(width), int(height)


def _image_size(path: str) -> tuple[int, int]:
    """``(width, height)`` of an image file.

    Raises:
        DataError: naming the image when it cannot be read (truncated, corrupt, not an image).
    """
    from omnislam.camera.calibration.detect import read_grey

    image = read_grey(path)
    return image.shape[1], image.shape[0]


def _common_image_size(paths: list[str]) -> tuple[int, int]:
    """The size of the images of a points file, every one read (the points are measured in
    them: one that cannot be read or has another size is bad input, not a name to skip).

    Raises:
        DataError: naming the first image that cannot be read or differs from the first's size.
    """
    from pathlib import Path

    from omnislam.errors import DataError

    size = _image_size(paths[0])
    for path in paths[1:]:
        other = _image_size(path)
        if other != size:
            raise DataError(
                f"image is {other[0]}x{other[1]} px, {Path(paths[0]).name} is "
                f"{size[0]}x{size[1]}: the images of one calibration share one size",
                path,
            )
    return size


def _first_image_size(paths: list[str]) -> tuple[int, int] | None:
    """The size of the first image that can be read (None when none can: detection, which
    skips an unreadable image, then reports it)."""
    from omnislam.errors import DataError

    for path in paths:
        try:
            return _image_size(path)
        except DataError:
            continue
    return None


def _ring_mask(size: tuple[int, int], inner: float, outer: float):  # noqa: ANN202
    import numpy as np

    width, height = size
    v, u = np.mgrid[0:height, 0:width]
    radius = np.hypot(u - (width - 1) / 2.0, v - (height - 1) / 2.0)
    return (radius >= inner) & (radius <= outer)


def _summary(calibration, args: argparse.Namespace, skipped) -> dict:  # noqa: ANN001
    return {
        "model": calibration.camera.MODEL,
        "reprojection_rms_px": calibration.rms_px,
        "residual_sigma_px": calibration.sigma_px,
        "corners": int(sum(len(v.pixels) for v in calibration.views)),
        "outliers": calibration.outliers,
        "source": args.points or "detected",
        "parameters": {
            name: {"value": calibration.values[name], "std": calibration.std[name]}
            for name in calibration.values
        },
        "images": [
            {
                "name": view.name,
                "rms_px": view.rms_px,
                "max_px": view.max_px,
                "corners": len(view.pixels),
                "outliers": int(view.outliers.sum()),
            }
            for view in calibration.views
        ],
        "skipped": [{"name": s.name, "reason": s.reason} for s in skipped],
        "solver": {"evaluations": calibration.nfev, "message": calibration.message},
    }


def _write_outputs(calibration, out, report, args, skipped) -> None:  # noqa: ANN001
    import json
    import os
    import tempfile

    from omnislam._files import atomic_write_text, make_public
    from omnislam.camera.io import save_camera

    summary = _summary(calibration, args, skipped)
    metadata = {
        "reprojection_rms_px": round(calibration.rms_px, 6),
        "calibration": {
            "images": [view.name for view in calibration.views],
            "corners": summary["corners"],
            "outliers": summary["outliers"],
            "std": {name: calibration.std[name] for name in calibration.std},
        },
    }
    report.mkdir(parents=True, exist_ok=True)
    atomic_write_text(report / "report.json", json.dumps(summary, indent=2) + "\n")
    atomic_write_text(report / "report.md", _markdown(summary))
    _figure(calibration, report / "residuals.png")
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=out.parent, prefix=f".{out.name}.", suffix=".tmp")
    os.close(fd)
    try:
        save_camera(calibration.camera, tmp, metadata)
        make_public(tmp)
        os.replace(tmp, out)
    except BaseException:
        os.unlink(tmp)
        raise


def _table(calibration) -> str:  # noqa: ANN001
    lines = [f"{'image':<24} {'corners':>7} {'rms_px':>8} {'max_px':>8} {'outliers':>8}"]
    for view in calibration.views:
        lines.append(
            f"{view.name:<24} {len(view.pixels):>7} {view.rms_px:>8.3f} {view.max_px:>8.3f} "
            f"{int(view.outliers.sum()):>8}"
        )
    lines.append("")
    lines.append(f"{'parameter':<16} {'value':>16} {'std':>12}")
    for name, value in calibration.values.items():
        lines.append(f"{name:<16} {value:>16.8g} {calibration.std[name]:>12.3g}")
    return "\n".join(lines)


def _markdown(summary: dict) -> str:
    lines = [
        f"# Calibration: {summary['model']} model",
        "",
        f"Reprojection RMS {summary['reprojection_rms_px']:.4f} px over {summary['corners']} "
        f"corners (RMS of the 2-D error norm); residual sigma per coordinate "
        f"{summary['residual_sigma_px']:.4f} px; {summary['outliers']} outlier(s); "
        f"corners: {summary['source']}.",
        "",
        "| image | corners | RMS [px] | max [px] | outliers |",
        "|---|---:|---:|---:|---:|",
    ]
    for image in summary["images"]:
        lines.append(
            f"| {image['name']} | {image['corners']} | {image['rms_px']:.3f} | "
            f"{image['max_px']:.3f} | {image['outliers']} |"
        )
    lines += ["", "| parameter | value | std |", "|---|---:|---:|"]
    for name, item in summary["parameters"].items():
        lines.append(f"| {name} | {item['value']:.8g} | {item['std']:.3g} |")
    if summary["skipped"]:
        lines += ["", "Skipped:", ""]
        lines += [f"- {s['name']}: {s['reason']}" for s in summary["skipped"]]
    lines += ["", "![residuals](residuals.png)", ""]
    return "\n".join(lines)


def _figure(calibration, path) -> None:  # noqa: ANN001
    """Residual vectors over the image (magnified) and the per-image RMS."""
    from omnislam._optional import available

    if not available("matplotlib"):
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    camera = calibration.camera
    pixels = np.concatenate([v.pixels for v in calibration.views])
    residuals = np.concatenate([v.residuals_px for v in calibration.views])
    outliers = np.concatenate([v.outliers for v in calibration.views])
    norm = np.linalg.norm(residuals, axis=1)
    fig, (ax, bars) = plt.subplots(1, 2, figsize=(13, 5.5), width_ratios=(1.6, 1))
    scale = 0.05 * min(camera.width, camera.height) / max(float(np.percentile(norm, 95)), 1e-9)
    quiver = ax.quiver(
        pixels[:, 0],
        pixels[:, 1],
        residuals[:, 0],
        residuals[:, 1],
        norm,
        angles="xy",
        scale_units="xy",
        scale=1.0 / scale,
        cmap="viridis",
    )
    ax.scatter(*pixels[outliers].T, s=40, facecolors="none", edgecolors="red", label="outlier")
    ax.set_xlim(-0.5, camera.width - 0.5)
    ax.set_ylim(camera.height - 0.5, -0.5)
    ax.set_aspect("equal")
    ax.set_title(f"residuals x{scale:.0f} ({camera.MODEL}, rms {calibration.rms_px:.3f} px)")
    ax.set_xlabel("u [px]")
    ax.set_ylabel("v [px]")
    fig.colorbar(quiver, ax=ax, label="|residual| [px]")
    if outliers.any():
        ax.legend(loc="lower right")
    names = [v.name for v in calibration.views]
    bars.barh(range(len(names)), [v.rms_px for v in calibration.views])
    bars.set_yticks(range(len(names)), names, fontsize=7)
    bars.invert_yaxis()
    bars.set_xlabel("RMS [px]")
    bars.set_title("per image")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
