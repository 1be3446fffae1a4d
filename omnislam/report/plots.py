"""Report figures, each answering one question, as SVG text (matplotlib's object API, no pyplot).

Imported lazily by ``report.figures`` and ``report.render`` only; matplotlib is the ``plots``
extra. Every function takes plain arrays (world-frame positions [m], already aligned to the ground
truth by the caller) and the report's estimator colours (``report.palette``), and returns a
standalone SVG document (``inline_svg`` turns it into an element for an HTML page).

Conventions shared by every figure:

* each estimator is drawn in its palette colour, the ground truth in black, and every artist
  that carries an estimator's colour has the SVG id ``estimator_id(label, n)`` (the label
  hex-encoded), so a test can read which colour each estimator got in each figure;
* text stays text (``svg.fonttype = none``): small, searchable, sharp at any zoom; the ids of a
  figure are prefixed with its name so that figures inlined in one page never share an id;
* the only raster parts are occupancy grids, embedded at their own resolution (one pixel per
  cell, drawn with ``image-rendering: pixelated``), and scatters and error-coloured paths of
  more than ``RASTERISE_ABOVE`` elements, at ``RASTER_DPI``;
* figures are sized for the report's 1200 px column: ``WIDTH_IN`` wide at most, panels of
  small multiples ``PANEL_IN`` square, text at 8-10 pt.
"""

from __future__ import annotations

import io
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from omnislam._optional import require
from omnislam.report.occupancy import OccupancyGrid
from omnislam.report.palette import TRUTH

require("matplotlib")

import matplotlib  # noqa: E402
from matplotlib.backends.backend_svg import FigureCanvasSVG  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from matplotlib.colors import ListedColormap, LogNorm  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Ellipse  # noqa: E402
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter  # noqa: E402

#: resolution of the raster parts inside an SVG (rasterised scatters) [dots per inch]
RASTER_DPI = 200
#: widest figure [in] (about 1000 px in the report's 1200 px column)
WIDTH_IN = 10.0
#: side of one panel of small multiples [in]
PANEL_IN = 2.45
#: side of a panel when there are fewer than a row of them [in]
PANEL_MAX_IN = 4.2
#: small multiples per row
PANELS_PER_ROW = 4
#: covariance ellipses are drawn at this many standard deviations ...
ELLIPSE_SIGMA = 2.0
#: ... and only on maps of at most this many landmarks (more overlap into a solid mass)
ELLIPSE_MAX_LANDMARKS = 60
#: lines are drawn through at most this many vertices (a panel is ~250 px wide)
MAX_LINE_POINTS = 1000
#: a path coloured by its error changes colour in this many steps (one polyline per run of
#: one step, not one per segment)
ERROR_LEVELS = 32
#: scatters of more points, and error-coloured paths of more polylines, than this are
#: rasterised at RASTER_DPI (an SVG element per point would make a map of a thousand
#: landmarks weigh 100 KB per panel)
RASTERISE_ABOVE = 150
#: the position-error colour map: viridis without its palest yellow (unreadable on white)
ERROR_CMAP = ListedColormap(matplotlib.colormaps["viridis"](np.linspace(0.0, 0.88, 256)))
_TRUTH_LINE = {"color": TRUTH, "linewidth": 0.8, "linestyle": (0, (4, 2)), "alpha": 0.7}
_RC = {
    "svg.fonttype": "none",
    "font.size": 9,
    "axes.titlesize": 9,
    "axes.labelsize": 9,
    "xtick.labelsize": 8,
    "ytick.labelsize": 8,
    "legend.fontsize": 8,
}
_ID_PREFIX = "estimator--"
_ID = re.compile(r'id="([^"]+)"')


@dataclass(frozen=True, slots=True)
class Series:
    """One estimator's curve: a label and (N, 2) x-y data."""

    label: str
    xy: np.ndarray


@dataclass(frozen=True, slots=True)
class TrajectorySeries:
    """One estimator's aligned path: (N, 2) positions [m] and the (N,) position error of each
    pose [m] (None without ground truth)."""

    label: str
    xy: np.ndarray
    error_m: np.ndarray | None = None
    ate_rmse_m: float | None = None


@dataclass(frozen=True, slots=True)
class LandmarkSeries:
    """One estimator's map: (M, 2) positions and optional (M, 2, 2) x-y covariances [m^2]."""

    label: str
    xy: np.ndarray
    covariances: np.ndarray | None = None


