"""Sightings -> (particle, slot, sighting) pairs: known ids, and per-particle maximum likelihood.

A sighting with a known landmark id addresses that landmark's slot in every particle. For a
sighting of unknown association (Montemerlo 2003, FastSLAM with unknown data association; Thrun
et al. 2005 sec. 13.6) every particle independently picks the landmark of its own map that
explains it best; if even the best explains it with likelihood below p0, the particle creates a
new landmark. Different particles may associate differently; wrong hypotheses die out in
resampling. Unknown association is supported for range-bearing sightings (the bearing mapper
refuses bearings without track ids).

Experimental options (``ExperimentalConfig``, all off by default): the pose term of S may be
widened by the odometry's covariance since each landmark was last seen
(``resighting.ResightingSpread``) or by the filter's pose covariance relative to its maps
(``pose_spread.PoseSpread``); the new-landmark test may be a chi-square gate on y^T S^-1 y
instead of log p0; and a frame's sightings may be assigned under mutual exclusion.
"""

from __future__ import annotations

import numpy as np

from omnislam.core.batch_linalg import inverse_and_logdet, transpose
from omnislam.core.gaussian import (
    LOG_2PI,
    log_likelihood_from_mahalanobis,
    mahalanobis_squared,
)
from omnislam.core.measurement import MeasurementModel, RangeBearing2D
from omnislam.fastslam.config import AssociationConfig
from omnislam.fastslam.landmark_store import ESTIMATED, LandmarkStore
from omnislam.fastslam.pose_spread import PoseSpread
from omnislam.fastslam.resighting import ResightingSpread
from omnislam.fastslam.sightings import Pairs, Sightings
from omnislam.fastslam.slot_registry import SlotRegistry

#: association result meaning "a new landmark"
NEW_LANDMARK = -1


