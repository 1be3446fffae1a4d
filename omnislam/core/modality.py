"""Sensor modality: which observation stream of a ``FrameInput`` an estimator consumes.

A dataset (with its front-end log, when it has one) describes which streams it carries; every
estimator declares which it can consume; ``resolve_modality`` picks one stream **once, at
construction**, by the one rule below, shared by all estimators. No estimator decides this
lazily from the first frame, and none reads another stream.

The rule: an explicit override (``--set modality=NAME``) wins if the data carry that stream and
the estimator consumes it; otherwise the first modality of ``PRIORITY`` that the data carry and
the estimator consumes. ``PRIORITY`` puts the streams the shared front end extracts from images
first (the experiment an image dataset is recorded for): omni bearings, then vertical-line
bearings; then direct range-bearing sightings (MR.CLAM, Victoria Park, synthetic poles, laser
landmarks).
"""

from __future__ import annotations

import enum
from collections.abc import Iterable

from omnislam.core.types import Bearings, FrameInput, RangeBearing, VerticalLines
from omnislam.errors import ConfigError

#: the ``--set`` key that overrides the resolved modality
MODALITY_OPTION = "modality"


class Modality(enum.Enum):
    """One observation stream of ``FrameInput``.

    * ``RANGE_BEARING_2D``: ``FrameInput.range_bearing``, planar range and bearing to point
      landmarks (MR.CLAM barcodes, Victoria Park trees, synthetic poles, laser landmarks).
    * ``BEARINGS_3D``: ``FrameInput.bearings``, unit bearing vectors (azimuth and elevation) of
      the omni front end's feature tracks.
    * ``VERTICAL_LINES``: ``FrameInput.vertical_lines``, the planar bearing (2-D bearing-only)
      of each vertical line, with its colour profiles (Barra & Costa).
    """

    RANGE_BEARING_2D = "range-bearing-2d"
    BEARINGS_3D = "bearings-3d"
    VERTICAL_LINES = "vertical-lines"

    @property
    def label(self) -> str:
        """Human-readable name for messages."""
        return _LABELS[self]

    def stream(self, frame: FrameInput) -> Bearings | RangeBearing | VerticalLines | None:
        """This stream's record of ``frame`` (None when the frame has none)."""
        return getattr(frame, _FIELDS[self])

    def count(self, frame: FrameInput) -> int:
        """Number of sightings of this stream in ``frame`` (0 when absent)."""
        stream = self.stream(frame)
        return 0 if stream is None else len(stream)

    @classmethod
    def parse(cls, text: str) -> Modality:
        """The modality named ``text`` (its value; ``_`` and ``-`` are interchangeable).

        Raises:
            ConfigError: an unknown name, listing the known ones.
        """
        wanted = text.strip().lower().replace("_", "-")
        for modality in cls:
            if modality.value == wanted:
                return modality
        known = ", ".join(m.value for m in cls)
        raise ConfigError(f"unknown modality {text!r}; known: {known}")


_FIELDS = {
    Modality.RANGE_BEARING_2D: "range_bearing",
    Modality.BEARINGS_3D: "bearings",
    Modality.VERTICAL_LINES: "vertical_lines",
}
_LABELS = {
    Modality.RANGE_BEARING_2D: "range-bearing 2-D sightings",
    Modality.BEARINGS_3D: "omni bearings (3-D)",
    Modality.VERTICAL_LINES: "vertical-line bearings (2-D)",
}

#: where each stream comes from, for the message of data that carry none an estimator takes
_SOURCES = {
    Modality.RANGE_BEARING_2D: "landmark sightings with bearings (e.g. MR.CLAM's "
    "RobotN_Measurement.dat) or laser scans the front end finds landmarks in",
    Modality.BEARINGS_3D: "omni camera images (the shared front end tracks their features)",
    Modality.VERTICAL_LINES: "camera images (the shared front end extracts their vertical lines)",
}

#: the shared preference order of ``resolve_modality``
PRIORITY: tuple[Modality, ...] = (
    Modality.BEARINGS_3D,
    Modality.VERTICAL_LINES,
    Modality.RANGE_BEARING_2D,
)


def modalities_of(frames: Iterable[FrameInput]) -> frozenset[Modality]:
    """The streams that carry at least one sighting in some frame of ``frames``."""
    found: set[Modality] = set()
    for frame in frames:
        found.update(m for m in Modality if m not in found and m.count(frame))
        if len(found) == len(Modality):
            break
    return frozenset(found)


def _names(modalities: Iterable[Modality]) -> str:
    ordered = [m.value for m in PRIORITY if m in set(modalities)]
    return ", ".join(ordered) if ordered else "none"


def resolve_modality(
    available: Iterable[Modality],
    accepted: Iterable[Modality],
    override: Modality | None = None,
    *,
    estimator: str = "the estimator",
    dataset: str = "the data",
) -> Modality:
    """The one stream an estimator consumes on a dataset (the rule of the module docstring).

    Args:
        available: the streams the dataset (and its front-end log) carry.
        accepted: the streams the estimator can consume.
        override: ``--set modality=NAME``, or None.
        estimator: the estimator's name, for the error message.
        dataset: the dataset's name, for the error message.

    Returns:
        The resolved modality.

    Raises:
        ConfigError: the override is not carried or not consumed, or no stream fits; the
            message says which modalities the data have and which the estimator takes.
    """
    available = frozenset(available)
    accepted = frozenset(accepted)
    detail = f"{dataset} has: {_names(available)}; {estimator} takes: {_names(accepted)}"
    if override is not None:
        if override not in available or override not in accepted:
            raise ConfigError(f"{MODALITY_OPTION}={override.value} is not usable: {detail}")
        return override
    for modality in PRIORITY:
        if modality in available and modality in accepted:
            return modality
    wanted = " or ".join(_SOURCES[m] for m in PRIORITY if m in accepted)
    raise ConfigError(f"{estimator} cannot run on {dataset}: {detail}; give it {wanted}")