@dataclass(frozen=True, slots=True)
class RunPoints:
    """One estimator column over seeds: ATE RMSE [m] and total run time [s] of each run."""

    label: str
    ate_rmse_m: np.ndarray
    total_s: np.ndarray


# --------------------------------------------------------------------------------------------
# SVG plumbing
# --------------------------------------------------------------------------------------------


def estimator_id(label: str, n: int) -> str:
    """The SVG id of the n-th artist of a figure drawn in ``label``'s colour."""
    return f"{_ID_PREFIX}{label.encode('utf-8').hex()}--{n}"


def label_of_id(svg_id: str) -> str | None:
    """The estimator label an SVG id of ``estimator_id`` names (None for other ids), also
    after ``_svg`` prefixed it with the figure's name."""
    match = re.search(rf"{_ID_PREFIX}([0-9a-f]*)--\d+$", svg_id)
    return bytes.fromhex(match.group(1)).decode("utf-8") if match else None


class _Ids:
    """Hands out ``estimator_id``s, unique within one figure."""

    def __init__(self) -> None:
        self._n = 0

    def __call__(self, label: str) -> str:
        self._n += 1
        return estimator_id(label, self._n)


def _figure(width_in: float, height_in: float) -> Figure:
    figure = Figure(figsize=(width_in, height_in), layout="constrained")
    FigureCanvasSVG(figure)
    return figure


def _svg(figure: Figure, name: str) -> str:
    """The figure as a standalone SVG document whose ids all start with ``name``."""
    buffer = io.StringIO()
    with matplotlib.rc_context({"svg.fonttype": "none", "svg.hashsalt": name}):
        figure.savefig(
            buffer, format="svg", dpi=RASTER_DPI, bbox_inches="tight", metadata={"Date": None}
        )
    text = re.sub(r"\s*<metadata>.*?</metadata>", "", buffer.getvalue(), count=1, flags=re.S)
    ids = set(_ID.findall(text))
    prefix = "".join(ch if ch.isalnum() or ch in "-_" else "-" for ch in name)

    def rename(match: re.Match[str]) -> str:
        head, value = match.group(1), match.group(2)
        return f"{head}{prefix}-{value}" if value in ids else match.group(0)

    text = re.sub(r'(id="|href="#|url\(#)([^")]+)', rename, text)
    # coordinates to 0.01 pt (1/7200 in): a third smaller, the same drawing
    return re.sub(r'( (?:d|x|y)=")([^"]*)"', _round_coordinates, text)


def _round_coordinates(match: re.Match[str]) -> str:
    numbers = re.sub(r"(-?\d+\.\d\d)\d+", r"\1", match.group(2))
    return f'{match.group(1)}{numbers}"'


def inline_svg(svg: str, title: str) -> str:
    """An SVG document as an element of an HTML page: no XML prologue, scaled down to the
    page's width (never up), with ``title`` as its accessible name."""
    start = svg.index("<svg")
    element = svg[start:]
    from html import escape

    return element.replace(
        "<svg ",
        f'<svg role="img" aria-label="{escape(title)}" style="max-width:100%;height:auto" ',
        1,
    )


def _g_formatter() -> FuncFormatter:
    return FuncFormatter(lambda value, _: f"{value:g}")


def _log_axis(axis: object, low: float, high: float) -> None:
    """Log ticks labelled as plain numbers (no 2x10^0 that collide with the axis label): at 1,
    1.5, 2, 3, 5 and 7 per decade over about one decade, at 1, 2 and 5 over up to 3 decades,
    at every decade up to 6, every other beyond."""
    decades = math.log10(max(high, 1e-300) / max(low, 1e-300)) if low > 0 else 10.0
    if decades <= 1.2:
        locator = LogLocator(base=10.0, subs=(1.0, 1.5, 2.0, 3.0, 5.0, 7.0))
    elif decades <= 3.0:
        locator = LogLocator(base=10.0, subs=(1.0, 2.0, 5.0))
    elif decades <= 6.0:
        locator = LogLocator(base=10.0, subs=(1.0,))
    else:
        locator = LogLocator(base=100.0, subs=(1.0,))
    axis.set_major_locator(locator)  # type: ignore[attr-defined]
    axis.set_major_formatter(_g_formatter())  # type: ignore[attr-defined]
    axis.set_minor_formatter(NullFormatter())  # type: ignore[attr-defined]


