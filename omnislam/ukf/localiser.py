"""The vertical-line UKF localiser of Barra & Costa: the five steps of sec. 3 around the UKF.

Per frame: predict with the odometry (sec. 4). Once the robot has travelled d_it since the last
processed frame (sec. 5: 37.5 cm between images; ``SpacingConfig.d_it_sightings_m``, 0, for the
frames of a range-bearing sensor) and the frame carries sightings, process it:

1.-2. the front end's vertical lines and their PMCs (``frontend.vertical_edges``), or the
      bearings of a range-bearing sensor (ranges unused);
3.    match them to the previous processed frame's (``tracking.track_lines``) with the
      displacement the filter estimates between the two frames;
4.    candidates from the predicted pose (``candidates``), photometric gate and C'_ij
      (``photometric``), u_shift windows and Sc_k (``association.associate_landmarks``);
5.    validation (``association.validate``); the validated bearings update the UKF.

With ``association.use_ids`` (by default: in a frame whose every sighting carries one) the
sightings' own landmark ids are the association (steps 3-5 skipped); otherwise ids are never
read.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from omnislam.core.gating import chi_square_gate
from omnislam.core.modality import Modality
from omnislam.core.motion import OdometryMotionModel
from omnislam.core.se import se2_between, wrap_angle
from omnislam.core.types import UNKNOWN_ID, Estimate, FrameInput, PriorMap, Trajectory
from omnislam.errors import ConfigError
from omnislam.ukf.association import PoseConsistency, associate_landmarks, validate
from omnislam.ukf.candidates import Candidates, select_candidates
from omnislam.ukf.config import PhotometricMode, UKFConfig
from omnislam.ukf.filter import PoseUKF
from omnislam.ukf.image_line import ImageLine
from omnislam.ukf.photometric import colour_differences, mc_from_pmc, photometric_scores
from omnislam.ukf.tracking import track_lines


@dataclass(frozen=True, slots=True)
class Sightings:
    """What one frame saw, in the localiser's terms.

    Attributes:
        bearings_rad: (K,) robot-frame bearings.
        sigmas_rad: (K,) their stds.
        profiles: (K, 3, W) PMCs, or None (no images).
        landmark_ids: (K,) ids as given (UNKNOWN_ID where unknown).
    """

    bearings_rad: np.ndarray
    sigmas_rad: np.ndarray
    profiles: np.ndarray | None
    landmark_ids: np.ndarray


@dataclass(frozen=True, slots=True)
class FrameAssociation:
    """What the localiser did with one processed frame (for benchmarks and tests).

    Attributes:
        index: frame index.
        bearings_rad: (K,) the sightings' bearings.
        candidates: landmark ids expected in view.
        pairs: (n, 2) step 4's [projection, landmark id].
        used: (m, 2) the validated pairs that updated the filter.
        prior_pose, prior_cov: the predicted pose (3,) and its covariance (3, 3) the frame was
            associated with (before its update).
    """

    index: int
    bearings_rad: np.ndarray
    candidates: np.ndarray
    pairs: np.ndarray
    used: np.ndarray
    prior_pose: np.ndarray
    prior_cov: np.ndarray


@dataclass(frozen=True, slots=True)
class UKFInfo:
    """Counts written to ``estimator_info.json``."""

    modality: str
    photometric_gate: bool
    use_ids: bool | None
    frames: int
    frames_processed: int
    frames_updated: int
    sightings_processed: int
    candidates_total: int
    pairs_pregated: int
    pairs_step4: int
    pairs_validated: int
    pairs_gated_out: int
    sets_scored: int


class VerticalLineUKF:
    """Localisation against a known map of vertical lines (or point landmarks seen by bearing).

    Args:
        prior_map: the map (points, walls, optional MC descriptors, the first frame's pose).
        config: UKFConfig.
        modality: VERTICAL_LINES or RANGE_BEARING_2D (bearings only).
        image_line: the 1-D image (``image_line.image_line_from_rig`` or ``AngularLine``).

    Raises:
        ConfigError: a map without an initial pose or without landmarks; photometric gate ON
            with a map without MC descriptors.
    """

    name = "ukf"

    def __init__(
        self,
        prior_map: PriorMap,
        config: UKFConfig,
        modality: Modality,
        image_line: ImageLine,
    ) -> None:
        if modality not in (Modality.VERTICAL_LINES, Modality.RANGE_BEARING_2D):
            raise ConfigError(f"ukf consumes vertical lines or range-bearing, not {modality.value}")
        if prior_map.initial_pose_w is None:
            raise ConfigError(
                f"ukf: the prior map ({prior_map.source}) has no initial pose; "
                "use a map whose first pose is known (--set prior_map=RUN_DIR)"
            )
        lines = prior_map.vertical_line
        use = lines if lines.any() else np.ones(len(prior_map), dtype=bool)
        if not use.any():
            raise ConfigError(f"ukf: the prior map ({prior_map.source}) holds no landmark")
        self.config = config
        self.modality = modality
        self.image_line = image_line
        self._ids = prior_map.landmark_ids[use]
        self._points = np.ascontiguousarray(prior_map.points_w[use, :2])
        self._walls = prior_map.walls_w
        self._row_of = {int(i): k for k, i in enumerate(self._ids)}
        has_mc = prior_map.means_left is not None
        mode = config.photometric.mode
        if mode is PhotometricMode.ON and not has_mc:
            raise ConfigError(
                f"ukf: photometric.mode=on needs MC descriptors (means_left/means_right) in the "
                f"prior map, and {prior_map.source} has none (a synthetic folder's "
                "line_colours.csv, written by `omnislam dataset synth`, holds them); set "
                "photometric.mode=off or auto"
            )
        self._photometric = (
            mode is not PhotometricMode.OFF and has_mc and (modality is Modality.VERTICAL_LINES)
        )
        if self._photometric:
            self._mc_left = np.asarray(prior_map.means_left)[use]
            self._mc_right = np.asarray(prior_map.means_right)[use]
        self.motion = OdometryMotionModel(config.motion_noise)
        start = config.filter
        P0 = np.diag([start.initial_sigma_xy_m**2] * 2 + [start.initial_sigma_theta_rad**2])
        self._ukf = PoseUKF(prior_map.initial_pose_w, P0, self.motion, config.sigma_points)
        self._tolerance_rad = config.tracking.tolerance_px / image_line.px_per_rad
        gate = config.filter.innovation_gate
        # one bearing: 1 degree of freedom
        self._gate = None if gate is None else chi_square_gate(gate, 1)
        # images every d_it (sec. 5); a range-bearing sensor's frames as they come (config)
        spacing = config.spacing
        self._d_it_m = (
            spacing.d_it_m if modality is Modality.VERTICAL_LINES else spacing.d_it_sightings_m
        )
        self._stamps: list[float] = []
        self._poses: list[np.ndarray] = []
        self._covs: list[np.ndarray] = []
        self._travel_m = math.inf  # the first frame with sightings is processed
        self._prev: tuple[Sightings, dict[int, int], np.ndarray] | None = None
        self.associations: list[FrameAssociation] = []
        self._counts = dict.fromkeys(
            (
                "frames_processed",
                "frames_updated",
                "sightings_processed",
                "candidates_total",
                "pairs_pregated",
                "pairs_step4",
                "pairs_validated",
                "pairs_gated_out",
                "sets_scored",
            ),
            0,
        )

    # --- the Estimator protocol -----------------------------------------------------------
    def step(self, frame: FrameInput) -> None:
        """Predict with the frame's odometry; process its sightings every d_it of travel."""
        if self._stamps:
            delta = frame.odometry.delta
            self._ukf.predict(delta, frame.odometry.covariance)
            self._travel_m += math.hypot(delta[0], delta[1])
        sightings = self._sightings(frame)
        due = self._travel_m >= (1.0 - self.config.spacing.d_it_tolerance) * self._d_it_m
        if sightings is not None and len(sightings.bearings_rad) and due:
            self._process(frame.index, sightings)
            self._travel_m = 0.0
        self._stamps.append(frame.stamp_s)
        self._poses.append(self._ukf.x)
        self._covs.append(self._ukf.P)

    def estimate(self) -> Estimate:
        """One pose per frame with its covariance, and no landmarks: a localiser estimates none
        (the prior map it used is the input, not a result to score)."""
        poses = np.array(self._poses).reshape(-1, 3)
        return Estimate(
            trajectory=Trajectory.from_se2(np.array(self._stamps), poses),
            pose_covariances=np.array(self._covs).reshape(-1, 3, 3),
        )

    def info(self) -> UKFInfo:
        """Counts of the association and the updates so far."""
        return UKFInfo(
            modality=self.modality.value,
            photometric_gate=self._photometric,
            use_ids=self.config.association.use_ids,
            frames=len(self._stamps),
            **self._counts,
        )

    # --- the five steps -------------------------------------------------------------------
    def _sightings(self, frame: FrameInput) -> Sightings | None:
        sigma = self.config.filter.sigma_bearing_rad
        if self.modality is Modality.VERTICAL_LINES:
            v = frame.vertical_lines
            if v is None:
                return None
            profiles = v.profiles if v.profiles.shape[2] >= 3 else None
            sig = v.sigma_bearing_rad if sigma is None else np.full(len(v), sigma)
            return Sightings(v.bearings_rad, sig, profiles, v.landmark_ids)
        rb = frame.range_bearing
        if rb is None:
            return None
        sig = rb.sigma_bearing_rad if sigma is None else np.full(len(rb), sigma)
        return Sightings(rb.bearings_rad, sig, None, rb.landmark_ids)

    def _process(self, index: int, seen: Sightings) -> None:
        """Steps 3-5 and the update on one processed frame (module docstring)."""
        self._counts["frames_processed"] += 1
        self._counts["sightings_processed"] += len(seen.bearings_rad)
        wTr, prior_cov = self._ukf.x, self._ukf.P
        if self._takes_ids(seen.landmark_ids):
            pairs = used = self._pairs_by_id(seen.landmark_ids)
            candidate_ids = np.array(sorted(set(used.values())), dtype=np.int64)
        else:
            pairs, candidate_ids = self._step4(wTr, seen)
            used = self._step5(wTr, seen, pairs)
        self._counts["pairs_step4"] += len(pairs)
        lines_used = self._update(seen, used)
        self._prev = (seen, pairs, self._ukf.x)
        self.associations.append(
            FrameAssociation(
                index=index,
                bearings_rad=seen.bearings_rad,
                candidates=np.asarray(candidate_ids, dtype=np.int64),
                pairs=_pair_array(pairs),
                used=_pair_array({i: used[i] for i in lines_used.tolist()}),
                prior_pose=wTr,
                prior_cov=prior_cov,
            )
        )

    def _takes_ids(self, landmark_ids: np.ndarray) -> bool:
        """Whether the sightings' own ids are the association (``AssociationConfig.use_ids``:
        by default when every sighting of the frame carries one)."""
        use_ids = self.config.association.use_ids
        if use_ids is None:
            return bool(len(landmark_ids)) and bool(np.all(landmark_ids != UNKNOWN_ID))
        return use_ids

    def _pairs_by_id(self, landmark_ids: np.ndarray) -> dict[int, int]:
        """Projection index -> landmark id for the sightings whose id the map holds."""
        rows = np.array([self._row_of.get(int(i), -1) for i in landmark_ids])
        lines = np.flatnonzero((landmark_ids != UNKNOWN_ID) & (rows >= 0))
        return {int(i): int(self._ids[rows[i]]) for i in lines}

    def _step4(self, wTr: np.ndarray, seen: Sightings) -> tuple[dict[int, int], np.ndarray]:
        """Step 4: candidates, the pre-gate, the photometric gate and C'_ij, u_shift windows
        and Sc_k.

        Returns:
            (projection index -> landmark id of the chosen set, the candidates' ids).
        """
        cfg = self.config.association
        cands = select_candidates(
            wTr, self._points, self._walls, self.image_line, cfg.max_range_m, cfg.wall_margin_m
        )
        self._counts["candidates_total"] += len(cands)
        candidate_ids = self._ids[cands.index]
        consistency = self._pose_consistency(seen, cands)
        if consistency is None:
            allowed = np.ones((len(seen.bearings_rad), len(cands)), dtype=bool)
        else:
            allowed = consistency.pregate()
        self._counts["pairs_pregated"] += int(allowed.sum())
        scores = self._pair_scores(seen, cands, allowed)
        u_lines = self.image_line.u_px(seen.bearings_rad)
        best = associate_landmarks(u_lines, cands.u_px, scores, cfg, consistency)
        self._counts["sets_scored"] += best.sets
        pairs = {
            int(i): int(candidate_ids[c])
            for i, c in zip(best.lines.tolist(), best.candidates.tolist(), strict=True)
        }
        return pairs, candidate_ids

    def _pose_consistency(self, seen: Sightings, cands: Candidates) -> PoseConsistency | None:
        """What the predicted pose and its covariance say about every (sighting, candidate)
        pair (``AssociationConfig.gate_probability``; None without that gate or candidates)."""
        probability = self.config.association.gate_probability
        if probability is None or not len(cands):
            return None
        prediction = self._ukf.predict_bearings(self._points[cands.index])
        return PoseConsistency(
            wrap_angle(seen.bearings_rad[:, None] - prediction.mean[None, :]),
            np.asarray(seen.sigmas_rad, dtype=float) ** 2,
            prediction,
            probability,
        )

    def _pair_scores(self, seen: Sightings, cands: Candidates, allowed: np.ndarray) -> np.ndarray:
        """(K, C) C'_ij of the pre-gated pairs (0 without the photometric stage), NaN where a
        gate rejects the pair."""
        scores = np.full(allowed.shape, np.nan)
        columns = np.flatnonzero(allowed.any(axis=0))
        if self._photometric and seen.profiles is not None and columns.size:
            # the photometric gate and C'_ij of the pre-gated pairs only
            left, right = mc_from_pmc(seen.profiles)
            rows = cands.index[columns]
            band, mean = colour_differences(left, right, self._mc_left[rows], self._mc_right[rows])
            scores[:, columns] = photometric_scores(band, mean, self.config.photometric)
        else:
            scores[:, columns] = 0.0
        scores[~allowed] = np.nan
        return scores

    def _step5(self, wTr: np.ndarray, seen: Sightings, pairs: dict[int, int]) -> dict[int, int]:
        """Steps 3 and 5: the pairs whose landmark the previous processed frame gave the same
        physical line (all of them without ``AssociationConfig.validate``)."""
        if not self.config.association.validate:
            return pairs
        if self._prev is None:
            return {}
        prev_seen, prev_pairs, prev_pose = self._prev
        tracked = track_lines(
            prev_seen.bearings_rad,
            seen.bearings_rad,
            se2_between(prev_pose, wTr),
            self._tolerance_rad,
            self.config.tracking,
            prev_seen.profiles,
            seen.profiles,
        )
        return validate(pairs, tracked, prev_pairs)

    def _update(self, seen: Sightings, used: dict[int, int]) -> np.ndarray:
        """The UKF update with the used pairs that pass the innovation gate.

        Returns:
            (m,) the projection indices that updated the filter, in increasing order.
        """
        lines_used = np.array(sorted(used), dtype=np.int64)
        landmarks = np.array([self._points[self._row_of[used[i]]] for i in lines_used.tolist()])
        bearings = seen.bearings_rad[lines_used]
        sigmas = seen.sigmas_rad[lines_used]
        if self._gate is not None and lines_used.size:
            keep = self._ukf.innovations(bearings, landmarks, sigmas) <= self._gate
            self._counts["pairs_gated_out"] += int((~keep).sum())
            lines_used, landmarks = lines_used[keep], landmarks[keep]
            bearings, sigmas = bearings[keep], sigmas[keep]
        if lines_used.size:
            self._ukf.update(bearings, landmarks.reshape(-1, 2), sigmas)
            self._counts["frames_updated"] += 1
            self._counts["pairs_validated"] += int(lines_used.size)
        return lines_used


def _pair_array(pairs: dict[int, int]) -> np.ndarray:
    if not pairs:
        return np.zeros((0, 2), dtype=np.int64)
    return np.array(sorted(pairs.items()), dtype=np.int64)
