"""Where FastSLAM's per-particle association of unlabelled range-bearing sightings goes wrong.

The FastSLAM analogue of ``association_diagnosis.py`` (graphslam) and
``ekfslam_association_diagnosis.py``: runs ``fastslam2`` (or ``--estimator fastslam1``) on a
dataset with its ids hidden (``association=unknown``, as ``omnislam run DATASET --estimator
fastslam2 --set association=unknown``) and scores every (particle, sighting) decision against the
hidden ids, looked up by frame, range and bearing in the same dataset loaded with ids. A slot is
named after the hidden id of the sighting that created it. Printed per dataset:

* the decisions: matched to a slot of the same hidden id, matched to another id's, new while the
  particle already held a landmark of the sighting's hidden id (*wrong new*), new for an id the
  particle had not mapped;
* for the wrong new decisions, against the particle's landmark of the true id: the squared
  Mahalanobis distance of the innovation under the association's S (without and with the spread
  since the last sighting, ``resighting.ResightingSpread`` at scale 1), the time since any particle
  last saw that slot, and the position std the odometry's noise (the motion model's step
  covariance) accumulates over that gap -- binned by the gap;
* the final map of the best particle: landmarks per hidden id.

``--set key=value`` overrides the estimator's options::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python \\
        benchmarks/fastslam_association_diagnosis.py [mrclam6-r1 ...] [--set key=value ...]
"""

from __future__ import annotations

import collections
import itertools
import sys

import numpy as np
from association_diagnosis import diagnose_each, hidden_ids

from omnislam.core.measurement import RangeBearing2D
from omnislam.estimators import make_estimator
from omnislam.fastslam import association as fs_association
from omnislam.fastslam.association import association_log_likelihood
from omnislam.fastslam.landmark_store import ESTIMATED
from omnislam.fastslam.resighting import ResightingSpread
from omnislam.harness.frames import sequence_info

#: a pairing with a landmark whose true position is farther than this is another group's
FAR_M = 0.5

#: gap bins [s] of the wrong new decisions
GAP_BINS_S = (0.0, 2.0, 10.0, 30.0, np.inf)


def mahalanobis(poses, pose_cov, mean, cov, z, R) -> np.ndarray:
    """(P, K, C) squared Mahalanobis distances of the association's innovations."""
    valid = np.ones(mean.shape[:2], dtype=bool)
    return association_log_likelihood(poses, pose_cov, mean, cov, valid, z, R, RangeBearing2D())[1]


