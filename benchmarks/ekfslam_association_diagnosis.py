"""Where EKF-SLAM's association of unlabelled range-bearing sightings goes wrong.

The EKF-SLAM analogue of ``association_diagnosis.py``: runs ``ekfslam`` on a dataset loaded
*with* its ids but told to ignore them (``association.ignore_ids``, the same decisions as
``omnislam run DATASET --estimator ekfslam --set association=unknown``) and scores every
decision against the hidden ids. A state landmark is named after the hidden id of the sighting
that created it (the tentative candidate's promoting sighting); a tentative candidate after its
first sighting.
Printed per dataset:

* the decisions of the joint test (paired / new / ambiguous / rejected) by sighting, the state
  updates that pair a sighting with a landmark created by another hidden id (*wrong pairings*)
  and their first frames, with the innovation widening of each (``innovation_widening``);
* the tentative stage: candidates started, re-observed by a foreign id, promoted, dropped stale;
* the wrong pairings with a landmark whose hidden id stands more than ``FAR_M`` from the
  sighting's own (another group: MR.CLAM's landmarks stand in groups 0.15-0.25 m apart), the ones
  that move the pose;
* the landmarks in the state per hidden id (duplicates);
* where the filtered path parts from the same filter's with ids: the largest position [m] and
  heading [deg] difference per stretch of frames, to place the wrong pairings in time.

The estimator runs with its defaults; ``--set key=value`` overrides them (both runs)::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python \
        benchmarks/ekfslam_association_diagnosis.py [mrclam6-r1 ...] [--set key=value ...]
"""

from __future__ import annotations

import collections
import sys

import numpy as np
from association_diagnosis import diagnose_each

from omnislam.core.compatibility import Decision
from omnislam.core.types import FrameInput, RangeBearing
from omnislam.datasets.registry import load_dataset, resolve
from omnislam.ekfslam import filter as ekf_filter
from omnislam.ekfslam.association import TentativeLandmarks
from omnislam.ekfslam.config import AssociationConfig, EKFSLAMConfig
from omnislam.ekfslam.filter import EKFSLAM
from omnislam.options import apply_options

#: a wrong pairing with a landmark whose true position is farther than this is another group's
FAR_M = 0.5


def true_id(sightings: RangeBearing, ids: np.ndarray, z: np.ndarray) -> int:
    """The hidden id of the sighting (range, bearing) ``z`` of a frame."""
    row = np.flatnonzero((sightings.ranges_m == z[0]) & (sightings.bearings_rad == z[1]))
    return int(ids[row[0]])


class TruthTentative(TentativeLandmarks):
    """Tentative landmarks that carry the hidden id of each sighting they hold."""

    def __init__(self, lookup: dict[bytes, int], log: collections.Counter) -> None:
        super().__init__()
        self.truth: list[int] = []
        self._lookup, self._log = lookup, log

    def add(self, point_w: np.ndarray, cov: np.ndarray, odometer_m: float) -> int:
        self.truth.append(self._lookup[np.asarray(point_w, float).tobytes()])
        self._log["started"] += 1
        return super().add(point_w, cov, odometer_m)

    def observe(self, index: int, point_w: np.ndarray, cov: np.ndarray, odometer_m: float) -> int:
        given = self._lookup[np.asarray(point_w, float).tobytes()]
        self._log[
            "re-observed, same id" if given == self.truth[index] else "re-observed, foreign id"
        ] += 1
        return super().observe(index, point_w, cov, odometer_m)

    def remove(self, indices: list[int]) -> None:
        drop = set(indices)
        self.truth = [t for i, t in enumerate(self.truth) if i not in drop]
        super().remove(indices)

    def drop_stale(self, odometer_m: float, window_m: float) -> int:
        seen = zip(self.truth, self.last_seen_m, strict=True)
        stale = [t for t, last in seen if odometer_m - last > window_m]
        for t in stale:
            self._log[f"dropped stale (id {t})"] += 1
        return super().drop_stale(odometer_m, window_m)