def _positive_span(*arrays: np.ndarray) -> tuple[float, float]:
    """(smallest, largest) positive finite value of the arrays ((1, 10) when there is none)."""
    values = np.concatenate([np.ravel(np.asarray(a, dtype=float)) for a in arrays] or [[]])
    values = values[np.isfinite(values) & (values > 0)]
    return (float(values.min()), float(values.max())) if values.size else (1.0, 10.0)


def _grid_of_panels(n: int, extra_width_in: float = 0.0) -> tuple[Figure, list, int]:
    """Figure of n equal panels sharing both axes, PANELS_PER_ROW to a row; fewer panels than
    a row get larger ones (up to PANEL_MAX_IN), so that a lone panel stays legible."""
    columns = min(PANELS_PER_ROW, n)
    rows = math.ceil(n / columns)
    side = min(PANEL_MAX_IN, max(PANEL_IN, (WIDTH_IN - 0.5 - extra_width_in) / columns))
    figure = _figure(min(WIDTH_IN, side * columns + 0.5 + extra_width_in), side * rows + 0.5)
    axes = figure.subplots(rows, columns, squeeze=False, sharex=True, sharey=True).ravel()
    for ax in axes[n:]:
        ax.set_axis_off()
    return figure, list(axes[:n]), columns


def _map_panel(ax: Any, colour: str, ids: _Ids, label: str) -> None:
    """One small-multiple map panel: framed in the estimator's colour, metric and square."""
    _frame(ax, colour, ids, label)
    ax.set_aspect("equal", adjustable="box")
    ax.grid(alpha=0.25)
    ax.tick_params(labelsize=7)


def _map_axes(axes: Sequence[Any], xlim: tuple[float, float], ylim: tuple[float, float]) -> None:
    """Shared limits of small-multiple map panels; x labels on the bottom row, y on the left."""
    axes[0].set_xlim(*xlim)
    axes[0].set_ylim(*ylim)
    for ax in axes:
        if ax.get_subplotspec().is_last_row() or ax is axes[-1]:
            ax.set_xlabel("x [m]")
        if ax.get_subplotspec().is_first_col():
            ax.set_ylabel("y [m]")


def _frame(ax: object, colour: str, ids: _Ids, label: str) -> None:
    """Outline a panel in its estimator's colour."""
    for spine in ax.spines.values():  # type: ignore[attr-defined]
        spine.set_edgecolor(colour)
        spine.set_linewidth(1.4)
        spine.set_gid(ids(label))


def _limits(points: Sequence[np.ndarray], pad: float = 0.06) -> tuple[float, float, float, float]:
    xy = np.concatenate([p.reshape(-1, 2) for p in points if len(p)])
    xy = xy[np.all(np.isfinite(xy), axis=1)]
    low, high = xy.min(axis=0), xy.max(axis=0)
    span = max(float(np.max(high - low)), 1e-6)
    low, high = low - pad * span, high + pad * span
    return float(low[0]), float(high[0]), float(low[1]), float(high[1])


def _error_runs(
    xy: np.ndarray, error_m: np.ndarray, norm: LogNorm
) -> tuple[list[np.ndarray], np.ndarray]:
    """A path cut into polylines of one colour each: each segment takes the ERROR_LEVELS step
    of its mean error (on ``norm``'s log scale), and consecutive segments of one step are one
    polyline. Returns (polylines, RGBA colour of each)."""
    mid = 0.5 * (error_m[:-1] + error_m[1:])
    level = np.clip(
        np.floor(np.asarray(norm(np.maximum(mid, norm.vmin))) * ERROR_LEVELS), 0, ERROR_LEVELS - 1
    ).astype(int)
    cuts = np.flatnonzero(np.diff(level)) + 1
    starts = np.concatenate([[0], cuts])
    ends = np.concatenate([cuts, [len(level)]])
    polylines = [xy[a : b + 1] for a, b in zip(starts, ends, strict=True)]
    return polylines, ERROR_CMAP((level[starts] + 0.5) / ERROR_LEVELS)


def _thin(n: int) -> np.ndarray:
    """Indices of at most MAX_LINE_POINTS vertices of an n-vertex line, first and last kept."""
    if n <= MAX_LINE_POINTS:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, MAX_LINE_POINTS).round().astype(int))


# --------------------------------------------------------------------------------------------
# Figures
# --------------------------------------------------------------------------------------------


