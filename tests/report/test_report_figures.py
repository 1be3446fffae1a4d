"""The report's figures: vector (or >= 150 dpi), one colour per estimator in every figure and
table, every occupancy grid, and -- on the same report -- the verdict, the provenance block and
the CSV and LaTeX tables.

The small grid: dead reckoning and four fake estimators (``report_fakes``: dead reckoning plus a
wobble; one of them also maps points on the walls) on the 60-frame room log over two seeds, so
the report has more than three estimators, a landmark map with ellipses and laser scans.
"""

from __future__ import annotations

import base64
import csv
import io
import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from room_log import write_room_log

from omnislam.estimators import Family
from omnislam.harness.grid import parse_grid
from omnislam.harness.runner import SerialExecutor, run_grid
from omnislam.report import palette, plots
from omnislam.report.comparison import write_report
from omnislam.report.figures import FIGURES
from omnislam.report.options import ReportOptions

SVG = "{http://www.w3.org/2000/svg}"
XLINK_HREF = "{http://www.w3.org/1999/xlink}href"
MIN_DPI = 150.0
#: the report's column is 1200 px wide; a figure must fit it unscaled (1 pt = 4/3 px)
PAGE_PX = 1200
COLOUR = re.compile(r"(?:fill|stroke)\s*:\s*(#[0-9a-fA-F]{6})")
FAKES = ("tidy_odo", "rough_odo", "third_odo", "mapper_odo")
#: the fakes' method families: the verdict ranks families, so each is its own but two
FAMILIES = {
    "tidy_odo": Family.PARTICLE_FILTER,
    "rough_odo": Family.FACTOR_GRAPH,
    "third_odo": Family.KALMAN_FILTER,
    "mapper_odo": Family.KALMAN_FILTER,
}


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> tuple[Path, Path, object]:
    import omnislam.estimators as registry

    tmp = tmp_path_factory.mktemp("figures")
    with pytest.MonkeyPatch.context() as patch:
        for name in FAKES:
            target = (
                "report_fakes:make_mapper" if name == "mapper_odo" else "report_fakes:make_wobbly"
            )
            entry = registry.EstimatorEntry(
                target, frozenset(), stochastic=True, family=FAMILIES[name]
            )
            patch.setitem(registry.ESTIMATORS, name, entry)
        write_room_log(tmp / "data" / "room.log", frames=60)
        grid = {
            "name": "figures",
            "datasets": ["data/room.log"],
            "estimators": [
                "deadreckoning",
                {"estimator": "tidy_odo", "options": {"amplitude": 0.02, "seed_gain": 0.5}},
                {"estimator": "rough_odo", "options": {"amplitude": 0.4, "seed_gain": 0.5}},
                {"estimator": "third_odo", "options": {"amplitude": 0.1}},
                {"estimator": "mapper_odo", "options": {"amplitude": 0.05, "landmarks": 16}},
            ],
            "seeds": [0, 1],
        }
        results = tmp / "results"
        run_grid(parse_grid(json.dumps(grid), tmp / "grid.yaml"), results, SerialExecutor)
        summary = write_report(
            results,
            tmp / "report",
            ReportOptions(exports=False, command=("omnislam", "report", "results")),
        )
    return results, tmp / "report", summary


def columns_of(results: Path) -> dict[str, list[float]]:
    out: dict[str, list[float]] = {}
    for row in json.loads((results / "results.json").read_text())["cells"]:
        assert row["status"] != "failed", row["error"]
        out.setdefault(row["column"], []).append(row["metrics"]["ate_rmse_m"])
    return out


def inline_svgs(page: str) -> list[str]:
    return re.findall(r"<svg\b.*?</svg>", page, flags=re.S)


def estimator_colours(root: ET.Element) -> dict[str, set[str]]:
    """label -> the colours of every element tagged with that estimator's id."""
    found: dict[str, set[str]] = {}
    for element in root.iter():
        label = plots.label_of_id(element.get("id", ""))
        if label is None:
            continue
        colours = set()
        for node in element.iter():
            style = node.get("style", "")
            colours |= {c.lower() for c in COLOUR.findall(style)}
            for attribute in ("fill", "stroke"):
                value = node.get(attribute, "")
                if value.startswith("#"):
                    colours.add(value.lower())
        found.setdefault(label, set()).update(colours)
        assert colours, f"{label}: an element with no colour"
        # black is allowed only as an outline beside the estimator's colour
        assert colours - {palette.TRUTH}, f"{label}: drawn in black only"
    return found


def png_size(data_uri: str) -> tuple[int, int]:
    from PIL import Image

    payload = re.sub(r"\s", "", data_uri.split(",", 1)[1])
    with Image.open(io.BytesIO(base64.b64decode(payload, validate=True))) as image:
        return image.size


