"""The report's sections, built once from its runs (``model.Section``), in report order.

1. the title;
2. the verdict: per dataset and input the best estimator of each method family by median ATE
   RMSE over seeds, dead reckoning excluded, how far each family is behind the best and whether
   the seed spread separates them (``metrics.verdict``), short notes on the rows that need one,
   then how to read every number;
3. the headline: ATE RMSE per dataset and estimator;
4. per dataset: its ground truth, its metrics per estimator beside the dead-reckoning baseline,
   every run's values, the association decisions each run counted, the runs that failed, its
   figures (``figures``);
5. what the report left out (figures, exports) and the notes of what could not be made;
6. the estimators of this installation and which are in the report;
7. the provenance block (``provenance``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from omnislam.errors import ConfigError
from omnislam.report.figures import dataset_figures
from omnislam.report.metric_tables import (
    association_table,
    cost_table,
    dataset_verdicts,
    headline_table,
    metrics_table,
    seeds_table,
    verdict_table,
)
from omnislam.report.model import Section
from omnislam.report.options import ReportOptions
from omnislam.report.provenance import UNKNOWN
from omnislam.report.results import ReportCell, gt_label
from omnislam.report.tables import make_table

#: how the verdict ranks, under its table
VERDICT_RULE = (
    "The verdict ranks only estimators that consumed the same input (the modality of their "
    "sightings and where they came from: the front end's tracks, the dataset's own sightings, "
    "a prior map), one method family per row: the family's best estimator by median ATE RMSE "
    "over seeds (with an even count of seeds, the lower of the two middle values, so the "
    "median is one run's), its min–max over seeds in brackets, how far it is behind the best "
    "family (in % of its own median) and whether the seed spread separates the two (their "
    "min–max ranges do not overlap). Variants of one method (graphslam and graphslam-batch, "
    "or one estimator with other options) are listed beside their family's best, not ranked "
    "against it. A deterministic estimator runs once per dataset on recorded data (every "
    "seed would repeat that run), so its range is its one value. Dead reckoning is the "
    "baseline and is not ranked."
)
#: what every metric of the tables means, under the verdict
METRICS_MEANING = (
    "Every number summarising an estimator over seeds is the median over seeds with its "
    "min–max range in brackets; 'deterministic' marks an estimator run once because every "
    "seed would repeat its run; each dataset's table of runs gives every seed's values. "
    "ATE: position RMSE after SE(2) alignment to the ground truth (Sturm et al. 2012); "
    "drift: the same with only the first pose anchored. RPE: segments of the stated length "
    "of ground-truth travel, SE(2) errors for planar runs. Landmark error: after the "
    "trajectory's alignment, matched by id where the data has ids, else by optimal "
    "assignment within a gate. NEES: pose error against the estimator's own covariance, "
    "median over the poses (3 when consistent) and the fraction of poses inside the 95 % "
    "chi-square band; 'inconsistent' where the median exceeds 100 times the degrees of "
    "freedom; '–' when the estimator has no covariance. Step times exclude the warm-up "
    "(the first step, and any step of the first 10 % slower than 10 median steps: "
    "compilation, the first frame), reported apart. Every row names the kind of ground "
    "truth it is measured against; pseudo ground truth (CARMEN) comes from another SLAM "
    "system and is not independent."
)
#: what the association table counts, under it
ASSOCIATION_MEANING = (
    "Association decisions as each estimator counts them (estimator_info.json): "
    "landmarks in the final map, landmarks created by the association, sightings "
    "associated with a landmark, left out as ambiguous, rejected by a gate, "
    "tentative landmarks dropped, landmarks merged by a loop closure and loop "
    "closures; '–' where the estimator does not count it."
)
#: what a report without figures says instead
NO_FIGURES = (
    "Figures: not drawn for this report but the summary figures (omnislam report "
    "--no-figures); omnislam report RESULTS_DIR --out DIR draws each dataset's from the same "
    "results."
)
#: what the exports are
EXPORTS = (
    "Exports: exports/CELL/trajectory.tum and trajectory.kitti for every run, "
    "landmarks.ply where the run has landmarks, graph.g2o where the estimator "
    "exported its factor graph."
)
#: how to read the provenance block
PROVENANCE_MEANING = (
    "Options are the estimator options a run was given (estimator_options in each "
    "RUN_DIR's config.yaml); 'defaults' means none were set. Path length is that of the "
    "ground truth, else of dead reckoning."
)


def title_section(title: str) -> Section:
    """The report's title (a level-1 heading)."""
    return Section(title, level=1)


