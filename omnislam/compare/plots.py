"""Report figures, rendered to PNG bytes with matplotlib's object API (no pyplot, no GUI).

Imported lazily by ``compare.report`` only; matplotlib is the ``plots`` extra. Every function
takes plain arrays (world-frame positions [m], already aligned to the ground truth by the
caller) and returns the PNG file's bytes.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from omnislam._optional import require
from omnislam.compare.occupancy import OccupancyGrid

require("matplotlib")

from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.patches import Ellipse  # noqa: E402

#: resolution of every figure [dots per inch]; small, reports are committed
DPI = 72
#: timing plots of longer runs show per-bin percentiles instead of every step
TIMING_BINS = 200
#: covariance ellipses are drawn at this many standard deviations
ELLIPSE_SIGMA = 2.0
_TRUTH_STYLE = {"color": "black", "linewidth": 1.4, "linestyle": "--"}


@dataclass(frozen=True, slots=True)
class Series:
    """One estimator's curve: a label and (N, 2) x-y data."""

    label: str
    xy: np.ndarray


@dataclass(frozen=True, slots=True)
class LandmarkSeries:
    """One estimator's map: (M, 2) positions and optional (M, 2, 2) x-y covariances [m^2]."""

    label: str
    xy: np.ndarray
    covariances: np.ndarray | None = None


def _png(figure: Figure) -> bytes:
    """The figure as PNG bytes, quantised to a 256-colour palette (a third of the size of
    matplotlib's RGBA output, indistinguishable for line plots; reports embed many figures)."""
    from PIL import Image

    FigureCanvasAgg(figure)
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=DPI, bbox_inches="tight")
    buffer.seek(0)
    with Image.open(buffer) as image:
        palette = image.convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT)
        out = io.BytesIO()
        palette.save(out, format="PNG", optimize=True)
    return out.getvalue()


def trajectories_png(
    title: str,
    truth_label: str,
    truth_xy: np.ndarray | None,
    series: Sequence[Series],
    truth_landmarks_xy: np.ndarray | None = None,
) -> bytes:
    """Estimated trajectories (aligned to the ground truth) over the ground truth."""
    figure = Figure(figsize=(6.0, 5.0))
    ax = figure.add_subplot()
    if truth_xy is not None and len(truth_xy):
        ax.plot(truth_xy[:, 0], truth_xy[:, 1], label=truth_label, **_TRUTH_STYLE)
    for s in series:
        ax.plot(s.xy[:, 0], s.xy[:, 1], linewidth=1.0, label=s.label)
    if truth_landmarks_xy is not None and len(truth_landmarks_xy):
        ax.scatter(
            truth_landmarks_xy[:, 0],
            truth_landmarks_xy[:, 1],
            marker="+",
            color="black",
            s=25,
            label="true landmarks",
        )
    ax.set(title=title, xlabel="x [m]", ylabel="y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    return _png(figure)


def landmark_map_png(
    title: str,
    truth_xy: np.ndarray | None,
    maps: Sequence[LandmarkSeries],
) -> bytes:
    """Estimated landmark maps with ELLIPSE_SIGMA covariance ellipses over the true landmarks."""
    figure = Figure(figsize=(6.0, 5.0))
    ax = figure.add_subplot()
    if truth_xy is not None and len(truth_xy):
        ax.scatter(truth_xy[:, 0], truth_xy[:, 1], marker="+", color="black", s=40, label="truth")
    for index, m in enumerate(maps):
        color = f"C{index}"
        ax.scatter(m.xy[:, 0], m.xy[:, 1], s=8, color=color, label=m.label)
        if m.covariances is None:
            continue
        for centre, cov in zip(m.xy, m.covariances, strict=True):
            values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))
            values = np.maximum(values, 0.0)
            angle = float(np.degrees(np.arctan2(vectors[1, 1], vectors[0, 1])))
            width, height = 2.0 * ELLIPSE_SIGMA * np.sqrt(values[::-1])
            ax.add_patch(
                Ellipse(
                    tuple(centre),
                    width,
                    height,
                    angle=angle,
                    fill=False,
                    color=color,
                    linewidth=0.6,
                )
            )
    ax.set(title=f"{title} ({ELLIPSE_SIGMA:g}-sigma ellipses)", xlabel="x [m]", ylabel="y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    return _png(figure)


def error_over_distance_png(
    title: str, translation: Sequence[Series], rotation: Sequence[Series]
) -> bytes:
    """RPE RMSE against segment length: translation [m] and rotation [deg] (log-log)."""
    figure = Figure(figsize=(9.0, 3.6))
    left, right = figure.subplots(1, 2)
    for s in translation:
        left.plot(s.xy[:, 0], s.xy[:, 1], marker="o", markersize=3, label=s.label)
    for s in rotation:
        right.plot(s.xy[:, 0], s.xy[:, 1], marker="o", markersize=3, label=s.label)
    left.set(xlabel="segment length [m]", ylabel="RPE translation RMSE [m]", title=title)
    right.set(xlabel="segment length [m]", ylabel="RPE rotation RMSE [deg]")
    for ax in (left, right):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(alpha=0.3, which="both")
        if ax.lines:
            ax.legend(fontsize=8)
    return _png(figure)


def timing_png(title: str, steps_ms: Sequence[Series]) -> bytes:
    """Per-step wall time against frame index [ms] (log scale), one line per estimator.

    Long runs are summarised per bin of consecutive frames (at most ``TIMING_BINS`` bins): the
    line is the bin's median step time, the shade spans its 5th to 95th percentile.
    """
    figure = Figure(figsize=(9.0, 3.2))
    ax = figure.add_subplot()
    for s in steps_ms:
        frames, ms = s.xy[:, 0], np.maximum(s.xy[:, 1], 1e-4)
        if frames.size > TIMING_BINS:
            bins = np.array_split(np.arange(frames.size), TIMING_BINS)
            centre = np.array([frames[b].mean() for b in bins])
            low, mid, high = (
                np.array([np.percentile(ms[b], q) for b in bins]) for q in (5, 50, 95)
            )
            (line,) = ax.plot(centre, mid, linewidth=0.8, label=s.label)
            ax.fill_between(centre, low, high, color=line.get_color(), alpha=0.2, linewidth=0)
        else:
            ax.plot(frames, ms, linewidth=0.6, label=s.label)
    ax.set(title=title, xlabel="frame", ylabel="step time [ms]", yscale="log")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="upper left")
    return _png(figure)


def occupancy_png(title: str, grids: Sequence[tuple[str, OccupancyGrid]]) -> bytes:
    """Occupancy probability maps side by side (white free, black occupied, grey unknown)."""
    figure = Figure(figsize=(4.2 * len(grids), 4.4))
    axes = figure.subplots(1, len(grids), squeeze=False)[0]
    for ax, (label, grid) in zip(axes, grids, strict=True):
        ax.imshow(
            grid.probability,
            origin="lower",
            cmap="gray_r",
            vmin=0.0,
            vmax=1.0,
            extent=grid.extent_w,
            interpolation="nearest",
        )
        ax.set(title=f"{label} ({grid.scans} scans)", xlabel="x [m]", ylabel="y [m]")
        ax.title.set_fontsize(9)
    figure.suptitle(title)
    return _png(figure)
