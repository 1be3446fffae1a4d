"""Re-run some datasets of the suite and splice their rows into its committed report::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/suite_rows.py PATTERN
        [--grid benchmarks/grids/suite.yaml] [--results runs/suite-rows] [--report reports/suite]
        [--workers N]

For a change that moves only some datasets' results (a loader fix, say) when the full suite's
results folder (``make suite``'s ``runs/suite``, hours of renders and cells) is not at hand. It
runs the suite grid's datasets whose label matches the regular expression PATTERN (``omnislam
compare``, resumable: an interrupted run continues), reports them (``omnislam report``, as ``make
suite`` does) and puts their results into the report in place of the old ones:

* ``tables/LABEL-*.csv|tex`` copied from the new report;
* the datasets' rows of ``tables/ate-rmse`` and ``tables/verdict`` (CSV and LaTeX) and, in
  ``report.md`` and ``index.html``, their verdict notes, their rows of the verdict, ATE and
  provenance tables and their sections replaced, and the CSV/LaTeX files that ``index.html``
  inlines re-encoded (the summary figures, drawn over every dataset, are not: ``make suite``
  redraws them);
* a provenance row names the re-run datasets, the commit and the date.

Every other row stays as the full run left it. The results table of the README and of
``docs/results/index.md`` is then ``benchmarks/suite_table.py`` (this script runs it for both).
Nothing is written unless every step succeeded: a row or section of a matched dataset missing
from either report is an error.
"""

from __future__ import annotations

import argparse
import base64
import csv
import datetime as dt
import html
import io
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml

from omnislam.harness.grid import load_grid
from omnislam.report.tables import latex_escape

REPO = Path(__file__).resolve().parents[1]
#: tables of the whole suite, one row per dataset
SUITE_TABLES = ("ate-rmse", "verdict")
#: the paragraphs ``omnislam report`` writes after the last dataset's section, which a dataset's
#: section does not take along (a regular expression)
TRAILERS = "(?:Figures: not drawn|Exports: )"


class SpliceError(Exception):
    """The old and the new report do not have the same rows or sections to exchange."""


def subset_grid(path: Path, pattern: str) -> tuple[dict, list[str]]:
    """The grid file's contents with only the datasets whose label (as ``omnislam compare``
    labels them, ``harness.grid``) matches ``pattern``, and those labels. Relative dataset
    paths are made absolute, so the subset grid may be written anywhere."""
    grid = yaml.safe_load(path.read_text())
    labels = load_grid(path).datasets
    if len(labels) != len(grid["datasets"]):
        raise SpliceError(f"{path}: {len(grid['datasets'])} dataset entries, {len(labels)} labels")
    kept, kept_labels = [], []
    for entry, label in zip(grid["datasets"], labels, strict=True):
        if not re.search(pattern, label):
            continue
        name = entry if isinstance(entry, str) else entry.get("dataset")
        local = isinstance(name, str) and (path.parent / name).exists()
        if local:  # the label kept as it was, whatever the grid derives from the new path
            entry = {**({} if isinstance(entry, str) else entry), "label": label}
            entry["dataset"] = str((path.parent / name).resolve())
        kept.append(entry)
        kept_labels.append(label)
    if not kept:
        raise SpliceError(f"no dataset of {path} matches {pattern!r}")
    return {**grid, "datasets": kept}, kept_labels


def _replace_all(old: str, new: str, pattern: str, what: str) -> str:
    """``old`` with each match of ``pattern`` replaced by the same-numbered match in ``new``
    (verdict notes may be absent from both)."""
    old_hits = list(re.finditer(pattern, old, flags=re.M | re.S))
    new_hits = list(re.finditer(pattern, new, flags=re.M | re.S))
    if not old_hits and not new_hits and what.split(" ")[1] == "notes":
        return old
    if not old_hits or len(old_hits) != len(new_hits):
        raise SpliceError(f"{what}: {len(old_hits)} in the old report, {len(new_hits)} in the new")
    out, last = [], 0
    for o, n in zip(old_hits, new_hits, strict=True):
        out += [old[last : o.start()], n.group(0)]
        last = o.end()
    return "".join(out) + old[last:]


#: what of a dataset ``report.md`` and ``index.html`` hold, as regular expressions around LABEL:
#: its rows of the verdict and ATE tables, its provenance row, its verdict sentence, its section
PAGE_PARTS = {
    "report.md": (
        ("rows", r"^\| LABEL \|[^\n]*$"),
        ("provenance", r"^\| dataset LABEL \|[^\n]*$"),
        ("notes", r"^- LABEL \([^\n]*$"),
        ("section", rf"^## LABEL — .*?(?=^## |^{TRAILERS})"),
    ),
    "index.html": (
        ("rows", r"<tr><td>LABEL</td>[^\n]*?</tr>"),
        ("provenance", r"<tr><td>dataset LABEL</td>[^\n]*?</tr>"),
        ("notes", r'<p class="note">LABEL \([^\n]*?</p>'),
        ("section", rf"<h2>LABEL — .*?(?=<h2>|<p>{TRAILERS})"),
    ),
}


