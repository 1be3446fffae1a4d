"""One colour per estimator column, the same in every figure and table of every report.

The registered estimators have fixed colours from the Okabe-Ito palette (distinguishable with
the common colour-vision deficiencies; Okabe & Ito 2008), dead reckoning is always the same
grey and the ground truth always black, whatever subset of estimators a report holds. A column
with any other label (an estimator run with options, ``"fastslam2 [particles=50]"``, or an
estimator registered later) takes a colour of ``EXTRA_COLOURS`` chosen by a stable hash of the
label, so it too keeps its colour from one report to the next; only when two such labels of one
report hash to the same colour does the later (in sorted order) take the next free one.

Pure Python: the tables use it without importing matplotlib.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable

#: the ground truth in every figure
TRUTH = "#000000"
#: dead reckoning, the baseline, in every figure
DEAD_RECKONING = "#7f7f7f"

#: registered estimator name -> its colour (hex RGB, lower case as matplotlib writes SVG)
ESTIMATOR_COLOURS: dict[str, str] = {
    "deadreckoning": DEAD_RECKONING,
    "graphslam": "#0072b2",  # blue
    "graphslam-batch": "#56b4e9",  # sky blue: the same graph, solved in batch
    "fastslam1": "#e69f00",  # orange
    "fastslam2": "#d55e00",  # vermillion: FastSLAM's other proposal
    "ekfslam": "#009e73",  # bluish green
    "ukf": "#cc79a7",  # reddish purple
}

#: colours of other labels: tones far from the ones above and from grey and black
EXTRA_COLOURS: tuple[str, ...] = (
    "#8c564b",  # brown
    "#9467bd",  # violet
    "#bcbd22",  # olive
    "#393b79",  # indigo
    "#637939",  # moss
    "#843c39",  # maroon
    "#7b4173",  # plum
    "#e7298a",  # magenta
    "#a6761d",  # ochre
)


def _slot(label: str) -> int:
    """A stable (process- and platform-independent) index into EXTRA_COLOURS."""
    digest = hashlib.sha256(label.encode("utf-8")).digest()
    return int.from_bytes(digest[:4], "big") % len(EXTRA_COLOURS)


def colour(label: str) -> str:
    """The colour of one column label, ignoring the other columns of its report."""
    return ESTIMATOR_COLOURS.get(label) or EXTRA_COLOURS[_slot(label)]


def colours(labels: Iterable[str]) -> dict[str, str]:
    """The colour of each column label of one report (see the module docstring).

    Registered estimator names get their fixed colour; other labels their hashed colour, or
    the next one not yet taken in this report when it is (EXTRA_COLOURS repeat only when a
    report holds more than len(EXTRA_COLOURS) such labels).
    """
    labels = list(dict.fromkeys(labels))
    out = {label: ESTIMATOR_COLOURS[label] for label in labels if label in ESTIMATOR_COLOURS}
    taken: set[str] = set()
    for label in sorted(label for label in labels if label not in ESTIMATOR_COLOURS):
        slot = _slot(label)
        for step in range(len(EXTRA_COLOURS)):
            candidate = EXTRA_COLOURS[(slot + step) % len(EXTRA_COLOURS)]
            if candidate not in taken:
                break
        else:
            candidate = EXTRA_COLOURS[slot]
        taken.add(candidate)
        out[label] = candidate
    return {label: out[label] for label in labels}
