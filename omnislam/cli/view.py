"""Write a Rerun recording of one run.

Writes FILE.rrd (default RUN_DIR/run.rrd) with the trajectory against the ground truth, the
landmarks with their covariance ellipsoids, the sightings over time and, for image datasets,
every image with its keypoints. --spawn then opens it in the Rerun viewer; open it later with
rerun FILE.rrd. Needs the view extra: pip install '.[view]' in a clone.
"""

from __future__ import annotations

import argparse

#: recording file written into the RUN_DIR when --out is not given
DEFAULT_NAME = "run.rrd"


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "view",
        help="write (or open) a Rerun recording of a run: trajectory, map, images, sightings",
        description=__doc__,
    )
    p.add_argument("run_dir", metavar="RUN_DIR", help="folder written by `omnislam run`")
    p.add_argument(
        "--out",
        default=None,
        metavar="FILE.rrd",
        help=f"recording to write (default RUN_DIR/{DEFAULT_NAME})",
    )
    p.add_argument("--spawn", action="store_true", help="open the recording in the Rerun viewer")
    p.add_argument("--no-images", action="store_true", help="leave the images out")
    p.add_argument(
        "--image-every", type=int, default=1, metavar="K", help="log every K-th image only (1)"
    )
    p.add_argument("--overwrite", action="store_true", help="replace an existing recording")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    import subprocess
    import sys
    from pathlib import Path

    from omnislam._files import check_output_location, check_overwrite
    from omnislam._optional import require
    from omnislam._progress import Progress
    from omnislam.errors import ConfigError, DataError
    from omnislam.harness.layout import CONFIG
    from omnislam.report.view import ViewOptions, write_recording

    run_dir = Path(args.run_dir)
    if not (run_dir / CONFIG).is_file():
        raise DataError(f"not a RUN_DIR (no {CONFIG})", run_dir)
    if args.image_every < 1:
        raise ConfigError(f"--image-every must be >= 1, got {args.image_every}")
    out = Path(args.out) if args.out else run_dir / DEFAULT_NAME
    if out.suffix != ".rrd":
        raise ConfigError(f"{out}: a Rerun recording is a .rrd file")
    check_overwrite(out, args.overwrite, "recording", lambda p: p.is_file())
    check_output_location(out, "recording")
    require("rerun")  # before any work: the error names the extra
    with Progress(f"view {run_dir.name}", None, "frame") as bar:
        summary = write_recording(
            run_dir,
            out,
            ViewOptions(images=not args.no_images, image_every=args.image_every),
            on_frame=lambda done, total: bar.update(done, total=total, doing="logging"),
        )
    for note in summary.notes:
        print(f"note: {note}", file=sys.stderr)
    print(
        f"omnislam view: {summary.frames} frames, {summary.images} images, "
        f"{summary.landmarks} landmarks ({summary.ellipsoids} with covariance ellipsoids) -> "
        f"{out} (open it with: rerun {out})"
    )
    if args.spawn:
        subprocess.Popen(  # the viewer outlives this command
            [sys.executable, "-m", "rerun", str(out)],
            stdin=subprocess.DEVNULL,
            start_new_session=True,
        )
    return 0
