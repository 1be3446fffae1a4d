"""Which of graphslam's unlabelled pairings are wrong, on data with true poses but no landmark ids.

``association_diagnosis.py`` scores the association against hidden landmark ids (MR.CLAM). The
CARMEN logs have no ids, only the corrected poses (pseudo ground truth); this script scores
against those instead. It runs ``graphslam`` through the harness, as

    omnislam run DATASET --estimator graphslam --seed 0 [--set key=value ...]

does (the shared front end's laser landmarks, cached under ``OMNISLAM_CACHE``), records every
association decision (a hook on ``RangeBearingGraph._add_decided`` and on the window
association's JCBB, in this process only), then places every sighting in the world with the
*true* pose of its frame. A landmark's sightings should then fall on one point (within the
sightings' noise and the pseudo ground truth's own error); a pairing whose placed sighting lies
more than ``--threshold-m`` from the placed sighting that started the landmark is *off*: named
after that first sighting (as ``association_diagnosis.py`` names a landmark after the hidden
id that started it), the landmark took a sighting of another feature. Printed per dataset:

* ATE RMSE (SE(2)-aligned), the decisions, and the off pairings -- frame, landmark (numbered
  from the first created), distance, the frame the landmark was started in, its sightings, the
  pairings of the frame's joint hypothesis, the pairing's squared Mahalanobis distance on its
  own (the individual gate's statistic), and its innovation widening (the largest
  std of S against the sighting noise R, ``core.compatibility.innovation_widening``: a pairing
  with a landmark the robot is no longer tied to has a wide S, its gate holds any feature within
  metres);
* the RMS of the ATE errors over stretches of ``--stretch`` frames (where the run goes wrong).

::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/association_placement.py
        [carmen-intel carmen-aces] [--set key=value ...] [--threshold-m 0.75] [--stretch 75]
"""

from __future__ import annotations

import argparse
import collections
import sys

import numpy as np
from association_diagnosis import landmarks_decided
from harness_cells import set_options

from omnislam.core.compatibility import Decision, innovation_widening
from omnislam.graphslam import range_bearing
from omnislam.graphslam import window_association as wa
from omnislam.harness.execute import RunSpec, execute_run
from omnislam.metrics.trajectory import associate, ate


class _Recorder:
    """The hooks: every decided sighting, and the widening of every JCBB pairing."""

    def __init__(self) -> None:
        # (frame, range, bearing, landmark or -1, decision name)
        self.decided: list[tuple[int, float, float, int, str]] = []
        # (frame, row) -> (widening, pairings in the frame's hypothesis, squared Mahalanobis
        # distance of the pairing on its own)
        self.widening: dict[tuple[int, int], tuple[float, int, float]] = {}
        self._pairings = None
        self._result = None

    def install(self) -> None:
        add_decided = range_bearing.RangeBearingGraph._add_decided
        decide_oldest = wa.WindowAssociation._decide_oldest
        jcbb = wa.jcbb
        recorder = self

        def recording_jcbb(pairings, probability):
            result = jcbb(pairings, probability)
            recorder._pairings, recorder._result = pairings, result
            return result

        def recording_decide_oldest(self, newest):
            recorder._pairings = recorder._result = None
            decided = decide_oldest(self, newest)
            pairings, result = recorder._pairings, recorder._result
            if pairings is not None:
                paired = decided.decisions == Decision.PAIRED
                for i in np.flatnonzero(paired):
                    a = int(result.assignment[i])
                    width = innovation_widening(pairings, int(i), a)
                    nu, H = pairings.innovations[i, a], pairings.jacobians[i, a]
                    S = H @ pairings.covariance @ H.T + pairings.noise[i]
                    d2 = float(nu @ np.linalg.solve(S, nu))
                    recorder.widening[(decided.k, int(i))] = (width, int(paired.sum()), d2)
            return decided

        def recording_add_decided(self, decision, k_now, guess_w, graph, values):
            next_id = self._next_created_id
            add_decided(self, decision, k_now, guess_w, graph, values)
            landmarks = landmarks_decided(decision, next_id)
            for i, (d, lid) in enumerate(zip(decision.decisions.tolist(), landmarks, strict=True)):
                recorder.decided.append(
                    (
                        decision.k,
                        float(decision.sightings.ranges_m[i]),
                        float(decision.sightings.bearings_rad[i]),
                        lid,
                        Decision(d).name,
                    )
                )

        self._originals = (add_decided, decide_oldest, jcbb)
        wa.jcbb = recording_jcbb
        wa.WindowAssociation._decide_oldest = recording_decide_oldest
        range_bearing.RangeBearingGraph._add_decided = recording_add_decided

    def remove(self) -> None:
        add_decided, decide_oldest, jcbb = self._originals
        range_bearing.RangeBearingGraph._add_decided = add_decided
        wa.WindowAssociation._decide_oldest = decide_oldest
        wa.jcbb = jcbb