class SightingAssociation:
    """Turns one frame's sightings into the pairs every particle updates.

    Args:
        registry: the filter's slots (known ids, new slots, the positions near the robot).
        store: the landmark store (candidate landmarks of each particle's map).
        config: the association section: the new-landmark threshold log p0 and the margin of
            the coarse gate (unknown sightings are compared with the landmarks whose last known
            position lies within the largest sighting range plus ``margin_m`` of the mean pose).
        exclusive: one landmark explains at most one sighting of a frame (mutual exclusion).
        spread: the odometry's pose covariance accumulated since each landmark was last seen
            (``resighting.ResightingSpread``), added to the pose term of each candidate's
            innovation covariance; None: the particle's pose alone (Montemerlo 2003).
        gate: the chi-square quantile of the new-landmark test, or None for log p0 alone
            (``maximum_likelihood_association``).
        pose_spread: the filter's pose covariance relative to its maps
            (``pose_spread.PoseSpread``), added to every particle's pose covariance, or None.
        kernels: the compiled kernels (``kernels.compiled()``) for the likelihoods of every
            (particle, sighting, candidate) triple, or None for the numpy reference (the same
            numbers, ``association_log_likelihood``).
    """

    def __init__(
        self,
        registry: SlotRegistry,
        store: LandmarkStore,
        config: AssociationConfig,
        exclusive: bool = False,
        spread: ResightingSpread | None = None,
        gate: float | None = None,
        pose_spread: PoseSpread | None = None,
        kernels: object | None = None,
    ) -> None:
        self._registry = registry
        self._kernels = kernels
        self._pose_spread = pose_spread
        self._spread = spread
        self._gate = gate
        #: (particle, sighting) decisions on unknown sightings: matched / new landmark
        self.matched = 0
        self.created = 0
        self._store = store
        self._margin_m = config.margin_m
        self._log_p0 = config.new_landmark_log_likelihood
        self._exclusive = exclusive
        self._model = RangeBearing2D()

    def pairs(
        self,
        sightings: Sightings,
        poses: np.ndarray,
        pose_cov: np.ndarray | None,
        weights: np.ndarray,
    ) -> Pairs:
        """(particle, slot, sighting) triples: known ids map to their slots in every particle;
        unknown sightings are associated per particle by maximum likelihood.

        Args:
            sightings: the frame's sightings.
            poses: (P, 3) sampled poses (FastSLAM 1.0) or the motion prediction's means (2.0).
            pose_cov: (P, 3, 3) the prediction's covariances (2.0), or None.
            weights: (P,) the particle weights (the mean pose of the coarse gate).
        """
        p = len(poses)
        known = np.flatnonzero(sightings.ids >= 0)
        unknown = np.flatnonzero(sightings.ids < 0)
        parts: list[Pairs] = []
        if known.size:
            slots = self._registry.slots_for_ids(sightings.ids[known])
            parts.append(
                Pairs(
                    np.repeat(np.arange(p), known.size),
                    _tiled(slots, p),
                    _tiled(known, p),
                    np.zeros(p * known.size, dtype=bool),
                )
            )
        if unknown.size:
            parts.append(self._unknown(sightings, unknown, poses, pose_cov, weights))
        return Pairs.concatenate(parts)

    def _unknown(
        self,
        sightings: Sightings,
        unknown: np.ndarray,
        poses: np.ndarray,
        pose_cov: np.ndarray | None,
        weights: np.ndarray,
    ) -> Pairs:
        """Pairs of the unknown sightings: the ML landmark of each particle, or a new slot."""
        p = len(poses)
        center = np.average(poses[:, :2], axis=0, weights=weights)
        radius = float(sightings.z[unknown, 0].max()) + self._margin_m
        candidates = self._registry.near(center, radius)
        c = candidates.size
        block = self._store.gather(np.repeat(np.arange(p), c), _tiled(candidates, p))
        if self._pose_spread is not None:
            extra = self._pose_spread.world_frame(p)
            pose_cov = extra if pose_cov is None else pose_cov + extra
        if self._spread is not None and c:
            gap = self._spread.world_frame(candidates, poses[:, 2])  # (P, C, 3, 3)
            pose_cov = gap if pose_cov is None else pose_cov[:, None] + gap
        choice, _ = maximum_likelihood_association(
            poses,
            pose_cov,
            block.mean.reshape(p, c, 2),
            block.cov.reshape(p, c, 2, 2),
            (block.status == ESTIMATED).reshape(p, c),
            sightings.z[unknown],
            sightings.R[unknown],
            self._model,
            self._log_p0,
            self._exclusive,
            self._gate,
            self._kernels,
        )
        new = choice == NEW_LANDMARK  # (P, K_u)
        n_new = int(np.count_nonzero(new))
        self.created += n_new
        self.matched += new.size - n_new
        wanted = np.flatnonzero(new.any(axis=0))
        new_slots = np.full(unknown.size, -1, dtype=np.int64)
        if wanted.size:
            new_slots[wanted] = self._registry.add(None, wanted.size)
        existing = candidates[np.maximum(choice, 0)] if c else np.zeros_like(choice)
        slots = np.where(new, new_slots[None, :], existing)
        return Pairs(
            np.repeat(np.arange(p), unknown.size),
            slots.ravel(),
            _tiled(unknown, p),
            new.ravel(),
        )


def _tiled(values: np.ndarray, times: int) -> np.ndarray:
    """``np.tile(values, times)`` of a 1-D array, by one broadcast copy (np.tile costs ~10x)."""
    return np.broadcast_to(values, (times, values.size)).ravel()