def _low_median(values: np.ndarray) -> float:
    """The report's median over seeds (``metrics.seeds``: the lower middle value)."""
    ordered = np.sort(np.asarray(values, dtype=float))
    return float(ordered[(len(ordered) - 1) // 2])


def ate_over_seeds(
    name: str, title: str, columns: Sequence[RunPoints], colours: Mapping[str, str]
) -> str:
    """How accurate is each estimator, and how much does it vary over seeds?

    A strip plot: the ATE RMSE of every seed (a dot) and the median (a bar) per estimator.
    """
    ids = _Ids()
    with matplotlib.rc_context(_RC):
        figure = _figure(min(WIDTH_IN, 1.6 + 0.9 * len(columns)), 3.4)
        ax = figure.add_subplot()
        values = np.concatenate([c.ate_rmse_m for c in columns]) if columns else np.zeros(0)
        positive = values[values > 0]
        log = positive.size > 0 and positive.max() / positive.min() > 20.0
        for k, c in enumerate(columns):
            colour = colours[c.label]
            ate = np.sort(c.ate_rmse_m)
            offsets = np.linspace(-0.18, 0.18, ate.size) if ate.size > 1 else np.zeros(1)
            ax.scatter(
                k + offsets[: ate.size],
                ate,
                s=22,
                color=colour,
                alpha=0.85,
                linewidths=0,
                zorder=3,
                gid=ids(c.label),
            )
            if ate.size:
                ax.plot(
                    [k - 0.3, k + 0.3],
                    [_low_median(ate)] * 2,
                    color=colour,
                    linewidth=2.2,
                    gid=ids(c.label),
                )
        ax.set_xticks(range(len(columns)), [c.label for c in columns])
        for tick, c in zip(ax.get_xticklabels(), columns, strict=True):
            tick.set_color(colours[c.label])
            tick.set_gid(ids(c.label))
        if len(columns) > 5 or max((len(c.label) for c in columns), default=0) > 12:
            for tick in ax.get_xticklabels():
                tick.set_rotation(25)
                tick.set_horizontalalignment("right")
        if log:
            ax.set_yscale("log")
            _log_axis(ax.yaxis, *_positive_span(values))
        else:
            ax.set_ylim(bottom=0.0)
        seeds = max((c.ate_rmse_m.size for c in columns), default=0)
        ax.set(
            title=f"{title}: ATE RMSE per seed (dots) and median (bar), {seeds} "
            f"seed{'s' * (seeds != 1)}",
            ylabel="ATE RMSE [m]",
            xlim=(-0.6, len(columns) - 0.4),
        )
        ax.grid(axis="y", alpha=0.3, which="both")
        return _svg(figure, name)


def accuracy_vs_time(
    name: str, title: str, columns: Sequence[RunPoints], colours: Mapping[str, str]
) -> str:
    """What does accuracy cost? ATE RMSE against total run time, one dot per run (log-log),
    the median of each estimator ringed."""
    ids = _Ids()
    with matplotlib.rc_context(_RC):
        figure = _figure(7.2, 3.8)
        ax = figure.add_subplot()
        handles = []
        for c in columns:
            ok = (c.total_s > 0) & (c.ate_rmse_m > 0)
            if not ok.any():
                continue
            colour = colours[c.label]
            ax.scatter(
                c.total_s[ok],
                c.ate_rmse_m[ok],
                s=16,
                color=colour,
                alpha=0.6,
                linewidths=0,
                gid=ids(c.label),
            )
            ax.scatter(
                [_low_median(c.total_s[ok])],
                [_low_median(c.ate_rmse_m[ok])],
                s=70,
                facecolors=colour,
                edgecolors=TRUTH,
                linewidths=0.8,
                zorder=3,
                gid=ids(c.label),
            )
            handles.append(
                Line2D(
                    [], [], marker="o", linestyle="", color=colour, label=c.label, gid=ids(c.label)
                )
            )
        ax.set_xscale("log")
        ax.set_yscale("log")
        _log_axis(ax.xaxis, *_positive_span(*(c.total_s for c in columns)))
        _log_axis(ax.yaxis, *_positive_span(*(c.ate_rmse_m for c in columns)))
        ax.set(
            title=f"{title}: accuracy against run time (ringed: median over seeds)",
            xlabel="total run time [s] (wall clock)",
            ylabel="ATE RMSE [m]",
        )
        ax.grid(alpha=0.3, which="both")
        if handles:
            legend = figure.legend(handles=handles, loc="outside right upper", frameon=False)
            for text, handle in zip(legend.get_texts(), handles, strict=True):
                text.set_color(handle.get_color())
                text.set_gid(ids(handle.get_label()))
        return _svg(figure, name)


def trajectories(
    name: str,
    title: str,
    truth_label: str,
    truth_xy: np.ndarray | None,
    series: Sequence[TrajectorySeries],
    colours: Mapping[str, str],
) -> str:
    """Where along the path does each estimator go wrong? One panel per estimator, its path
    coloured by its position error (one logarithmic scale for every panel), over the truth."""
    ids = _Ids()
    with matplotlib.rc_context(_RC):
        figure, axes, _ = _grid_of_panels(len(series), extra_width_in=0.8)
        errors = [s.error_m[np.isfinite(s.error_m)] for s in series if s.error_m is not None]
        errors = [e[e > 0] for e in errors if e.size]
        norm = None
        if errors:
            high = max(float(np.max(e)) for e in errors)
            low = max(min(float(np.percentile(e, 5)) for e in errors), high * 1e-3)
            norm = LogNorm(vmin=min(low, high / 1.01), vmax=high)
        shown = [s.xy for s in series]
        if truth_xy is not None and len(truth_xy):
            shown.append(truth_xy)
        x0, x1, y0, y1 = _limits(shown)
        for ax, s in zip(axes, series, strict=True):
            colour = colours[s.label]
            if truth_xy is not None and len(truth_xy):
                keep = _thin(len(truth_xy))
                ax.plot(truth_xy[keep, 0], truth_xy[keep, 1], **_TRUTH_LINE)
            keep = _thin(len(s.xy))
            xy = s.xy[keep]
            if s.error_m is not None and norm is not None and len(xy) > 1:
                polylines, rgba = _error_runs(xy, s.error_m[keep], norm)
                ax.add_collection(
                    LineCollection(
                        polylines,
                        colors=rgba,
                        linewidths=1.6,
                        capstyle="round",
                        rasterized=len(polylines) > RASTERISE_ABOVE,
                    )
                )
            else:
                ax.plot(xy[:, 0], xy[:, 1], color=colour, linewidth=1.2, gid=ids(s.label))
            ax.plot(xy[:1, 0], xy[:1, 1], marker="o", markersize=3, color=TRUTH, linestyle="")
            head = (
                s.label
                if s.ate_rmse_m is None
                else f"{s.label}\nATE {s.ate_rmse_m:.3g} m (median seed)"
            )
            ax.set_title(head, color=colour, fontsize=9, gid=ids(s.label))
            _map_panel(ax, colour, ids, s.label)
        _map_axes(axes, (x0, x1), (y0, y1))
        if norm is not None:
            from matplotlib.cm import ScalarMappable

            bar = figure.colorbar(
                ScalarMappable(norm=norm, cmap=ERROR_CMAP), ax=axes, shrink=0.8, pad=0.02
            )
            bar.set_label("position error [m] (log scale)")
            _log_axis(bar.ax.yaxis, norm.vmin, norm.vmax)
        figure.suptitle(
            f"{title}: each estimator's path, coloured by its position error; dashed: {truth_label}"
            if truth_xy is not None
            else f"{title}: each estimator's path (no ground truth)",
            fontsize=10,
        )
        return _svg(figure, name)


def _ellipse(centre: np.ndarray, cov: np.ndarray, colour: str) -> Ellipse:
    values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))
    values = np.maximum(values, 0.0)
    angle = float(np.degrees(np.arctan2(vectors[1, 1], vectors[0, 1])))
    width, height = 2.0 * ELLIPSE_SIGMA * np.sqrt(values[::-1])
    return Ellipse(
        tuple(centre), width, height, angle=angle, fill=False, color=colour, linewidth=0.6
    )