def diagnose(dataset: str, options: dict[str, str], threshold_m: float, stretch: int) -> None:
    """Run, score and print one dataset (see the module docstring)."""
    shown = " ".join(f"{k}={v}" for k, v in options.items())
    print(f"{dataset}: running graphslam {shown} ...", file=sys.stderr, flush=True)
    recorder = _Recorder()
    recorder.install()
    try:
        record = execute_run(RunSpec(dataset, "graphslam", 0, dict(options)))
    finally:
        recorder.remove()
    truth = record.ground_truth.trajectory
    estimate = record.estimate.trajectory
    if truth is None:
        raise SystemExit(f"{dataset}: no ground-truth poses to place the sightings with")
    i_est, i_gt = associate(estimate.stamps_s, truth.stamps_s)
    true_pose = dict(zip(i_est.tolist(), truth.se2[i_gt], strict=True))
    placed: dict[int, list[tuple[int, int, np.ndarray]]] = collections.defaultdict(list)
    row_in_frame: collections.Counter = collections.Counter()
    for k, r, b, lid, _ in recorder.decided:
        row = row_in_frame[k]
        row_in_frame[k] += 1
        pose = true_pose.get(k)
        if lid < 0 or pose is None:
            continue
        point = pose[:2] + r * np.array([np.cos(pose[2] + b), np.sin(pose[2] + b)])
        placed[lid].append((k, row, point))
    base = range_bearing.CREATED_ID_BASE
    off = []
    for lid, sightings in placed.items():
        start = sightings[0][2]
        for k, row, point in sightings[1:]:  # the first one started the landmark
            distance = float(np.linalg.norm(point - start))
            if distance > threshold_m:
                width, paired, d2 = recorder.widening.get((k, row), (float("nan"), 0, float("nan")))
                first, n = sightings[0][0], len(sightings)
                off.append((k, row, distance, first, n, paired, width, d2, lid - base))
    result = ate(estimate, truth)
    counts = collections.Counter(d for *_, d in recorder.decided)
    shown = " ".join(f"{k}={v}" for k, v in options.items())
    print(f"\n{dataset} {shown}".rstrip())
    print(f"  ATE {result.rmse_m:.3f} m; decisions {dict(counts)}; landmarks {len(placed)}")
    print(
        f"  off pairings (placed > {threshold_m} m from the landmark's first sighting): {len(off)}"
    )
    off_rows = {(k, row) for k, row, *_ in off}
    lone_wide = [key for key, (w, paired, _) in recorder.widening.items() if paired == 1 and w > 5]
    print(
        f"  lone pairings (one in the frame's hypothesis) with widening > 5: {len(lone_wide)}, "
        f"off: {sum(key in off_rows for key in lone_wide)}"
    )
    for k, _, distance, first, n, paired, width, d2, lid in sorted(off):
        print(
            f"    frame {k}: landmark {lid} (started at frame {first}, {n} sightings) "
            f"{distance:.2f} m off; {paired} pairing(s) in the frame, widening {width:.1f}, "
            f"d2 {d2:.1f}"
        )
    errors = result.errors_m
    unit = "frames" if result.matched == len(estimate) else "poses with ground truth"
    print(f"  ATE RMS per {stretch} {unit}:")
    for start in range(0, len(errors), stretch):
        chunk = errors[start : start + stretch]
        print(f"    {start}-{start + len(chunk) - 1}: {np.sqrt(np.mean(chunk**2)):.3f} m")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("datasets", nargs="*", default=["carmen-intel", "carmen-aces"])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--threshold-m", type=float, default=0.75)
    parser.add_argument("--stretch", type=int, default=75)
    args = parser.parse_args()
    options = set_options(parser, args.set)
    for dataset in args.datasets:
        diagnose(dataset, options, args.threshold_m, args.stretch)


if __name__ == "__main__":
    main()