def assert_vector_or_fine_raster(root: ET.Element, name: str) -> None:
    """Every raster inside the SVG is >= MIN_DPI at its drawn size, or one pixel per data cell
    drawn pixelated (sharp at any size)."""
    view_width = float(root.get("viewBox").split()[2])
    width_pt = float(root.get("width").removesuffix("pt"))
    pt_per_unit = width_pt / view_width
    for image in root.iter(f"{SVG}image"):
        if "pixelated" in image.get("style", ""):
            continue
        assert image.get("transform", "").startswith("scale(1 -1)"), name  # drawn unscaled
        pixels_wide, _ = png_size(image.get(XLINK_HREF))
        inches = float(image.get("width")) * pt_per_unit / 72.0
        assert pixels_wide / inches >= MIN_DPI, (name, pixels_wide / inches)


def test_figures_are_vector_readable_and_one_colour_per_estimator(report):
    results, out, summary = report
    columns = list(columns_of(results))
    expected = palette.colours(columns)
    assert expected["deadreckoning"] == palette.DEAD_RECKONING
    assert len(set(expected.values())) == len(columns)
    page = (out / "index.html").read_text()
    assert "<img" not in page and "data:image/png" not in page.split("<svg", 1)[0]
    svgs = inline_svgs(page)
    # the summary figures, then every figure of FIGURES in that order
    summary_figures = ["room-ate-by-input.svg", "accuracy-vs-time.svg", "families.svg"]
    stems = summary_figures + [f"room-{stem}.svg" for stem, _ in FIGURES]
    assert list(summary.figures) == stems
    assert len(svgs) == len(stems)
    md = (out / "report.md").read_text()
    seen: dict[str, dict[str, set[str]]] = {}
    for name, inline in zip(summary.figures, svgs, strict=True):
        standalone = (out / name).read_text()
        assert f"]({name})" in md
        assert inline.split(">", 1)[1] in standalone  # the page shows the file's drawing
        root = ET.fromstring(standalone)
        assert root.tag == f"{SVG}svg"
        assert ET.fromstring(inline).tag == f"{SVG}svg"
        width_px = float(root.get("width").removesuffix("pt")) * 4.0 / 3.0
        assert 300 < width_px <= PAGE_PX - 32, (name, width_px)
        texts = list(root.iter(f"{SVG}text"))
        assert texts, name  # text stays text
        sizes = [
            float(s)
            for t in texts
            for s in re.findall(r"font-size: ([\d.]+)px", t.get("style", ""))
        ]
        assert sizes and min(sizes) >= 7.0, (name, min(sizes, default=None))
        assert_vector_or_fine_raster(root, name)
        seen[name] = estimator_colours(root)
    # one colour per estimator, the palette's, in every figure
    for name, found in seen.items():
        for label, colours in found.items():
            assert colours - {palette.TRUTH} == {expected[label]}, (name, label, colours)
    everyone = set(columns)
    for stem in (
        "ate-seeds",
        "accuracy-vs-time",
        "trajectories",
        "error-over-distance",
        "step-time",
        "occupancy",
    ):
        assert set(seen[f"room-{stem}.svg"]) == everyone, stem
    assert set(seen["room-ate-by-input.svg"]) == everyone
    assert set(seen["accuracy-vs-time.svg"]) == everyone - {"deadreckoning"}  # its reference
    assert set(seen["room-landmarks.svg"]) == {"mapper_odo"}  # the only one with a map
    # and in every table of the page: the swatch before an estimator's name has its colour
    swatches = re.findall(
        r'<span class="swatch" style="background:(#\w+)"[^>]*></span>([^<]+)<', page
    )
    assert {label for _, label in swatches} == everyone
    for colour, label in swatches:
        assert colour == expected[label], label
    # every occupancy grid the caption promises: the ground truth's and each of five estimators'
    occupancy = (out / "room-occupancy.svg").read_text()
    assert occupancy.count("scans)</text>") == 1 + len(columns)
    landmarks = (out / "room-landmarks.svg").read_text()
    assert "mapper_odo: 16 landmarks" in landmarks and "2-sigma ellipses" in landmarks


