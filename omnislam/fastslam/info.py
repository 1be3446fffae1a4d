"""What a FastSLAM estimator has done so far (``FastSLAM.info``; ``estimator_info.json``)."""

from __future__ import annotations

from dataclasses import dataclass

from omnislam.core.modality import Modality
from omnislam.fastslam.config import Variant


@dataclass(frozen=True, slots=True)
class FastSLAMInfo:
    """What a FastSLAM estimator has done so far (``FastSLAM.info``; ``estimator_info.json``).

    Attributes:
        variant: FastSLAM 1.0 or 2.0.
        modality: the observation stream it reads.
        particles: number of particles P.
        frames: frames consumed.
        frames_with_sightings: frames that carried sightings of the modality (mapped and
            weighed; the others only predicted).
        frames_stated_odometry: frames whose pose noise was drawn from the odometry's stated
            covariance (``FastSLAMConfig.stated_odometry_noise``), not from the alpha model.
        resample_count: resamplings so far.
        last_ess: effective sample size after the last update (thesis eq. 4.51).
        landmark_slots: landmarks known to any particle (slots).
        landmarks: landmarks estimated in the best particle's map (those ``estimate()``
            reports).
        rays_pending: landmarks of the best particle with a stored ray only, waiting for a ray
            with enough parallax (3-D).
        unknown_slots: slots created for sightings of unknown association.
        unknown_matched: (particle, sighting) decisions that gave a sighting of unknown
            association to a landmark of the particle's map.
        unknown_new: (particle, sighting) decisions that made such a sighting a new landmark.
        landmarks_pruned: (particle, landmark) deletions by the existence index (thesis
            5.1.2).
        sightings_gated: (particle, sighting) landmark updates rejected by the outlier gate
            (3-D: ``bearings.gate_probability``; 2-D: ``experimental.outlier_gate_probability``).
        proposal_sightings_gated: (particle, sighting) pairs the gate kept out of the
            FastSLAM 2.0 proposal.
        triangulation_fallbacks: triangulated updates of established landmarks replaced by
            the direct bearing update for lack of parallax (3-D, ``BearingUpdate.TRIANGULATED``).
        distinct_ancestors_min: fewest distinct particles of the previous step any step's set
            descended from (``diversity.py``; 1: the set collapsed onto one particle).
        distinct_ancestors_median: median distinct ancestors over the resampling steps.
        single_ancestor_steps: steps with sightings whose set descended from one particle.
        single_ancestor_longest_run: longest run of consecutive such steps.
        ess_min: smallest effective sample size before resampling.
        log_evidence: the particle filter's estimate of log p(z_1:t)
            (``ParticleSet.log_evidence``).
    """

    variant: Variant
    modality: Modality
    particles: int
    frames: int
    frames_with_sightings: int
    frames_stated_odometry: int
    resample_count: int
    last_ess: float
    landmark_slots: int
    landmarks: int
    rays_pending: int
    unknown_slots: int
    unknown_matched: int
    unknown_new: int
    landmarks_pruned: int
    sightings_gated: int
    proposal_sightings_gated: int
    triangulation_fallbacks: int
    distinct_ancestors_min: int
    distinct_ancestors_median: float
    single_ancestor_steps: int
    single_ancestor_longest_run: int
    ess_min: float
    log_evidence: float
