"""The landmark mapper of one modality: what the filter asks of the 2-D and 3-D landmark EKFs.

FastSLAM's mapping step (thesis sec. 4.4.1) depends on what the sensor measures: range-bearing
sightings initialise a 2-D landmark at once and update it by EKF (``range_bearing_mapper``);
omni bearings store a ray, triangulate at a later sighting and update a 3-D landmark, with a
chi-square gate against jumped tracks (``bearing_mapper``). The filter resolves its modality at
construction (``core.modality``) and builds the one mapper for it here; everything else in the
filter is the same for both.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from omnislam.core.measurement import MeasurementModel
from omnislam.core.modality import Modality
from omnislam.core.types import FrameInput
from omnislam.errors import ConfigError
from omnislam.fastslam.bearing_mapper import BearingMapper
from omnislam.fastslam.config import FastSLAMConfig
from omnislam.fastslam.landmark_store import LandmarkBlock
from omnislam.fastslam.range_bearing_mapper import RangeBearingMapper
from omnislam.fastslam.sightings import Pairs, Sightings

#: the modalities FastSLAM consumes
MODALITIES: tuple[Modality, ...] = (Modality.RANGE_BEARING_2D, Modality.BEARINGS_3D)


class LandmarkMapper(Protocol):
    """Reads one modality's sightings and updates the addressed landmark EKFs.

    Attributes:
        modality: the stream of ``FrameInput`` it reads.
        landmark_dim: landmark dimension d (2 or 3).
        ray_dim: size of the stored sighting (the bearing's ray, 6) or 0.
        proposal_model: the measurement model of the FastSLAM 2.0 proposal and its weights.
        proposal_gate: validation gate on the proposal's innovations (infinite: none).
    """

    modality: Modality
    landmark_dim: int
    ray_dim: int
    proposal_model: MeasurementModel
    proposal_gate: float

    def read(self, frame: FrameInput) -> Sightings | None:
        """The frame's sightings of this modality, or None when it has none (predict only)."""
        ...

    def update(
        self, block: LandmarkBlock, wTr: np.ndarray, sightings: Sightings, obs: np.ndarray
    ) -> np.ndarray:
        """Update ``block`` (N pairs, one round) in place with sightings ``obs`` (N,) seen from
        the poses ``wTr`` (N, 3).

        Returns:
            (N,) innovation log-likelihoods (FastSLAM 1.0's importance factors, eq. 4.47).
        """
        ...

    def proposal_landmarks(
        self, block: LandmarkBlock, pairs: Pairs, usable: np.ndarray
    ) -> np.ndarray:
        """(N,) bool: which of the ``usable`` pairs refine the FastSLAM 2.0 proposal."""
        ...


def make_mapper(
    modality: Modality, config: FastSLAMConfig, kernels: object | None = None
) -> LandmarkMapper:
    """The mapper of ``modality`` (both update with the compiled ``kernels`` when given; the
    2-D one gates at ``config.outlier_gate_probability``).

    Raises:
        ConfigError: no modality, or one FastSLAM does not consume (naming those it does).
    """
    if modality is Modality.RANGE_BEARING_2D:
        return RangeBearingMapper(kernels, config.outlier_gate_probability)
    if modality is Modality.BEARINGS_3D:
        return BearingMapper(config, kernels)
    allowed = " or ".join(m.value for m in MODALITIES)
    got = modality.value if isinstance(modality, Modality) else repr(modality)
    raise ConfigError(f"FastSLAM consumes the modality {allowed}, not {got}")
