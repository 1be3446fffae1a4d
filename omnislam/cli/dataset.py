"""``omnislam dataset list``, ``synth``, ``check``, ``export`` and ``import``.

``list`` prints every registered real dataset (source, sensors, ground truth, found or not and
where it was looked for) and the synthetic presets. ``synth`` renders a synthetic world; it is
implemented by the synthetic-world work as ``omnislam.datasets.synthetic.cli_synth(args)``
(args: preset, out, seed, frames, image_every, backend, overwrite), with its progress on stderr;
an existing
dataset folder is replaced only with ``--overwrite``.

``check DIR`` validates an omnislam folder (docs/datasets/folder-format.md): one line per
problem (file, line, what) on stdout, exit code 2 when there is any. ``export NAME --out DIR``
writes any dataset omnislam reads (a registered name or a path, with its loader options) as an
omnislam folder. ``import BAG --out DIR --topic ROLE=/topic ...`` converts a ROS 1 or ROS 2 bag
(the ``rosbag`` extra).
"""

from __future__ import annotations

import argparse
import json

#: the ``--groundtruth-kind`` values of ``dataset import`` (``GroundTruthKind`` without NONE;
#: named here so that the parser imports nothing), the first the default
GROUNDTRUTH_KINDS = ("motion-capture", "gps-partial", "pseudo", "reference", "exact")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "dataset",
        help="list known datasets, render synthetic ones, check, export and import folders",
    )
    p.set_defaults(handler=lambda args: p.print_help() or 2)
    actions = p.add_subparsers(dest="action", metavar="ACTION")

    listing = actions.add_parser("list", help="registered real datasets and synthetic presets")
    listing.add_argument("--json", action="store_true", help="print JSON instead of a table")
    listing.set_defaults(handler=run_list)

    # ---- synth: owned by the synthetic-world work (omnislam.datasets.synthetic.cli_synth) ----
    synth = actions.add_parser("synth", help="render a synthetic preset to a dataset folder")
    synth.add_argument("preset", help="preset name (see `omnislam dataset list`)")
    synth.add_argument("--out", required=True, help="output folder")
    synth.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    synth.add_argument(
        "--frames",
        type=int,
        default=None,
        metavar="N",
        help="end the run at its N-th image (default: the whole route); the odometry frames "
        "up to that image are kept",
    )
    synth.add_argument(
        "--image-every",
        type=int,
        default=None,
        metavar="K",
        help="one image every K odometry steps (default: the preset's); the same world, route "
        "and odometry at another image rate",
    )
    synth.add_argument(
        "--backend",
        choices=("open3d", "numpy"),
        default=None,
        help="ray-casting backend (default: open3d when installed)",
    )
    synth.add_argument(
        "--overwrite", action="store_true", help="replace an existing synthetic dataset folder"
    )
    synth.add_argument(
        "--realism",
        default="clean",
        metavar="LEVEL",
        help="clean (default: the renderer's images) or realistic (a camera sensor: motion "
        "blur, noise, auto-exposure, vignetting, JPEG)",
    )
    synth.set_defaults(handler=run_synth)
    # ---- end of synth ----
    _add_folder_actions(actions)


def _add_folder_actions(actions: argparse._SubParsersAction) -> None:
    """``check``, ``export`` and ``import``: the omnislam folder format."""
    check = actions.add_parser("check", help="validate an omnislam folder, one line per problem")
    check.add_argument("folder", metavar="DIR", help="the folder (with its dataset.json)")
    check.set_defaults(handler=run_check)

    export = actions.add_parser(
        "export", help="write any dataset omnislam reads as an omnislam folder"
    )
    export.add_argument("dataset", metavar="NAME", help="registered dataset name or path")
    export.add_argument("--out", required=True, metavar="DIR", help="folder to write")
    export.add_argument(
        "--set", dest="options", action="append", default=[], metavar="KEY=VALUE",
        help="loader option (repeatable, e.g. robot=2)",
    )
    export.add_argument("--overwrite", action="store_true", help="replace an existing folder")
    export.set_defaults(handler=run_export)

    bag = actions.add_parser(
        "import", help="convert a ROS 1 or ROS 2 bag into an omnislam folder (extra: rosbag)"
    )
    bag.add_argument("bag", metavar="BAG", help="a ROS 1 .bag file or a ROS 2 bag folder")
    bag.add_argument("--out", required=True, metavar="DIR", help="folder to write")
    bag.add_argument(
        "--topic", dest="topics", action="append", default=[], metavar="ROLE=/topic",
        help="what a topic is: odometry, images, scan, groundtruth (repeatable); "
        "groundtruth=/tf takes the transforms of --gt-frame in --world-frame",
    )
    bag.add_argument("--calibration", metavar="YAML",
                     help="camera calibration (omnislam rig YAML) of the images")
    bag.add_argument("--world-frame", default="world", help="parent frame of ground truth on /tf")
    bag.add_argument("--gt-frame", default="base_link", help="child frame of ground truth on /tf")
    bag.add_argument(
        "--laser-offset", default=None, metavar="X,Y,YAW",
        help="the laser's pose on the robot [m, m, rad] (default: read from the bag's "
        "/tf_static, the scans' frame in the odometry's child frame)",
    )
    bag.add_argument("--source", default=None, help="one line saying where the data come from")
    bag.add_argument("--licence", default="unstated", help="the data's licence")
    bag.add_argument(
        "--groundtruth-kind", default=GROUNDTRUTH_KINDS[0], choices=GROUNDTRUTH_KINDS,
        help="where the ground-truth topic's poses come from, written as the folder's "
        "ground_truth.kind (default: motion-capture)",
    )
    bag.add_argument("--overwrite", action="store_true", help="replace an existing folder")
    bag.set_defaults(handler=run_import)


