"""``omnislam dataset list`` and ``omnislam dataset synth``.

``list`` prints every registered real dataset (source, sensors, ground truth, found or not and
where it was looked for) and the synthetic presets. ``synth`` renders a synthetic world; it is
implemented by the synthetic-world work as ``omnislam.datasets.synthetic.cli_synth(args)``
(args: preset, out, seed, frames, image_every, backend, overwrite), with its progress on stderr;
an existing
dataset folder is replaced only with ``--overwrite``.
"""

from __future__ import annotations

import argparse
import json


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("dataset", help="list known datasets, render synthetic ones")
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
    synth.set_defaults(handler=run_synth)
    # ---- end of synth ----


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
