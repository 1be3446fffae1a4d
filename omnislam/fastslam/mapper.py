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
from omnislam.fastslam.config import BearingsConfig
from omnislam.fastslam.landmark_store import LandmarkBlock
from omnislam.fastslam.range_bearing_mapper import RangeBearingMapper
from omnislam.fastslam.sightings import Sightings

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
        proposal_converged_only: whether only converged landmarks may refine the FastSLAM 2.0
            proposal (``proposal_sampling.converged_pairs``): landmarks triangulated from
            bearings are uncertain in depth, their errors correlated with the poses that
            triangulated them.
        sightings_gated: (particle, sighting) landmark updates its gate rejected so far.
        triangulation_fallbacks: triangulated updates replaced by the direct one so far (0
            where nothing is triangulated).
    """

    modality: Modality
    landmark_dim: int
    ray_dim: int
    proposal_model: MeasurementModel
    proposal_gate: float
    proposal_converged_only: bool
    sightings_gated: int
    triangulation_fallbacks: int

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


def make_mapper(
    modality: Modality,
    bearings: BearingsConfig,
    sensor_height_m: float,
    outlier_gate_probability: float = 1.0,
    kernels: object | None = None,
) -> LandmarkMapper:
    """The mapper of ``modality``: the 3-D one of the ``bearings`` section seen from
    ``sensor_height_m``, the 2-D one gating at ``outlier_gate_probability``
    (``ExperimentalConfig``); both update with the compiled ``kernels`` when given.

    Raises:
        ConfigError: no modality, or one FastSLAM does not consume (naming those it does).
    """
    if modality is Modality.RANGE_BEARING_2D:
        return RangeBearingMapper(kernels, outlier_gate_probability)
    if modality is Modality.BEARINGS_3D:
        return BearingMapper(bearings, sensor_height_m, kernels)
    allowed = " or ".join(m.value for m in MODALITIES)
    got = modality.value if isinstance(modality, Modality) else repr(modality)
    raise ConfigError(f"FastSLAM consumes the modality {allowed}, not {got}")