def landmark_maps(
    name: str,
    title: str,
    truth_xy: np.ndarray | None,
    maps: Sequence[LandmarkSeries],
    colours: Mapping[str, str],
) -> str:
    """Where does each estimator put the landmarks? One panel per estimator over the true
    landmarks (+), with ELLIPSE_SIGMA covariance ellipses where the map has at most
    ELLIPSE_MAX_LANDMARKS landmarks; points beyond the view are counted in the panel title."""
    ids = _Ids()
    with matplotlib.rc_context(_RC):
        figure, axes, _ = _grid_of_panels(len(maps))
        has_truth = truth_xy is not None and len(truth_xy) > 0
        robust = []
        for m in maps:
            finite = m.xy[np.all(np.isfinite(m.xy), axis=1)]
            if len(finite):
                robust.append(np.percentile(finite, [1, 99], axis=0))
        x0, x1, y0, y1 = _limits([*robust, *([truth_xy] if has_truth else [])])
        for ax, m in zip(axes, maps, strict=True):
            colour = colours[m.label]
            if has_truth:
                ax.scatter(
                    truth_xy[:, 0], truth_xy[:, 1], marker="+", s=30, color=TRUTH, linewidths=0.8
                )
            dense = len(m.xy) > RASTERISE_ABOVE
            ax.scatter(
                m.xy[:, 0],
                m.xy[:, 1],
                s=4 if dense else 10,
                color=colour,
                linewidths=0,
                alpha=0.7 if dense else 1.0,
                rasterized=dense,
                gid=ids(m.label),
            )
            head = f"{m.label}: {len(m.xy)} landmarks"
            if m.covariances is not None and len(m.xy) <= ELLIPSE_MAX_LANDMARKS:
                for centre, cov in zip(m.xy, m.covariances, strict=True):
                    patch = _ellipse(centre, cov, colour)
                    patch.set_gid(ids(m.label))
                    ax.add_patch(patch)
                head += f"\n{ELLIPSE_SIGMA:g}-sigma ellipses"
            elif m.covariances is not None:
                head += f"\n(> {ELLIPSE_MAX_LANDMARKS}: no ellipses)"
            outside = int(
                np.sum(
                    ~(
                        (m.xy[:, 0] >= x0)
                        & (m.xy[:, 0] <= x1)
                        & (m.xy[:, 1] >= y0)
                        & (m.xy[:, 1] <= y1)
                    )
                )
            )
            if outside:
                head += f"; {outside} outside the view"
            ax.set_title(head, color=colour, fontsize=8.5, gid=ids(m.label))
            _map_panel(ax, colour, ids, m.label)
        _map_axes(axes, (x0, x1), (y0, y1))
        figure.suptitle(
            f"{title}: landmark maps" + (" (+: true landmarks)" if has_truth else ""),
            fontsize=10,
        )
        return _svg(figure, name)