def diagnose(dataset: str, options: dict[str, str]) -> None:
    """Run, score and print one dataset (see the module docstring)."""
    options = dict(options)
    estimator_name = options.pop("estimator", "fastslam2")
    labelled, sequence, frames, options = hidden_ids(dataset, options)
    info = sequence_info(sequence, frames)
    truth_w = dict(
        zip(
            sequence.ground_truth.landmark_ids.tolist(),
            sequence.ground_truth.landmarks_w[:, :2],
            strict=True,
        )
    )
    filt = make_estimator(estimator_name, info, dict(options), np.random.default_rng(0))
    creator: dict[int, int] = {}  # slot -> hidden id of the sighting that created it
    last_seen: dict[int, float] = {}  # slot -> stamp of its last update by any particle
    decisions: collections.Counter = collections.Counter()
    wrong_new: list[tuple[float, float, float, float]] = []  # (d2, d2 with spread, gap s, std m)
    shadow = ResightingSpread(1.0)  # the spread since each slot's last sighting, scale 1
    current = {"frame": None}
    original_unknown = fs_association.SightingAssociation._unknown

    def recording(self, sightings, unknown, poses, pose_cov, weights):
        frame = current["frame"]
        given = labelled[frame.index]
        rows = [
            np.flatnonzero(
                (given.ranges_m == sightings.z[k, 0]) & (given.bearings_rad == sightings.z[k, 1])
            )[0]
            for k in unknown
        ]
        hidden = given.landmark_ids[rows]
        p = len(poses)
        center = np.average(poses[:, :2], axis=0, weights=weights)
        radius = float(sightings.z[unknown, 0].max()) + self._margin_m
        candidates = self._registry.near(center, radius)
        c = candidates.size
        pairs = original_unknown(self, sightings, unknown, poses, pose_cov, weights)
        slots = pairs.slot.reshape(p, unknown.size)
        new = pairs.new_unknown.reshape(p, unknown.size)
        for k in range(unknown.size):
            for s in np.unique(slots[new[:, k], k]):
                creator.setdefault(int(s), int(hidden[k]))
        if c:
            block = self._store.gather(
                np.repeat(np.arange(p), c), np.broadcast_to(candidates, (p, c)).ravel()
            )
            valid = (block.status == ESTIMATED).reshape(p, c)
            mean, cov = block.mean.reshape(p, c, 2), block.cov.reshape(p, c, 2, 2)
            z, R = sightings.z[unknown], sightings.R[unknown]
            d2 = mahalanobis(poses, pose_cov, mean, cov, z, R)
            gap_cov = shadow.world_frame(candidates, poses[:, 2])
            spread_cov = gap_cov if pose_cov is None else pose_cov[:, None] + gap_cov
            d2_spread = mahalanobis(poses, spread_cov, mean, cov, z, R)
            robot = shadow.robot_frame(candidates)
            std = np.sqrt(robot[:, 0, 0] + robot[:, 1, 1])
            names = np.array([creator.get(int(s), -2) for s in candidates])
        for i in range(p):
            for k in range(unknown.size):
                slot = int(slots[i, k])
                if not new[i, k]:
                    name = creator.get(slot)
                    if name == hidden[k]:
                        decisions["matched, same id"] += 1
                    elif np.linalg.norm(truth_w[name] - truth_w[hidden[k]]) > FAR_M:
                        decisions["matched, another group's id"] += 1
                    else:
                        decisions["matched, another id of the group"] += 1
                    continue
                own = np.flatnonzero((names == hidden[k]) & valid[i]) if c else []
                if len(own) == 0:
                    decisions["new, id not in the particle's map"] += 1
                    continue
                decisions["new, id already mapped (wrong new)"] += 1
                j = own[np.argmin(d2[i, k, own])]
                gap = frame.stamp_s - last_seen.get(int(candidates[j]), frame.stamp_s)
                wrong_new.append((d2[i, k, j], d2_spread[i, k, j], gap, std[j]))
        for s in np.unique(pairs.slot):
            last_seen[int(s)] = frame.stamp_s
        return pairs

    fs_association.SightingAssociation._unknown = recording
    try:
        motion = filt._motion
        print(
            f"{dataset}: running {estimator_name} without the ids ...", file=sys.stderr, flush=True
        )
        for frame in frames:
            current["frame"] = frame
            filt.step(frame)
            shadow.advance(frame.odometry.delta, motion.covariance(frame.odometry.delta))
            seen = [s for s, stamp in last_seen.items() if stamp == frame.stamp_s]
            shadow.seen(np.array(seen, dtype=np.int64))
        estimate = filt.estimate()
    finally:
        fs_association.SightingAssociation._unknown = original_unknown
    print(f"\n{dataset} {estimator_name} {options or ''}")
    print(f"  decisions (particle x sighting): {dict(decisions)}")
    if wrong_new:
        rows = np.array(wrong_new)
        print("  wrong new, against the particle's landmark of the true id, by gap since seen:")
        for lo, hi in itertools.pairwise(GAP_BINS_S):
            sel = (rows[:, 2] >= lo) & (rows[:, 2] < hi)
            if not sel.any():
                continue
            med = np.median(rows[sel], axis=0)
            print(
                f"    gap {lo:>4.0f}-{hi:<4.0f} s: {sel.sum():6d}  median d2 {med[0]:9.1f}  "
                f"with spread {med[1]:7.1f}  odometry std {med[3]:.2f} m"
            )
    ids = estimate.landmark_ids
    named = collections.Counter(creator.get(int(i - (1 << 32)), -2) for i in ids)
    print(
        f"  best particle's map: {len(ids)} landmarks for {len(named)} hidden ids; "
        f"per id {dict(sorted(named.items()))}"
    )


def main() -> None:
    diagnose_each(diagnose, __doc__.splitlines()[0])


if __name__ == "__main__":
    main()
