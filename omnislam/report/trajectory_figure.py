"""The figure of ``omnislam evaluate --plot``: estimates against one reference, as evo draws them.

Two panels: the top view (x-y, metres) of the reference and of each estimate after its
alignment, and each estimate's translation error (the ATE's position error of every associated
pose) over time. The file's suffix chooses the format: SVG, PDF or PNG (matplotlib's object
API, no pyplot). Colours are the report's (``report.palette``): an estimator's own colour when
the label is its name, a stable colour per label otherwise, the reference in black.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from omnislam.errors import ConfigError

#: file suffix -> matplotlib's format name
PLOT_FORMATS = {".svg": "svg", ".pdf": "pdf", ".png": "png"}
#: figure size [in] and the resolution of a PNG [dpi]
FIGURE_IN = (10.0, 4.5)
PNG_DPI = 150


@dataclass(frozen=True, slots=True)
class PlottedEstimate:
    """One estimate of the figure.

    Attributes:
        label: its name in the legend.
        positions_w: (N, 2) x-y of every pose after the alignment, reference frame [m].
        stamps_s: (M,) stamps of the poses associated with the reference [s].
        errors_m: (M,) their position error after the alignment [m].
    """

    label: str
    positions_w: np.ndarray
    stamps_s: np.ndarray
    errors_m: np.ndarray


def plot_format(path: str | Path) -> str:
    """The format of a plot file, from its suffix.

    Raises:
        ConfigError: a suffix other than .svg, .pdf or .png.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in PLOT_FORMATS:
        raise ConfigError(
            f"{path}: a plot is written as .svg, .pdf or .png, not {suffix or 'no suffix'!r}"
        )
    return PLOT_FORMATS[suffix]


def trajectory_figure(
    reference_w: np.ndarray,
    estimates: Sequence[PlottedEstimate],
    fmt: str,
    title: str,
) -> bytes:
    """The figure as the bytes of a ``fmt`` file (``plot_format``).

    Args:
        reference_w: (N, 2) x-y of the reference poses [m].
        estimates: the estimates, aligned to the reference.
        fmt: "svg", "pdf" or "png".
        title: the figure's title (what was compared, and how it was aligned).
    """
    from omnislam._optional import require

    require("matplotlib")
    import matplotlib
    from matplotlib.figure import Figure

    from omnislam.report.palette import TRUTH, colours

    figure = Figure(figsize=FIGURE_IN, layout="constrained")
    top, error = figure.subplots(1, 2, width_ratios=(1.0, 1.3))
    colour = colours(e.label for e in estimates)
    top.plot(reference_w[:, 0], reference_w[:, 1], color=TRUTH, lw=1.2, label="reference")
    start_s = min((float(e.stamps_s[0]) for e in estimates if len(e.stamps_s)), default=0.0)
    for estimate in estimates:
        xy = estimate.positions_w
        top.plot(xy[:, 0], xy[:, 1], color=colour[estimate.label], lw=1.0, label=estimate.label)
        error.plot(
            estimate.stamps_s - start_s,
            estimate.errors_m,
            color=colour[estimate.label],
            lw=1.0,
            label=estimate.label,
        )
    top.set(xlabel="x [m]", ylabel="y [m]", title="top view, aligned")
    top.set_aspect("equal", adjustable="datalim")
    top.legend(fontsize=8)
    error.set(xlabel="time [s]", ylabel="translation error [m]", title="ATE over time")
    error.set_ylim(bottom=0.0)
    error.grid(alpha=0.3)
    figure.suptitle(title, fontsize=10)
    buffer = io.BytesIO()
    metadata = {"Date": None} if fmt == "svg" else None
    # an SVG's text stays text, and its ids and bytes are the same from one run to the next
    with matplotlib.rc_context({"svg.fonttype": "none", "svg.hashsalt": "omnislam"}):
        figure.savefig(buffer, format=fmt, dpi=PNG_DPI, metadata=metadata)
    return buffer.getvalue()