def error_over_distance(
    name: str,
    title: str,
    translation: Sequence[Series],
    rotation: Sequence[Series],
    colours: Mapping[str, str],
) -> str:
    """How does the error grow with the distance travelled? RPE RMSE against segment length:
    translation [m] and rotation [deg] (log-log), one legend for both panels."""
    ids = _Ids()
    with matplotlib.rc_context(_RC):
        figure = _figure(WIDTH_IN, 3.5)
        left, right = figure.subplots(1, 2)
        handles: dict[str, Line2D] = {}
        panels = ((left, translation), (right, rotation))
        for ax, curves in panels:
            for s in curves:
                (line,) = ax.plot(
                    s.xy[:, 0],
                    s.xy[:, 1],
                    marker="o",
                    markersize=3,
                    linewidth=1.2,
                    color=colours[s.label],
                    label=s.label,
                    gid=ids(s.label),
                )
                handles.setdefault(s.label, line)
        left.set(xlabel="segment length [m]", ylabel="RPE translation RMSE [m]")
        left.set_title(f"{title}: translation", loc="left")
        right.set(xlabel="segment length [m]", ylabel="RPE rotation RMSE [deg]")
        right.set_title(f"{title}: rotation", loc="left")
        for ax, curves in panels:
            if not ax.lines:
                ax.text(0.5, 0.5, "no values", transform=ax.transAxes, ha="center")
                continue
            ax.set_xscale("log")
            ax.set_yscale("log")
            _log_axis(ax.xaxis, *_positive_span(*(s.xy[:, 0] for s in curves)))
            _log_axis(ax.yaxis, *_positive_span(*(s.xy[:, 1] for s in curves)))
            ax.grid(alpha=0.3, which="both")
        if handles:
            legend = figure.legend(
                handles=list(handles.values()), loc="outside right upper", frameon=False
            )
            for text, label in zip(legend.get_texts(), handles, strict=True):
                text.set_color(colours[label])
                text.set_gid(ids(label))
        return _svg(figure, name)


#: the percentiles of the step-time figure and their markers
STEP_PERCENTILES: tuple[tuple[float, str, str], ...] = (
    (50.0, "o", "p50"),
    (95.0, "D", "p95"),
    (99.0, "^", "p99"),
    (100.0, "x", "max"),
)