def test_report_has_the_verdict_provenance_and_publication_tables(report):
    results, out, _ = report
    ate = columns_of(results)
    medians = {c: sorted(v)[(len(v) - 1) // 2] for c, v in ate.items() if c != "deadreckoning"}
    md = (out / "report.md").read_text()
    page = (out / "index.html").read_text()
    assert md.index("## Verdict") < md.index("## ATE RMSE") < md.index("## Provenance")
    verdict = list(csv.DictReader(io.StringIO((out / "tables" / "verdict.csv").read_text())))
    # one row per family, each family's best column, ranked by its median
    best_of = {}
    for column, median in medians.items():
        family = FAMILIES[column].value
        if family not in best_of or median < medians[best_of[family]]:
            best_of[family] = column
    ranked = sorted(best_of.values(), key=medians.get)
    assert [r["best"] for r in verdict] == ranked
    assert [r["family"] for r in verdict] == [FAMILIES[c].value for c in ranked]
    for row, column in zip(verdict, ranked, strict=True):
        assert float(row["median [m]"]) == pytest.approx(medians[column], rel=1e-12)
        assert float(row["behind the best [m]"]) == pytest.approx(
            medians[column] - medians[ranked[0]], abs=1e-12
        )
        assert row["input"] == "odometry"
    # third_odo and mapper_odo share the Kalman family: only the better one is ranked
    assert len(verdict) == 3
    provenance = dict(
        list(csv.reader(io.StringIO((out / "tables" / "provenance.csv").read_text())))[1:]
    )
    assert provenance["command line"] == "omnislam report results"
    assert provenance["seeds"] == "0, 1" and "cores" in provenance["machine"]
    assert "frames 60" in provenance["dataset room"]
    assert provenance["estimator mapper_odo"] == "mapper_odo; options: amplitude=0.05, landmarks=16"
    assert ">Provenance</h2>" in page and provenance["git commit"].split()[0] in page
    names = re.findall(r"\*Table as \[CSV\]\(tables/([^)]+)\.csv\)", md)
    assert {"verdict", "ate-rmse", "estimators", "room-metrics", "provenance"} <= set(names)
    for name in names:
        rows = list(csv.reader(io.StringIO((out / "tables" / f"{name}.csv").read_text())))
        assert len(rows) >= 2 and len({len(r) for r in rows}) == 1, name  # rectangular
        tex = (out / "tables" / f"{name}.tex").read_text()
        assert tex.index(r"\toprule") < tex.index(r"\midrule") < tex.index(r"\bottomrule"), name
        assert tex.count(r"\begin{tabular}") == tex.count(r"\end{tabular}") == 1, name


def test_dense_maps_are_rasterised_at_high_resolution_and_ellipses_dropped(rng):
    truth = rng.uniform(0, 20, (30, 2))
    dense = plots.LandmarkSeries(
        "graphslam", rng.uniform(0, 20, (500, 2)), np.tile(np.eye(2) * 0.01, (500, 1, 1))
    )
    sparse = plots.LandmarkSeries(
        "ekfslam", truth + rng.normal(0, 0.1, truth.shape), np.tile(np.eye(2) * 0.01, (30, 1, 1))
    )
    svg = plots.landmark_maps(
        "t-landmarks", "t", truth, [dense, sparse], palette.colours(["graphslam", "ekfslam"])
    )
    root = ET.fromstring(svg)
    images = list(root.iter(f"{SVG}image"))
    assert len(images) == 1  # the 500 points, as one raster
    assert_vector_or_fine_raster(root, "t-landmarks")
    ellipses = [e for e in root.iter() if (plots.label_of_id(e.get("id", "")) == "ekfslam")]
    assert len(ellipses) >= 30  # the sparse map's ellipses (and its dots, title, frame)
    assert "no ellipses" in svg and "2-sigma ellipses" in svg
    found = estimator_colours(root)
    assert found["graphslam"] - {palette.TRUTH} == {palette.ESTIMATOR_COLOURS["graphslam"]}
    assert found["ekfslam"] - {palette.TRUTH} == {palette.ESTIMATOR_COLOURS["ekfslam"]}


def test_palette_is_fixed_per_estimator_whatever_subset_is_present():
    registered = list(palette.ESTIMATOR_COLOURS)
    assert len(set(palette.ESTIMATOR_COLOURS.values())) == len(registered)
    assert palette.TRUTH not in palette.ESTIMATOR_COLOURS.values()
    full = palette.colours(registered)
    for k in range(1, len(registered)):
        subset = registered[k:] + registered[:1]
        assert palette.colours(subset) == {label: full[label] for label in subset}
    assert palette.colours(["ukf", "deadreckoning"])["deadreckoning"] == palette.DEAD_RECKONING
    # labels that are no registered estimator: hashed, stable, distinct within a report
    others = [f"fastslam2 [particles={n}]" for n in (10, 20, 50, 100, 200, 500)]
    together = palette.colours([*registered, *others])
    assert len(set(together.values())) == len(together)
    assert not set(palette.EXTRA_COLOURS) & set(palette.ESTIMATOR_COLOURS.values())
    for label in others:
        assert palette.colours([label]) == {label: palette.colour(label)}
        assert together[label] in palette.EXTRA_COLOURS
    assert all(re.fullmatch(r"#[0-9a-f]{6}", c) for c in together.values())