def run_list(args: argparse.Namespace) -> int:
    from omnislam.datasets.registry import list_datasets

    rows = list_datasets()
    if args.json:
        print(json.dumps([_row_dict(r) for r in rows], indent=2))
        return 0
    header = ("name", "kind", "ground truth", "found", "location")
    table = [(r.name, r.kind, r.ground_truth, "yes" if r.found else "NO", r.location) for r in rows]
    widths = [max(len(h), *(len(t[i]) for t in table)) for i, h in enumerate(header)]
    print("  ".join(h.ljust(w) for h, w in zip(header, widths, strict=True)).rstrip())
    for t in table:
        print("  ".join(c.ljust(w) for c, w in zip(t, widths, strict=True)).rstrip())
    print()
    for r in rows:
        if r.kind == "real":
            print(f"{r.name}: {r.source}; {r.sensors}")
    missing = [r for r in rows if not r.found]
    if missing:
        print(
            f"\n{len(missing)} dataset(s) not found; set OMNISLAM_DATA to the folder holding "
            "the real data (mrclam/, victoria_park/, carmen/)."
        )
    return 0


def _row_dict(row: object) -> dict[str, object]:
    return {name: getattr(row, name) for name in row.__slots__}


def run_synth(args: argparse.Namespace) -> int:
    from omnislam._files import check_overwrite
    from omnislam.errors import ConfigError

    try:
        from omnislam.datasets.synthetic import cli_synth, is_synthetic_folder
    except (ImportError, AttributeError) as exc:
        raise ConfigError(f"dataset synth cannot run in this installation ({exc})") from None
    check_overwrite(args.out, args.overwrite, "synthetic dataset folder", is_synthetic_folder)
    return int(cli_synth(args) or 0)


def run_check(args: argparse.Namespace) -> int:
    from omnislam.datasets.folder import check_folder

    problems = check_folder(args.folder)
    for problem in problems:
        print(problem)
    if problems:
        return 2
    print(f"{args.folder}: a valid omnislam folder")
    return 0


def _is_folder_output(path: object) -> bool:
    from omnislam.datasets.folder import is_folder

    return is_folder(path)  # type: ignore[arg-type]


def run_export(args: argparse.Namespace) -> int:
    from omnislam._files import check_output_location, check_overwrite
    from omnislam.cli.run import parse_set
    from omnislam.datasets.folder import export_folder
    from omnislam.datasets.registry import load_dataset

    check_overwrite(args.out, args.overwrite, "omnislam folder", _is_folder_output)
    check_output_location(args.out, "omnislam folder")
    sequence = load_dataset(args.dataset, parse_set(args.options))
    out = export_folder(sequence, args.out)
    print(f"wrote {out}: {len(sequence)} frames of {args.dataset} as an omnislam folder")
    return 0


def _laser_offset(text: str | None) -> list[float] | None:
    """``--laser-offset X,Y,YAW`` as three floats (None when not given).

    Raises:
        ConfigError: not three numbers.
    """
    from omnislam.errors import ConfigError

    if text is None:
        return None
    try:
        values = [float(part) for part in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 3:
        raise ConfigError(f"--laser-offset needs X,Y,YAW (three numbers), got {text!r}")
    return values


def run_import(args: argparse.Namespace) -> int:
    from omnislam._files import check_output_location, check_overwrite
    from omnislam.datasets.rosbag import import_bag, parse_topics
    from omnislam.datasets.sequence import GroundTruthKind

    topics = parse_topics(args.topics)
    check_overwrite(args.out, args.overwrite, "omnislam folder", _is_folder_output)
    check_output_location(args.out, "omnislam folder")
    out = import_bag(
        args.bag,
        args.out,
        topics,
        calibration=args.calibration,
        world_frame=args.world_frame,
        gt_frame=args.gt_frame,
        source=args.source,
        licence=args.licence,
        groundtruth_kind=GroundTruthKind(args.groundtruth_kind),
        laser_offset_r=_laser_offset(args.laser_offset),
    )
    print(f"wrote {out}: an omnislam folder from {args.bag}")
    return 0