def step_times(
    name: str, title: str, steps_ms: Sequence[Series], colours: Mapping[str, str]
) -> str:
    """How long does one step take, typically and at worst? Per estimator the 50th, 95th and
    99th percentile and the maximum of its step times (log scale), the line spanning the 5th
    percentile to the maximum; ``Series.xy[:, 1]`` holds the step times [ms]."""
    ids = _Ids()
    with matplotlib.rc_context(_RC):
        figure = _figure(WIDTH_IN * 0.8, 0.9 + 0.36 * max(len(steps_ms), 1))
        ax = figure.add_subplot()
        labels = []
        for row, s in enumerate(steps_ms):
            colour = colours[s.label]
            ms = np.asarray(s.xy[:, 1], dtype=float)
            ms = ms[np.isfinite(ms)]
            if not ms.size:
                continue
            ms = np.maximum(ms, 1e-4)  # a step under 0.1 us is below the clock's resolution
            y = -row
            ax.plot(
                [np.percentile(ms, 5), ms.max()],
                [y, y],
                color=colour,
                linewidth=1.0,
                gid=ids(s.label),
            )
            for q, marker, _ in STEP_PERCENTILES:
                ax.plot(
                    [np.percentile(ms, q)],
                    [y],
                    marker=marker,
                    markersize=5.5,
                    color=colour,
                    linestyle="",
                    gid=ids(s.label),
                )
            ax.annotate(
                f"p50 {np.percentile(ms, 50):.3g} · p95 {np.percentile(ms, 95):.3g} ms",
                (1.0, y),
                xycoords=("axes fraction", "data"),
                xytext=(6, 0),
                textcoords="offset points",
                va="center",
                fontsize=7.5,
                color=colour,
                gid=ids(s.label),
            )
            labels.append((y, s.label))
        ax.set_yticks([y for y, _ in labels], [label for _, label in labels])
        for tick, (_, label) in zip(ax.get_yticklabels(), labels, strict=True):
            tick.set_color(colours[label])
            tick.set_gid(ids(label))
        ax.set_ylim(-len(steps_ms) + 0.4, 0.6)
        ax.set_xscale("log")
        _log_axis(ax.xaxis, *_positive_span(*(np.maximum(s.xy[:, 1], 1e-4) for s in steps_ms)))
        ax.set(title=f"{title}: step time percentiles (wall clock)", xlabel="step time [ms]")
        ax.grid(axis="x", alpha=0.3, which="both")
        keys = [
            Line2D([], [], marker=marker, linestyle="", color=TRUTH, label=label)
            for _, marker, label in STEP_PERCENTILES
        ]
        ax.legend(
            handles=keys,
            loc="lower center",
            bbox_to_anchor=(0.5, 1.08),
            ncols=len(keys),
            frameon=False,
            fontsize=7.5,
        )
        return _svg(figure, name)


def occupancy(
    name: str,
    title: str,
    grids: Sequence[tuple[str, OccupancyGrid]],
    colours: Mapping[str, str],
) -> str:
    """What map do the laser scans make on each trajectory? Occupancy probability (white free,
    black occupied, grey unknown), one panel per trajectory, every one of them; a label not in
    ``colours`` (the ground truth) is titled in black."""
    ids = _Ids()
    with matplotlib.rc_context(_RC):
        figure, axes, _ = _grid_of_panels(len(grids))
        for ax, (label, grid) in zip(axes, grids, strict=True):
            ax.imshow(
                grid.probability,
                origin="lower",
                cmap="gray_r",
                vmin=0.0,
                vmax=1.0,
                extent=grid.extent_w,
                interpolation="none",  # one pixel per cell, drawn pixelated at any size
            )
            colour = colours.get(label, TRUTH)
            gid = ids(label) if label in colours else None
            ax.set_title(f"{label} ({grid.scans} scans)", color=colour, fontsize=8.5, gid=gid)
            if label in colours:
                _frame(ax, colour, ids, label)
            ax.tick_params(labelsize=7)
        for ax in axes:
            if ax.get_subplotspec().is_last_row() or ax is axes[-1]:
                ax.set_xlabel("x [m]")
            if ax.get_subplotspec().is_first_col():
                ax.set_ylabel("y [m]")
        figure.suptitle(f"{title}: occupancy from the laser scans on each trajectory", fontsize=10)
        return _svg(figure, name)


@dataclass(frozen=True, slots=True)
class FamilyPoint:
    """The best estimator of one method family on one dataset and input (a verdict's row).

    Attributes:
        row: the row's label (``dataset · input``).
        family: the method family.
        column: its best estimator column.
        ate_m: that column's median ATE RMSE [m]; low_m, high_m: its min-max over seeds.
    """

    row: str
    family: str
    column: str
    ate_m: float
    low_m: float
    high_m: float


