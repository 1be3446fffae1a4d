"""Why FastSLAM does not close loops on ``campus1500``: each re-sighting against the gate.

A pole that comes back into the sensor's view after at least one frame out of it (a new
*visibility episode*, counted from the sightings' true ids) is a chance to re-associate: the
particle should match the sighting to the landmark it made of that pole before. This runs one
FastSLAM configuration on the route's pole sightings (unknown association, as
``benchmarks/fastslam_campus.py``) and, at the first frame of every episode of a pole the filter
has already mapped, measures in every particle, before the association:

* the distance between where the particle's pose puts the sighting (pose + range/bearing) and
  its own estimate of that pole (the landmarks created from sightings of that pole, nearest
  one), and
* that landmark's log-likelihood for the sighting (the association's, ``association.py``:
  landmark, sighting and, for FastSLAM 2.0, predicted-pose covariance) against the
  new-landmark threshold ``association.new_landmark_log_likelihood``: below it the particle
  starts a new landmark instead.

Re-sightings are grouped by the pole's episode (2: the first return to it); the table gives per
group the distance driven (true path) since the pole was last in view, the particles' median
and 90th-percentile distance, the share of (re-sighting, particle) pairs whose old landmark
passes the gate, and the set's spread (median distance of a particle's placement of the
sighting from the set's mean placement): how far apart the hypotheses are. It also counts how
often a sighting of a pole that was in view the frame before starts a new landmark (tracking
lost within an episode)::

    .venv/bin/python benchmarks/fastslam_campus_resighting.py [--data runs/campus1500]
        [--estimator fastslam2] [--particles 50] [--seed 0] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
from harness_cells import set_options

from omnislam.core.batch_linalg import inverse_and_logdet, transpose
from omnislam.core.gaussian import gaussian_log_likelihood
from omnislam.core.measurement import RangeBearing2D
from omnislam.datasets.registry import load_dataset, resolve
from omnislam.errors import OmnislamError
from omnislam.estimators import make_estimator
from omnislam.fastslam.landmark_store import ESTIMATED
from omnislam.harness.frames import sequence_info


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default="runs/campus1500")
    parser.add_argument("--estimator", default="fastslam2", choices=("fastslam1", "fastslam2"))
    parser.add_argument("--particles", type=int, default=50)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    options = {"particles.n_particles": str(args.particles), "modality": "range-bearing-2d"}
    options |= set_options(parser, args.set)
    try:
        resolved = resolve(str(Path(args.data).resolve()))
        truth = load_dataset(resolved, {"association": "known"})
        sequence = load_dataset(resolved, {"association": "unknown"})
    except OmnislamError as error:
        parser.exit(2, f"{parser.prog}: {error}\n")
    frames = list(sequence.frame_inputs())
    rng = np.random.default_rng(args.seed)
    estimator = make_estimator(args.estimator, sequence_info(sequence, frames), options, rng)
    probe = _Probe(estimator, truth)
    print(
        f"{args.data}: running {args.estimator} with {args.particles} particles ...",
        file=sys.stderr,
        flush=True,
    )
    for frame in frames:
        probe.frame = frame.index
        estimator.step(frame)
    landmarks = len(estimator.estimate().landmark_ids)
    print(f"{args.estimator}/{args.particles}, seed {args.seed}: {landmarks} landmarks at the end")
    _report(probe, estimator.config.association.new_landmark_log_likelihood)


class _Probe:
    """Wraps the filter's association: measures re-sightings, remembers which pole made a slot."""

    def __init__(self, estimator: object, truth: object) -> None:
        self._association = estimator._association  # a diagnostic: the filter's own
        self._store = estimator.store
        self._pairs = self._association.pairs
        self._association.pairs = self._measured_pairs
        self._ids = truth.range_bearing
        xy = truth.ground_truth.trajectory.positions_w[:, :2]  # one true pose per frame
        path = np.linalg.norm(np.diff(xy, axis=0), axis=1)
        self._driven = np.concatenate([[0.0], np.cumsum(path)])
        self._model = RangeBearing2D()
        self._slots: dict[int, list[int]] = defaultdict(list)  # pole -> slots made from it
        self._last_seen: dict[int, int] = {}  # pole -> last frame it was in view
        self._episodes: dict[int, int] = defaultdict(int)  # pole -> its episodes so far
        self.frame = 0
        #: per re-sighting: (episode, driven [m], distances (P,), log-likelihoods (P,), spread (P,))
        self.rows: list[tuple[int, float, np.ndarray, np.ndarray, np.ndarray]] = []
        #: (particle decisions, new landmarks) for sightings of a pole also seen the frame before
        self.tracking = np.zeros(2, dtype=np.int64)

    def _measured_pairs(self, sightings, poses, pose_cov, weights):
        ids = self._ids[self.frame].landmark_ids
        for k, pole in enumerate(ids.tolist()):
            last = self._last_seen.get(pole)
            if last is not None and last == self.frame - 1:
                continue
            self._episodes[pole] += 1
            if last is not None and self._slots[pole]:
                gap = float(self._driven[self.frame] - self._driven[last])
                measured = self._against_old(poses, pose_cov, sightings, k, pole)
                self.rows.append((self._episodes[pole], gap, *measured))
        pairs = self._pairs(sightings, poses, pose_cov, weights)
        tracked = np.array([self._last_seen.get(j) == self.frame - 1 for j in ids.tolist()])
        if tracked.any():
            chosen = tracked[pairs.obs]
            self.tracking += (int(chosen.sum()), int(pairs.new_unknown[chosen].sum()))
        for slot in np.unique(pairs.slot[pairs.new_unknown]).tolist():
            k = int(pairs.obs[pairs.new_unknown][pairs.slot[pairs.new_unknown] == slot][0])
            self._slots[int(ids[k])].append(slot)
        for pole in ids.tolist():
            self._last_seen[pole] = self.frame
        return pairs

    def _against_old(self, poses, pose_cov, sightings, k, pole):
        """Per particle: distance [m] and log-likelihood of its best landmark made from
        ``pole``, and how far the particle puts the sighting from the set's mean placement [m]."""
        p, slots = len(poses), np.array(self._slots[pole])
        c = slots.size
        block = self._store.gather(np.repeat(np.arange(p), c), np.tile(slots, p))
        mean = block.mean.reshape(p, c, 2)
        cov = block.cov.reshape(p, c, 2, 2)
        valid = (block.status == ESTIMATED).reshape(p, c)
        z_hat, H_x, H_m = self._model.predict(poses[:, None, :], mean)
        S = H_m @ cov @ transpose(H_m) + sightings.R[k]
        if pose_cov is not None:
            S = S + H_x @ pose_cov[:, None] @ transpose(H_x)
        y = self._model.residual(sightings.z[k][None, None, :], z_hat)
        S_inv, logdet = inverse_and_logdet(S)
        ll = np.where(valid, gaussian_log_likelihood(y, S_inv, logdet), -np.inf)
        r, b = sightings.z[k]
        heading = poses[:, 2] + b
        placed = poses[:, :2] + r * np.stack([np.cos(heading), np.sin(heading)], axis=-1)
        distance = np.where(valid, np.linalg.norm(mean - placed[:, None], axis=-1), np.inf)
        best = np.argmax(ll, axis=1)
        rows = np.arange(p)
        spread = np.linalg.norm(placed - placed.mean(axis=0), axis=1)
        return distance.min(axis=1), ll[rows, best], spread


def _report(probe: _Probe, log_p0: float) -> None:
    decisions, new = probe.tracking.tolist()
    print(
        f"sightings of a pole in view the frame before: {new} of {decisions} particle "
        f"decisions ({new / max(decisions, 1):.2%}) start a new landmark"
    )
    print(f"{len(probe.rows)} re-sightings of mapped poles; gate: log-likelihood >= {log_p0:g}")
    print(
        f"{'episode':>7s} {'n':>4s} {'driven since [m]':>16s} {'median distance [m]':>19s} "
        f"{'p90 distance [m]':>16s} {'passing the gate':>16s} {'set spread [m]':>14s}"
    )
    for episode in sorted({row[0] for row in probe.rows}):
        sel = [row for row in probe.rows if row[0] == episode]
        distance = np.concatenate([row[2] for row in sel])
        passing = np.concatenate([row[3] >= log_p0 for row in sel])
        print(
            f"{episode:7d} {len(sel):4d} {np.median([row[1] for row in sel]):16.1f} "
            f"{np.median(distance):19.3f} {np.percentile(distance, 90):16.3f} "
            f"{passing.mean():16.1%} {np.median(np.concatenate([row[4] for row in sel])):14.3f}"
        )


if __name__ == "__main__":
    main()