def splice_page(name: str, old: str, new: str, labels: list[str], note: str) -> str:
    """report.md or index.html (``name``): the labels' rows, verdicts and sections from
    ``new``, the dating line marked and a provenance row added."""
    for label in labels:
        escaped = re.escape(html.escape(label) if name == "index.html" else label)
        for what, pattern in PAGE_PARTS[name]:
            old = _replace_all(
                old, new, pattern.replace("LABEL", escaped), f"{name} {what} of {label}"
            )
    old = _mark_made_with(old)
    if name == "index.html":
        row = f"<tr><td>rows re-run</td><td>{html.escape(note)}</td></tr>"
        return _add_provenance_row(old, r"<tr><td>runs</td>.*?</tr>", row)
    return _add_provenance_row(old, r"^\| runs \|[^\n]*$", f"| rows re-run | {note} |")


#: the report's line that dates it (``omnislam.report.sections``)
MADE_WITH = "; see Provenance at the end."
RE_RUN = "; some rows were re-run since: see Provenance at the end."


def _mark_made_with(text: str) -> str:
    """The report's "Made with ... on DATE" line, saying that rows were re-run since."""
    if RE_RUN in text:
        return text
    if text.count(MADE_WITH) != 1:
        raise SpliceError("the report has no single 'Made with ...' line")
    return text.replace(MADE_WITH, RE_RUN)


def _add_provenance_row(text: str, after: str, row: str) -> str:
    hit = re.search(after, text, flags=re.M)
    if hit is None:
        raise SpliceError("the report has no 'runs' provenance row")
    separator = "" if row.startswith("<") else "\n"
    return text[: hit.end()] + separator + row + text[hit.end() :]


def splice_table(old: str, new: str, labels: list[str], suffix: str, what: str) -> str:
    """A suite table (CSV: ``suffix`` ',', LaTeX: ' &'): the labels' rows from ``new``."""
    for label in labels:
        pattern = rf"^{re.escape(label)}{re.escape(suffix)}[^\n]*$"
        old = _replace_all(old, new, pattern, f"{what} row {label}")
    return old


def splice_csv(old: str, new: str, labels: list[str], what: str) -> str:
    """A suite CSV table: the labels' rows from ``new`` (a dataset may have several, one per
    input and method family in the verdict), laid out in ``old``'s columns.

    A report leaves out an estimator's "min" and "max" columns when no dataset ran it on several
    seeds, so the re-run datasets' report may lack columns the whole suite's has: those cells
    are empty, as they are in the whole report for an estimator run once.
    """
    old_rows = list(csv.reader(io.StringIO(old)))
    new_rows = list(csv.reader(io.StringIO(new)))
    header, new_header = old_rows[0], new_rows[0]
    missing = [c for c in new_header if c not in header]
    lacking = [
        c for c in header if c not in new_header and not c.endswith((" min", " max"))
    ]
    if missing or lacking:
        raise SpliceError(f"{what}: columns {missing or lacking} are in one report only")
    by_label: dict[str, list[dict[str, str]]] = {}
    for row in new_rows[1:]:
        by_label.setdefault(row[0], []).append(dict(zip(new_header, row, strict=True)))
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(header)
    seen = set()
    for row in old_rows[1:]:
        if row[0] not in labels:
            writer.writerow(row)
            continue
        if row[0] not in by_label:
            raise SpliceError(f"{what}: no row {row[0]} in the new report")
        if row[0] not in seen:  # the label's rows of the new report, once, where its first was
            writer.writerows([r.get(column, "") for column in header] for r in by_label[row[0]])
        seen.add(row[0])
    if seen != set(labels):
        raise SpliceError(f"{what}: no row {sorted(set(labels) - seen)} in the old report")
    return out.getvalue()


def reencode_links(page: str, replaced: dict[bytes, bytes]) -> str:
    """``page`` with every inlined ``data:`` link whose content is a key of ``replaced``
    re-encoded with its value."""

    def swap(match: re.Match) -> str:
        content = base64.b64decode(match.group(2))
        if content not in replaced:
            return match.group(0)
        return match.group(1) + base64.b64encode(replaced[content]).decode("ascii")

    return re.sub(r'(href="data:[^";,]+(?:;[^";,]+)*;base64,)([A-Za-z0-9+/=]+)', swap, page)