#: a fixed colour per method family (Okabe-Ito, as the estimators')
FAMILY_COLOURS = {
    "factor graph": "#0072B2",
    "particle filter": "#D55E00",
    "Kalman filter": "#009E73",
    "localiser in a known map": "#CC79A7",
    "dead reckoning": "#7f7f7f",
}


def family_summary(name: str, points: Sequence[FamilyPoint]) -> str:
    """Which family wins where? The best of each method family per dataset and input: its
    median ATE RMSE (dot) and min-max over seeds (line), one row per dataset and input (log)."""
    rows = list(dict.fromkeys(p.row for p in points))
    with matplotlib.rc_context(_RC):
        figure = _figure(WIDTH_IN * 0.8, 1.0 + 0.28 * len(rows))
        ax = figure.add_subplot()
        families = list(dict.fromkeys(p.family for p in points))
        shift = {f: (k - (len(families) - 1) / 2) * 0.14 for k, f in enumerate(families)}
        for p in points:
            y = rows.index(p.row) + shift[p.family]
            colour = FAMILY_COLOURS.get(p.family, TRUTH)
            ax.plot([p.low_m, p.high_m], [y, y], color=colour, linewidth=1.2, alpha=0.8)
            ax.scatter([p.ate_m], [y], s=20, color=colour, zorder=3)
        ax.set_yticks(range(len(rows)), rows)
        ax.set_ylim(len(rows) - 0.5, -0.5)  # the first row on top
        ax.set_xscale("log")
        values = np.array([v for p in points for v in (p.low_m, p.high_m)], dtype=float)
        if values.size:
            _log_axis(ax.xaxis, *_positive_span(values))
        handles = [
            Line2D([], [], marker="o", linestyle="", color=FAMILY_COLOURS.get(f, TRUTH), label=f)
            for f in families
        ]
        ax.set(
            title="best of each method family: median ATE RMSE over seeds (dot), min–max (line)",
            xlabel="ATE RMSE [m]",
        )
        ax.grid(axis="x", alpha=0.3, which="both")
        if handles:
            figure.legend(handles=handles, loc="outside right upper", frameon=False)
        return _svg(figure, name)


@dataclass(frozen=True, slots=True)
class CostPoint:
    """One estimator column on one dataset: its median ATE over dead reckoning's and its median
    run time.

    Attributes:
        column: the estimator column.
        relative_ate: median ATE RMSE / dead reckoning's median ATE RMSE.
        total_s: median total run time [s].
    """

    column: str
    relative_ate: float
    total_s: float


def accuracy_vs_time_summary(
    name: str, points: Sequence[CostPoint], colours: Mapping[str, str]
) -> str:
    """What does accuracy cost, over every dataset? Each estimator's median ATE relative to
    dead reckoning against its median run time, one dot per dataset (log-log)."""
    ids = _Ids()
    with matplotlib.rc_context(_RC):
        figure = _figure(7.2, 3.8)
        ax = figure.add_subplot()
        handles = []
        for column in dict.fromkeys(p.column for p in points):
            mine = [
                p for p in points if p.column == column and p.total_s > 0 and p.relative_ate > 0
            ]
            if not mine:
                continue
            colour = colours[column]
            ax.scatter(
                [p.total_s for p in mine],
                [p.relative_ate for p in mine],
                s=18,
                color=colour,
                alpha=0.75,
                linewidths=0,
                gid=ids(column),
            )
            handles.append(
                Line2D(
                    [], [], marker="o", linestyle="", color=colour, label=column, gid=ids(column)
                )
            )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.axhline(1.0, **_TRUTH_LINE)
        times = np.array([p.total_s for p in points], dtype=float)
        ratios = np.array([p.relative_ate for p in points], dtype=float)
        _log_axis(ax.xaxis, *_positive_span(times))
        _log_axis(ax.yaxis, *_positive_span(ratios, np.ones(1)))
        ax.set(
            title="every dataset: ATE relative to dead reckoning (dashed: 1) against run time",
            xlabel="median total run time [s] (wall clock)",
            ylabel="median ATE / dead reckoning's",
        )
        ax.grid(alpha=0.3, which="both")
        if handles:
            legend = figure.legend(handles=handles, loc="outside right upper", frameon=False)
            for text, handle in zip(legend.get_texts(), handles, strict=True):
                text.set_color(handle.get_color())
        return _svg(figure, name)