class Recording(EKFSLAM):
    """EKF-SLAM that records its decisions against the hidden ids of each frame."""

    def __init__(self, config: EKFSLAMConfig, truth: dict[int, RangeBearing]) -> None:
        super().__init__(config)
        self.truth = truth
        self.lookup: dict[bytes, int] = {}
        self.tentative_log: collections.Counter = collections.Counter()
        self._tentative = TruthTentative(self.lookup, self.tentative_log)
        self.creator: list[int] = []  # hidden id that created each slot
        self.updates: list[tuple[int, int, int, float]] = []  # (frame, id, slot, widening)
        self.decisions: collections.Counter = collections.Counter()
        self.ambiguous_ids: collections.Counter = collections.Counter()
        self._frame: FrameInput | None = None
        self._last: list = []
        self._rows: list[int] = []
        self.frame_test: list = []  # the last joint test: [pairings, JCBB result, decisions]
        original = ekf_filter.decide_on_kept_support

        def keep(*args, **kwargs):
            result = original(*args, **kwargs)
            self._last = [args[0], *result]
            return result

        ekf_filter.decide_on_kept_support = keep
        self._restore = lambda: setattr(ekf_filter, "decide_on_kept_support", original)

    def _id(self, z: np.ndarray) -> int:
        assert self._frame is not None
        return true_id(self.truth[self._frame.index], self.truth[self._frame.index].landmark_ids, z)

    def step(self, frame: FrameInput) -> None:
        self._frame = frame
        super().step(frame)

    def _joint_step(
        self, rows: list[int], z_all: np.ndarray, R_all: np.ndarray, used: set[int]
    ) -> list[int]:
        self._last, self._rows = [], list(rows)
        out = super()._joint_step(rows, z_all, R_all, used)
        if self._last:
            for i, row in enumerate(rows):
                name = Decision(int(self._last[2][i])).name
                self.decisions[name] += 1
                if name == "AMBIGUOUS":
                    self.ambiguous_ids[self._id(z_all[row])] += 1
        self.frame_test, self._last, self._rows = self._last, [], []
        return out

    def _widening_of(self, row: int) -> float:
        """The innovation widening of the joint test's pairing of ``row`` (0 without one)."""
        if not self._last or row not in self._rows:
            return 0.0
        pairings, result, _ = self._last
        i = self._rows.index(row)
        return ekf_filter.innovation_widening(pairings, i, int(result.assignment[i]))

    def _observe(self, sightings: RangeBearing) -> None:
        state = self.state
        original = state.update
        frame = self._frame.index

        def update(slot, z, R, model=None, gate=np.inf):
            out = original(slot, z, R, model, gate)
            if out is not None:
                row = np.flatnonzero(
                    (sightings.ranges_m == z[0]) & (sightings.bearings_rad == z[1])
                )[0]
                self.updates.append((frame, self._id(z), slot, self._widening_of(int(row))))
            return out

        state.update = update
        try:
            super()._observe(sightings)
        finally:
            del state.update

    def _tentative_step(self, rows: list[int], z_all: np.ndarray, R_all: np.ndarray) -> None:
        pose = self.state.pose
        for row in rows:
            point, _, _ = self.model.inverse(pose, z_all[row])
            self.lookup[np.asarray(point, float).tobytes()] = self._id(z_all[row])
        super()._tentative_step(rows, z_all, R_all)
        self.lookup.clear()

    def _add_landmark(self, z: np.ndarray, R: np.ndarray, landmark_id: int | None) -> None:
        self.creator.append(self._id(z))
        super()._add_landmark(z, R, landmark_id)


def divergence(with_ids: EKFSLAM, without: EKFSLAM, parts: int = 24) -> str:
    """ "frame:metres/degrees" of the largest difference of the two filtered paths per stretch."""
    a, b = np.asarray(without._poses), np.asarray(with_ids._poses)
    dxy = np.linalg.norm(a[:, :2] - b[:, :2], axis=1)
    dth = np.degrees(np.abs(np.angle(np.exp(1j * (a[:, 2] - b[:, 2])))))
    step = max(1, len(a) // parts)
    return " ".join(
        f"{i}:{dxy[i : i + step].max():.2f}/{dth[i : i + step].max():.0f}"
        for i in range(0, len(a), step)
    )


def diagnose(dataset: str, options: dict[str, str]) -> None:
    """Run, score and print one dataset (see the module docstring)."""
    resolved = resolve(dataset)
    sequence = load_dataset(resolved, {})
    frames = list(sequence.frame_inputs())
    truth = {f.index: f.range_bearing for f in frames if f.range_bearing is not None}
    with_ids = EKFSLAM(apply_options(EKFSLAMConfig(), options))
    print(f"{dataset}: running ekfslam with the ids, then without ...", file=sys.stderr, flush=True)
    for frame in frames:
        with_ids.step(frame)
    ignoring = EKFSLAMConfig(association=AssociationConfig(ignore_ids=True))
    estimator = Recording(apply_options(ignoring, options), truth)
    try:
        for frame in frames:
            estimator.step(frame)
    finally:
        estimator._restore()
    creator = estimator.creator
    truth_w = dict(
        zip(
            sequence.ground_truth.landmark_ids.tolist(),
            sequence.ground_truth.landmarks_w[:, :2],
            strict=True,
        )
    )
    wrong = [(k, t, slot, w) for k, t, slot, w in estimator.updates if creator[slot] != t]
    far = [
        (k, t, slot, w)
        for k, t, slot, w in wrong
        if np.linalg.norm(truth_w[t] - truth_w[creator[slot]]) > FAR_M
    ]
    print(f"\n{dataset} {options or ''}")
    print(f"  joint-test decisions: {dict(estimator.decisions)}")
    print(f"  ambiguous drops by hidden id: {dict(sorted(estimator.ambiguous_ids.items()))}")

    def listed(rows: list) -> str:
        return ", ".join(f"f{k} id {t}->{creator[slot]} (w {w:.0f})" for k, t, slot, w in rows[:12])

    print(
        f"  state updates {len(estimator.updates)}; pairings with a landmark another id created "
        f"{len(wrong)}, the first: {listed(wrong)}"
    )
    print(f"  of them with another group's (> {FAR_M} m) {len(far)}, the first: {listed(far)}")
    print(f"  tentative: {dict(estimator.tentative_log)}")
    mapped = collections.Counter(creator)
    print(
        f"  landmarks {len(creator)} for {len(mapped)} hidden ids; duplicated: "
        f"{ {t: n for t, n in sorted(mapped.items()) if n > 1} }"
    )
    print(f"  parting from the path with ids (frame:m/deg): {divergence(with_ids, estimator)}")


def main() -> None:
    diagnose_each(diagnose, __doc__.splitlines()[0])


if __name__ == "__main__":
    main()