def verdict_sections(cells: Sequence[ReportCell], made: Mapping[str, str]) -> list[Section]:
    """The verdict of every dataset and input as one table, notes on the rows that need one,
    how it ranks, what made the report, what the numbers mean.

    Args:
        cells: every run of the report.
        made: the provenance block's fields (``provenance.provenance_rows``).
    """
    verdicts = dataset_verdicts(cells)
    commit = made["git commit"]
    made_with = (
        f"Made with omnislam {made['omnislam version']} (commit "
        f"{commit[:12] if commit != UNKNOWN else commit}) on {made['date (UTC)']}; "
        "see Provenance at the end."
    )
    return [
        Section(
            "Verdict",
            tables=(verdict_table(verdicts),),
            notes=tuple(note for v in verdicts for note in v.notes()),
        ),
        Section(None, paragraphs=(VERDICT_RULE, made_with, METRICS_MEANING)),
    ]


def summary_section(
    cells: Sequence[ReportCell], colours: Mapping[str, str], options: ReportOptions
) -> list[Section]:
    """The summary figures (``report.summary``); none when not asked for or nothing to draw."""
    from omnislam.report.summary import summary_figures

    if not options.summary_figures:
        return []
    figures = summary_figures(cells, dataset_verdicts(cells), colours)
    return [Section("Summary figures", figures=tuple(figures))] if figures else []


def headline_section(cells: Sequence[ReportCell]) -> Section:
    """ATE RMSE per dataset and estimator, one table."""
    return Section("ATE RMSE [m] per dataset and estimator", tables=(headline_table(cells),))


def dataset_sections(
    cells: Sequence[ReportCell],
    colours: Mapping[str, str],
    options: ReportOptions,
    notes: list[str],
) -> list[Section]:
    """One section per dataset, in the order of the cells (``dataset_section``), telling
    ``options.on_step`` as each dataset's figures are drawn."""
    say = options.on_step or _silent
    datasets = list(dict.fromkeys(c.dataset for c in cells))
    sections = []
    for index, dataset in enumerate(datasets):
        say(f"figures of {dataset}", index, len(datasets))
        group = [c for c in cells if c.dataset == dataset]
        sections.append(dataset_section(dataset, group, colours, options, notes))
    say("figures", len(datasets), len(datasets))
    return sections


def dataset_section(
    dataset: str,
    cells: Sequence[ReportCell],
    colours: Mapping[str, str],
    options: ReportOptions,
    notes: list[str],
) -> Section:
    """One dataset: its ground truth, its metrics and association tables, the runs that failed
    and its figures (what could not be drawn is appended to ``notes``)."""
    note = next((c.metrics.ground_truth.note for c in cells if c.ok and c.metrics is not None), "")
    association = association_table(dataset, cells)
    failed = tuple(f"Failed: {c.cell_id}: {c.error}" for c in cells if not c.ok)
    figures = dataset_figures(dataset, cells, colours, options, notes) if options.figures else []
    return Section(
        f"{dataset} — {gt_label(cells)}",
        lead=(f"Ground truth: {note}",) if note else (),
        tables=(
            metrics_table(dataset, cells),
            cost_table(dataset, cells),
            seeds_table(dataset, cells),
            *([association] if association else []),
        ),
        paragraphs=((ASSOCIATION_MEANING,) if association else ()) + failed,
        figures=tuple(figures),
    )


def left_out_section(options: ReportOptions) -> Section:
    """What the report did not draw (figures) or wrote beside it (exports); no heading."""
    paragraphs = ((NO_FIGURES,) if not options.figures else ()) + (
        (EXPORTS,) if options.exports else ()
    )
    return Section(None, paragraphs=paragraphs)


def notes_sections(notes: Sequence[str]) -> list[Section]:
    """The Notes: what could not be drawn or written, and why (none: no section)."""
    return [Section("Notes", notes=tuple(notes))] if notes else []


def estimators_section(cells: Sequence[ReportCell]) -> Section:
    """Every estimator of omnislam, whether this installation has it and whether it ran here."""
    ran = {c.estimator for c in cells}
    return Section(
        "Estimators",
        tables=(
            make_table(
                "estimators",
                "Estimators of omnislam and whether they are in this report",
                ["estimator", "status", "in this report"],
                [
                    [name, status, "yes" if name in ran else "no"]
                    for name, status in _estimator_availability()
                ],
            ),
        ),
    )


def provenance_section(made: Sequence[tuple[str, str]]) -> Section:
    """How the report was made (``provenance.provenance_rows``)."""
    return Section(
        "Provenance",
        tables=(
            make_table("provenance", "How this report was made", ["what", "value"],
                       [[k, v] for k, v in made]),
        ),
        paragraphs=(PROVENANCE_MEANING,),
    )


def _estimator_availability() -> list[tuple[str, str]]:
    from omnislam.estimators import ESTIMATORS, estimator_factory

    out = []
    for name in ESTIMATORS:
        try:
            estimator_factory(name)
            out.append((name, "available"))
        except (ConfigError, ImportError) as exc:
            reason = "not available yet" if "not available yet" in str(exc) else str(exc)
            out.append((name, reason))
    return out


def _silent(stage: str, done: int, total: int) -> None:
    """The ``on_step`` of a report nobody watches."""