def maximum_likelihood_association(
    poses: np.ndarray,
    pose_cov: np.ndarray | None,
    landmark_mean: np.ndarray,
    landmark_cov: np.ndarray,
    landmark_valid: np.ndarray,
    z: np.ndarray,
    R: np.ndarray,
    model: MeasurementModel,
    log_p0: float,
    exclusive: bool = False,
    gate: float | None = None,
    kernels: object | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Associate K sightings with C candidate landmarks in each of P particles.

    The likelihood of sighting k under landmark c is N(z_k; h(x, mu_c), S) with
    S = H_m Sigma_c H_m^T + R_k, plus H_x P H_x^T when the pose is still uncertain (FastSLAM 2.0
    associates before sampling, with the motion prediction's covariance P). Each sighting takes
    its likeliest landmark (Montemerlo 2003 ch. 4), or, with ``exclusive``, the frame's
    sightings are assigned greedily so that no landmark takes two of them
    (``_exclusive_choice``).

    Args:
        poses: (P, 3) particle poses (sampled, or the predicted means for FastSLAM 2.0).
        pose_cov: (P, 3, 3) pose covariance, or (P, C, 3, 3) one per candidate (with the
            spread since its last sighting), or None for a sampled (exact) pose.
        landmark_mean: (P, C, d) candidates in each particle's map.
        landmark_cov: (P, C, d, d) their covariances.
        landmark_valid: (P, C) False where the particle has no estimate of the candidate.
        z: (K, k) sightings; R: (K, k, k) their noise.
        model: measurement model.
        log_p0: log-likelihood threshold for a new landmark.
        exclusive: enforce mutual exclusion within the frame.
        gate: None: a sighting starts a new landmark when its likeliest candidate's
            log-likelihood is below ``log_p0`` (Montemerlo 2003 sec. 3.4.1). A chi-square
            quantile: when no candidate's squared Mahalanobis distance is inside it (the
            validation gate of nearest-neighbour association, Bar-Shalom & Fortmann 1988; Thrun
            et al. 2005 sec. 7.5.2), and the likeliest candidate inside it otherwise -- a test
            on y^T S^-1 y alone, which a wide S (the spread since the last sighting) does not
            push below p0 by its determinant.
        kernels: the compiled kernels for ``association_log_likelihood``, or None.

    Returns:
        choice (P, K): candidate index, or ``NEW_LANDMARK``; and log_likelihood (P, K) of the
        choice (log_p0 for new landmarks).
    """
    p, c = landmark_valid.shape
    k = z.shape[0]
    if c == 0:
        return np.full((p, k), NEW_LANDMARK), np.full((p, k), log_p0)
    log_likelihood, d2 = association_log_likelihood(
        poses, pose_cov, landmark_mean, landmark_cov, landmark_valid, z, R, model, kernels
    )
    if gate is not None:
        # candidates outside the gate are not candidates; inside it, a pair always beats p0
        inside = d2 <= gate
        log_likelihood = np.where(inside, np.maximum(log_likelihood, log_p0), -np.inf)
    if exclusive and k > 1:
        return _exclusive_choice(log_likelihood, log_p0)
    best = np.argmax(log_likelihood, axis=2)
    best_ll = np.take_along_axis(log_likelihood, best[..., None], axis=2)[..., 0]
    new = best_ll < log_p0
    return np.where(new, NEW_LANDMARK, best), np.where(new, log_p0, best_ll)


def _exclusive_choice(log_likelihood: np.ndarray, log_p0: float) -> tuple[np.ndarray, np.ndarray]:
    """Greedy maximum-likelihood assignment under mutual exclusion, per particle.

    Each particle takes its likeliest remaining (sighting, landmark) pair, removes that sighting
    and that landmark from its remaining choices, and repeats while a pair above log p0 is left;
    the sightings left over start new landmarks. Two sightings of one frame are two objects (one
    laser scan does not see a trunk twice), so one landmark explains at most one of them
    (the mutual exclusion constraint of Montemerlo 2003 ch. 4, in the greedy form of the
    assignment).

    Args:
        log_likelihood: (P, K, C) log N(z_k; h(x, mu_c), S), -inf where not a candidate.
        log_p0: the new-landmark threshold.

    Returns:
        choice (P, K) and log-likelihood (P, K) as ``maximum_likelihood_association``.
    """
    p, k, c = log_likelihood.shape
    remaining = log_likelihood.copy()
    choice = np.full((p, k), NEW_LANDMARK)
    chosen_ll = np.full((p, k), log_p0)
    rows = np.arange(p)
    for _ in range(min(k, c)):
        flat = remaining.reshape(p, k * c)
        best = np.argmax(flat, axis=1)
        best_ll = flat[rows, best]
        take = best_ll >= log_p0
        if not take.any():
            break
        who = rows[take]
        sighting, landmark = np.divmod(best[take], c)
        choice[who, sighting] = landmark
        chosen_ll[who, sighting] = best_ll[take]
        remaining[who, sighting, :] = -np.inf
        remaining[who, :, landmark] = -np.inf
    return choice, chosen_ll


def association_log_likelihood(
    poses: np.ndarray,
    pose_cov: np.ndarray | None,
    landmark_mean: np.ndarray,
    landmark_cov: np.ndarray,
    landmark_valid: np.ndarray,
    z: np.ndarray,
    R: np.ndarray,
    model: MeasurementModel,
    kernels: object | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """log N(z_k; h(x, mu_c), S_kc) of K sightings under C candidates in each of P particles,
    S = H_m Sigma_c H_m^T + H_x P H_x^T + R_k (the pose term only with ``pose_cov``; arguments
    as ``maximum_likelihood_association``, ``pose_cov`` (P, 3, 3) or (P, C, 3, 3) per
    candidate).

    The prediction and the sighting-independent part of S are computed per (particle,
    candidate); with ``kernels`` and ``RangeBearing2D`` the rest, per (particle, sighting,
    candidate), is compiled (``_compiled_log_likelihood``): the numpy path's numbers bit for
    bit (the same operations in the same order; log det S stays numpy's).

    Returns:
        (P, K, C) log-likelihoods (-inf where ``landmark_valid`` is False) and (P, K, C) squared
        Mahalanobis distances y^T S^-1 y (inf there).
    """
    z_hat, H_x, H_m = model.predict(poses[:, None, :], landmark_mean)  # (P, C, ...)
    S = H_m @ landmark_cov @ transpose(H_m)
    if pose_cov is not None:
        if pose_cov.ndim == 3:
            pose_cov = pose_cov[:, None]
        S = S + H_x @ pose_cov @ transpose(H_x)
    if kernels is not None and isinstance(model, RangeBearing2D):
        return _compiled_log_likelihood(kernels, z_hat, S, landmark_valid, z, R)
    S = S[:, None] + R[None, :, None]  # (P, K, C, k, k)
    y = model.residual(z[None, :, None, :], z_hat[:, None])
    S_inv, logdet = inverse_and_logdet(S)
    d2 = mahalanobis_squared(y, S_inv)
    log_likelihood = log_likelihood_from_mahalanobis(d2, logdet, y.shape[-1])
    valid = landmark_valid[:, None, :]
    return np.where(valid, log_likelihood, -np.inf), np.where(valid, d2, np.inf)


def _compiled_log_likelihood(
    kernels: object,
    z_hat: np.ndarray,
    S_landmark: np.ndarray,
    landmark_valid: np.ndarray,
    z: np.ndarray,
    R: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """``association_log_likelihood``'s (particle, sighting, candidate) part for range-bearing
    sightings with the compiled kernels, bit for bit the numpy path's numbers.

    The inverses and log-determinants of S = S_pc + R_k are computed once per distinct R (one
    for a sensor of fixed noise, ``kernels.association_inverses``; the log is numpy's, as the
    reference's), then every triple's residual, Mahalanobis distance and log-likelihood in one
    pass (``kernels.association_scores``), without the (P, K, C, 2, 2) temporaries.

    Args:
        z_hat: (P, C, 2) predicted sightings; S_landmark: (P, C, 2, 2) H_m Sigma H_m^T (+ the
            pose term); landmark_valid: (P, C); z: (K, 2); R: (K, 2, 2).

    Returns:
        (P, K, C) log-likelihoods and squared Mahalanobis distances, as the numpy path.
    """
    first: dict[bytes, int] = {}  # a noise's bit pattern -> its group
    group = np.array([first.setdefault(r.tobytes(), len(first)) for r in R], dtype=np.int64)
    noises = R[np.unique(group, return_index=True)[1]]
    p, c = landmark_valid.shape
    inverse = np.empty((len(noises), p, c, 4))
    det = np.empty((len(noises), p, c))
    kernels.association_inverses(S_landmark, noises, inverse, det)
    logdet = np.log(det)
    log_likelihood = np.empty((p, len(z), c))
    d2 = np.empty((p, len(z), c))
    kernels.association_scores(
        z_hat,
        inverse,
        logdet,
        group,
        z,
        landmark_valid,
        z.shape[-1] * LOG_2PI,
        log_likelihood,
        d2,
    )
    return log_likelihood, d2
