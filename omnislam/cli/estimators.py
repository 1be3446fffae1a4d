"""List the registered estimators and their options.

For each estimator of the registry (the built-ins and the installed plugins): what it is, the
plugin it comes from, the observation streams it consumes, whether this installation can run it,
its presets, and its main --set KEY=VALUE options with their defaults and meaning, then the
sections its other options live in; --all lists every option, section by section. Everything is
read from the estimators' configuration classes and their documentation, so the list cannot
drift from the code. The options the harness takes for every estimator (modality, prior_map,
wrong_id_fraction, clutter_per_frame) end the list.
"""

from __future__ import annotations

import argparse

#: options whose default the factories take from the dataset when it states one
FROM_THE_DATA = {
    "sensor_height_m": "(default: the height of the dataset's camera rig, when it has one)",
}


def harness_options() -> dict[str, tuple[str, str]]:
    """Options the harness (``harness.execute``) takes for every estimator:
    key -> (what it takes, meaning)."""
    from omnislam.core.modality import MODALITY_OPTION, Modality
    from omnislam.harness.perturb import CLUTTER_OPTION, WRONG_ID_OPTION
    from omnislam.harness.prior import PRIOR_MAP_OPTION

    return {
        MODALITY_OPTION: (
            "|".join(m.value for m in Modality),
            "the observation stream to consume instead of the one the shared rule picks.",
        ),
        PRIOR_MAP_OPTION: (
            "RUN_DIR",
            "the landmarks of an earlier run as the prior map (for localisers).",
        ),
        WRONG_ID_OPTION: (
            "float",
            "re-label this fraction of the sightings with another landmark's id before the run.",
        ),
        CLUTTER_OPTION: (
            "float",
            "add this many false range-bearing detections per frame (Poisson mean), without ids.",
        ),
    }


def loader_options() -> dict[str, tuple[str, ...]]:
    """Dataset format -> the ``--set`` keys its loader takes (formats that take any)."""
    from omnislam.datasets.registry import FORMATS

    return {fmt.value: tuple(spec.options) for fmt, spec in FORMATS.items() if spec.options}


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "estimators",
        help="list the estimators with their options, defaults and meaning",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("names", nargs="*", metavar="NAME", help="only these estimators")
    p.add_argument("--all", action="store_true", help="every option, section by section")
    p.add_argument("--json", action="store_true", help="print JSON (every option, in full)")
    p.set_defaults(handler=run)


def _availability(name: str) -> str:
    from omnislam.errors import OmnislamError
    from omnislam.estimators import estimator_factory

    try:
        estimator_factory(name)
    except (OmnislamError, ImportError) as exc:
        return f"not available: {exc}"
    return "available"


def describe(name: str) -> dict[str, object]:
    """What ``omnislam estimators`` says about one estimator (the JSON object)."""
    from omnislam.estimators import ESTIMATORS, estimator_defaults, estimator_origin
    from omnislam.options import describe_options, main_options

    entry = ESTIMATORS[name]
    config, presets = estimator_defaults(name)
    options = [] if config is None else describe_options(config)
    main = () if config is None else main_options(config)
    return {
        "name": name,
        "summary": entry.summary,
        "origin": estimator_origin(name),
        "consumes": sorted(m.value for m in entry.modalities),
        "status": _availability(name),
        "presets": list(presets),
        "preset": entry.preset or None,
        "main_options": list(main),
        "options": [
            {
                "key": o.key,
                "section": o.section,
                "kind": o.kind,
                "default": o.default,
                "meaning": o.meaning,
            }
            for o in options
        ],
    }


def _option_lines(options: list[dict], indent: str) -> list[str]:
    """``KEY=DEFAULT  [KIND]  first sentence`` per option, the columns aligned."""
    from omnislam.options import first_sentence

    width = max(len(f"{o['key']}={o['default']}") for o in options)
    lines = []
    for o in options:
        setting = f"{o['key']}={o['default']}"
        meaning = first_sentence(str(o["meaning"])).replace("``", "")
        leaf = str(o["key"]).rsplit(".", 1)[-1]
        if leaf in FROM_THE_DATA:
            meaning += f" {FROM_THE_DATA[leaf]}"
        lines.append(f"{indent}{setting.ljust(width)}  [{o['kind']}]  {meaning}")
    return lines


def _print_options(d: dict, every: bool) -> None:
    """The options of one described estimator: the main ones and the sections' names, or
    (``every``) all of them section by section."""
    options: list[dict] = d["options"]
    if not options:
        print("  options: none")
        return
    main = [o for key in d["main_options"] for o in options if o["key"] == key]
    if every or not main:
        print("  options (--set KEY=VALUE; the default shown, then what it takes):")
        sections = dict.fromkeys(o["section"] for o in options)
        for section in sections:
            members = [o for o in options if o["section"] == section]
            if section:
                print(f"   [{section}]")
            print("\n".join(_option_lines(members, "    ")))
        return
    print("  main options (--set KEY=VALUE; the default shown, then what it takes):")
    print("\n".join(_option_lines(main, "    ")))
    counts: dict[str, int] = {}
    for o in options:
        if o not in main:
            top = str(o["key"]).split(".", 1)[0] if o["section"] else "(top level)"
            counts[top] = counts.get(top, 0) + 1
    listed = ", ".join(f"{name} ({n})" for name, n in counts.items())
    print(f"  more options, by section (--all lists them): {listed}")


def run(args: argparse.Namespace) -> int:
    import json

    from omnislam.errors import ConfigError
    from omnislam.estimators import ESTIMATORS, unknown_estimator_message

    unknown = [n for n in args.names if n not in ESTIMATORS]
    if unknown:
        raise ConfigError(unknown_estimator_message(unknown[0]))
    names = list(dict.fromkeys(args.names)) or list(ESTIMATORS)  # each named one once
    described = [describe(name) for name in names]
    harness = harness_options()
    loaders = loader_options()
    if args.json:
        print(
            json.dumps(
                {
                    "estimators": described,
                    "harness_options": [
                        {"key": key, "kind": kind, "meaning": meaning}
                        for key, (kind, meaning) in harness.items()
                    ],
                    "loader_options": {fmt: list(keys) for fmt, keys in loaders.items()},
                },
                indent=2,
            )
        )
        return 0
    for d in described:
        print(f"{d['name']}: {d['summary']}")
        if d["origin"] != "omnislam":
            print(f"  plugin: {d['origin']} (entry point group omnislam.estimators)")
        consumes = ", ".join(d["consumes"]) or "no sightings (odometry only)"  # type: ignore[arg-type]
        print(f"  consumes: {consumes}; {d['status']}")
        if d["presets"]:
            presets = ", ".join(
                f"{p} (default)" if p == d["preset"] else str(p)
                for p in d["presets"]  # type: ignore[union-attr]
            )
            print(f"  presets (--set preset=NAME): {presets}")
        _print_options(d, args.all)
        print()
    print("options of every estimator (taken by the harness):")
    width = max(len(k) for k in harness)
    for key, (kind, meaning) in harness.items():
        print(f"    {key.ljust(width)}  [{kind}]  {meaning}")
    print("options of the dataset loaders (by dataset format; --set passes them to the loader):")
    for fmt, keys in loaders.items():
        print(f"    {fmt}: {', '.join(keys)}")
    return 0