def _header(table: str) -> str | None:
    """A suite table's line of column names (CSV or LaTeX)."""
    return next((line for line in table.splitlines() if line.startswith("dataset")), None)


def splice_report(old_dir: Path, new_dir: Path, labels: list[str], note: str) -> dict[Path, str]:
    """The files of ``old_dir`` to write (path -> text), the labels' results from ``new_dir``."""
    out: dict[Path, str] = {}
    replaced: dict[bytes, bytes] = {}
    for name in SUITE_TABLES:
        for ext, suffix in ((".csv", ","), (".tex", " &")):
            path = Path("tables") / f"{name}{ext}"
            old = (old_dir / path).read_text()
            new = (new_dir / path).read_text()
            if ext == ".csv":
                out[path] = splice_csv(old, new, labels, str(path))
            else:
                if _header(old) != _header(new):
                    raise SpliceError(f"{path}: the new report's columns differ from the old's")
                out[path] = splice_table(old, new, labels, suffix, str(path))
            replaced[old.encode()] = out[path].encode()
    for ext in (".csv", ".tex"):
        path = Path("tables") / f"provenance{ext}"
        old, new = (old_dir / path).read_text(), (new_dir / path).read_text()
        suffix = "," if ext == ".csv" else " &"
        rows = [f"dataset {label}" for label in labels]
        text = splice_table(old, new, rows, suffix, str(path))
        if ext == ".csv":
            line = io.StringIO()
            csv.writer(line, lineterminator="").writerow(["rows re-run", note])
            row = line.getvalue()
        else:
            row = f"rows re-run & {latex_escape(note)} \\\\"
        out[path] = _add_provenance_row(text, rf"^runs{re.escape(suffix)}[^\n]*$", row)
        replaced[old.encode()] = out[path].encode()
    for path in sorted((new_dir / "tables").glob("*")):
        if path.stem not in (*SUITE_TABLES, "estimators", "provenance"):
            out[Path("tables") / path.name] = path.read_text()
    for name in PAGE_PARTS:
        page = splice_page(
            name, (old_dir / name).read_text(), (new_dir / name).read_text(), labels, note
        )
        out[Path(name)] = reencode_links(page, replaced) if name == "index.html" else page
    return out


def run(command: list[str]) -> None:
    print("  $ " + " ".join(command), file=sys.stderr, flush=True)
    subprocess.run(command, check=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("pattern", help="regular expression on the dataset labels")
    parser.add_argument("--grid", type=Path, default=REPO / "benchmarks/grids/suite.yaml")
    parser.add_argument("--results", type=Path, default=Path("runs/suite-rows"))
    parser.add_argument("--report", type=Path, default=REPO / "reports/suite")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)

    try:
        grid, labels = subset_grid(args.grid, args.pattern)
    except SpliceError as error:
        print(f"suite_rows: {error}", file=sys.stderr)
        return 2
    print(f"re-running {len(labels)} datasets: {', '.join(labels)}", file=sys.stderr)
    args.results.mkdir(parents=True, exist_ok=True)
    grid_path = args.results.parent / f"{args.results.name}.grid.yaml"
    grid_path.write_text(yaml.safe_dump(grid, sort_keys=False))
    bin_dir = Path(sys.executable).parent
    resume = ["--resume"] if any(args.results.iterdir()) else ["--overwrite"]
    run([str(bin_dir / "omnislam"), "compare", str(grid_path), "--out", str(args.results),
         "--workers", str(args.workers), *resume])  # fmt: skip
    commit = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], cwd=REPO, capture_output=True, text=True
    ).stdout.strip()
    note = (
        f"{', '.join(labels)}: re-run at commit {commit} on "
        f"{dt.datetime.now(dt.UTC).date().isoformat()} "
        f"(benchmarks/suite_rows.py '{args.pattern}'); the other rows are the full run's"
    )
    with tempfile.TemporaryDirectory() as tmp:
        new_dir = Path(tmp) / "report"
        run([str(bin_dir / "omnislam"), "report", str(args.results), "--out", str(new_dir),
             "--no-exports", "--no-figures", "--overwrite"])  # fmt: skip
        try:
            files = splice_report(args.report, new_dir, labels, note)
        except SpliceError as error:
            print(f"suite_rows: {error}; nothing written", file=sys.stderr)
            return 2
    for path, text in files.items():
        (args.report / path).write_text(text)
    print(f"spliced {len(files)} files of {args.report}", file=sys.stderr)
    for page in ("README.md", "docs/results/index.md"):
        run([sys.executable, str(REPO / "benchmarks/suite_table.py"), "--report", str(args.report),
             "--readme", str(REPO / page)])  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
