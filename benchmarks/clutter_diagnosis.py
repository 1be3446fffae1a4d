"""What graphslam's association does with false detections, scored against the hidden ids.

Two diagnoses of the clutter target (``benchmarks/clutter.py`` measures the target itself):

``decisions DATASET`` runs ``graphslam`` on a dataset with ids (MR.CLAM) with the ids hidden
(``association=unknown``) and ``--rate`` false detections per frame added exactly as
``omnislam run DATASET --estimator graphslam --set association=unknown --set
clutter_per_frame=RATE --seed SEED`` adds them (``harness.perturb.add_clutter`` with the
harness's random stream). Every association decision is scored: a sighting is *real* when it
is one of the dataset's own (found by frame, range and bearing in the dataset loaded with ids),
else *clutter*; a landmark is *clutter-started* or *real-started* after the sighting that
started it. Printed: the decisions of real and clutter sightings by the kind of landmark they
were given to, the first frames where a real sighting went to a clutter-started landmark, and
the map's landmarks by what started them. ``--trace LO HI`` prints, for frames LO..HI, each
frame's decisions (``id->DECISION:landmark(started by)``, -9 for clutter) beside the online
estimate's position and heading error against the ground truth, both expressed relative to the
first frame (start-aligned).

``in-view DATASET`` runs ``omnislam run DATASET --estimator graphslam`` (any data with
range-bearing sightings decided by the association: MR.CLAM with ``--set association=unknown``,
CARMEN's laser landmarks; ``--set clutter_per_frame=R`` as the harness takes it) and prints,
for the landmarks of the final map, the sightings per frame *in view*: frames whose sensor
reported and from whose final pose estimate the landmark lies inside the span of the data's own
sightings (1st-99th percentile of range and bearing). A landmark seen in few of the frames it
was in view of is what an existence test (thesis sec. 5.1.2) would drop::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/clutter_diagnosis.py \\
        decisions mrclam6-r3 [--rate 0.5] [--seed 0] [--trace 200 230] [--set KEY=VALUE ...]
    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/clutter_diagnosis.py \\
        in-view carmen-aces [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import collections
import sys

import numpy as np
from association_diagnosis import hidden_ids, landmarks_decided
from harness_cells import set_options

from omnislam.core.compatibility import Decision
from omnislam.core.se import se2_between
from omnislam.datasets.registry import resolve
from omnislam.estimators import make_estimator
from omnislam.graphslam import isam, range_bearing
from omnislam.harness.execute import RunSpec, execute_run
from omnislam.harness.frames import sequence_info
from omnislam.harness.perturb import add_clutter, clutter_stream
from omnislam.harness.reference import reference_for

#: the label of a false detection (no dataset id is negative)
CLUTTER = -9


def decisions(dataset: str, rate: float, seed: int, trace: tuple[int, int] | None, options):
    """Run, score and print the ``decisions`` diagnosis (module docstring)."""
    labelled, sequence, frames, estimator_options = hidden_ids(dataset, options)
    info = sequence_info(sequence, frames)  # told before the clutter, as the harness does
    frames, added = add_clutter(frames, rate, clutter_stream(seed))

    def label(k: int, r: float, b: float) -> int:
        given = labelled[k]
        row = np.flatnonzero((given.ranges_m == r) & (given.bearings_rad == b))
        return int(given.landmark_ids[row[0]]) if len(row) else CLUTTER

    decided: list[tuple[int, int, int, str]] = []  # frame, label, landmark or -1, decision
    started_by: dict[int, int] = {}
    original = range_bearing.RangeBearingGraph._add_decided

    def recording(self, decision, k_now, guess_w, graph, values):
        next_id = self._next_created_id
        original(self, decision, k_now, guess_w, graph, values)
        rb = decision.sightings
        for i, (d, lid) in enumerate(
            zip(decision.decisions.tolist(), landmarks_decided(decision, next_id), strict=True)
        ):
            t = label(decision.k, rb.ranges_m[i], rb.bearings_rad[i])
            if d == Decision.NEW:
                started_by[lid] = t
            decided.append((decision.k, t, lid, Decision(d).name))

    truth = None
    if trace is not None:
        resolved = resolve(dataset)
        ground_truth, _ = reference_for(resolved.format, resolved.path, sequence)
        truth = ground_truth.trajectory
        truth_se2 = np.array(truth.se2, dtype=float)
        truth_se2[:, 2] = np.unwrap(truth_se2[:, 2])  # interpolated without a jump at +-pi
    print(
        f"{dataset}: running graphslam without the ids, {added} false detections added ...",
        file=sys.stderr,
        flush=True,
    )
    range_bearing.RangeBearingGraph._add_decided = recording
    try:
        estimator = make_estimator(
            "graphslam", info, estimator_options, np.random.default_rng(seed)
        )
        start = None
        for frame in frames:
            before = len(decided)
            estimator.step(frame)
            if trace is None or not trace[0] <= frame.index <= trace[1]:
                continue
            pose = estimator.newest_pose()
            true = np.array(
                [np.interp(frame.stamp_s, truth.stamps_s, truth_se2[:, j]) for j in range(3)]
            )
            if start is None:
                start = (pose, true)
            moved, true_moved = se2_between(start[0], pose), se2_between(start[1], true)
            error = float(np.hypot(*(moved[:2] - true_moved[:2])))
            heading = float(np.degrees(np.angle(np.exp(1j * (moved[2] - true_moved[2])))))
            shown = " ".join(
                f"{t}->{d[:3]}:{lid - range_bearing.CREATED_ID_BASE if lid >= 0 else ''}"
                f"({started_by.get(lid, '')})"
                for _, t, lid, d in decided[before:]
            )
            print(f"  frame {frame.index:5d}  {error:6.3f} m {heading:7.2f} deg  {shown}")
        estimator.estimate()
    finally:
        range_bearing.RangeBearingGraph._add_decided = original

    counts: collections.Counter = collections.Counter()
    to_clutter_frames = []
    for k, t, lid, d in decided:
        kind = "clutter" if t == CLUTTER else "real"
        if d == Decision.PAIRED.name:
            if started_by.get(lid) == CLUTTER:
                target = "a clutter-started landmark"
                if kind == "real":
                    to_clutter_frames.append(k)
            elif started_by.get(lid) == t:
                target = "the landmark its own id started"
            else:
                target = "a landmark another id started"
            counts[(kind, f"paired with {target}")] += 1
        else:
            counts[(kind, d.lower())] += 1
    print(f"\n{dataset}: {added} false detections added (rate {rate:g}, seed {seed})")
    for (kind, what), n in sorted(counts.items()):
        print(f"  {kind} sightings {what}: {n}")
    print(
        "  first frames a real sighting went to a clutter-started landmark: "
        f"{to_clutter_frames[:8]}"
    )
    graph = estimator._graph
    mapped = [lid for lid in started_by if graph._registry.active(lid) and lid in graph._in_graph]
    by_clutter = sum(started_by[lid] == CLUTTER for lid in mapped)
    print(f"  landmarks in the map: {len(mapped)}, {by_clutter} of them clutter-started")


def in_view(dataset: str, seed: int, options) -> None:
    """Run and print the ``in-view`` diagnosis (module docstring)."""
    seen: dict[int, int] = collections.Counter()
    sensed: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    original_decided = range_bearing.RangeBearingGraph._add_decided
    original_step = isam.GraphSLAM.step

    def recording(self, decision, k_now, guess_w, graph, values):
        next_id = self._next_created_id
        original_decided(self, decision, k_now, guess_w, graph, values)
        for lid in landmarks_decided(decision, next_id):
            if lid >= 0:
                seen[lid] += 1

    def stepping(self, frame):
        rb = frame.range_bearing
        if rb is not None:
            sensed[frame.index] = (np.asarray(rb.ranges_m), np.asarray(rb.bearings_rad))
        return original_step(self, frame)

    range_bearing.RangeBearingGraph._add_decided = recording
    isam.GraphSLAM.step = stepping
    shown = " ".join(f"{k}={v}" for k, v in options.items())
    print(f"{dataset}: running graphslam {shown} ...", file=sys.stderr, flush=True)
    try:
        record = execute_run(RunSpec(dataset, "graphslam", seed, dict(options)))
    finally:
        range_bearing.RangeBearingGraph._add_decided = original_decided
        isam.GraphSLAM.step = original_step
    estimate = record.estimate
    ranges = np.concatenate([r for r, _ in sensed.values()])
    bearings = np.concatenate([b for _, b in sensed.values()])
    r_low, r_high = np.percentile(ranges, [1, 99])
    b_low, b_high = np.percentile(bearings, [1, 99])
    poses = np.asarray(estimate.trajectory.se2)[np.array(sorted(sensed))]
    rows = []
    for lid, point in zip(estimate.landmark_ids.tolist(), estimate.landmarks_w[:, :2], strict=True):
        d = point - poses[:, :2]
        r = np.hypot(d[:, 0], d[:, 1])
        b = np.angle(np.exp(1j * (np.arctan2(d[:, 1], d[:, 0]) - poses[:, 2])))
        frames = int(np.sum((r >= r_low) & (r <= r_high) & (b >= b_low) & (b <= b_high)))
        rows.append((seen[lid] / max(frames, 1), seen[lid], frames))
    rows.sort()
    ratios = np.array([row[0] for row in rows])
    print(
        f"{dataset} {options or ''}: {len(rows)} landmarks; span {r_low:.2f}-{r_high:.2f} m, "
        f"{b_low:.2f}..{b_high:.2f} rad"
    )
    quantiles = np.percentile(ratios, [0, 10, 25, 50, 75, 90, 100])
    print(
        "  sightings per frame in view, quantiles 0/10/25/50/75/90/100 %: "
        + " ".join(f"{q:.3f}" for q in quantiles)
    )
    sightings = np.percentile([row[1] for row in rows], [0, 25, 50, 75, 100])
    print(
        "  sightings per landmark, quantiles 0/25/50/75/100 %: "
        + " ".join(f"{q:g}" for q in sightings)
    )
    print(
        "  the ten least seen (ratio, sightings, frames in view): "
        + ", ".join(f"({a:.3f}, {n}, {v})" for a, n, v in rows[:10])
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("diagnosis", choices=["decisions", "in-view"])
    parser.add_argument("dataset")
    parser.add_argument("--rate", type=float, default=0.5, help="false detections per frame")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--trace", type=int, nargs=2, metavar=("LO", "HI"))
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    options = set_options(parser, args.set)
    if args.diagnosis == "decisions":
        decisions(args.dataset, args.rate, args.seed, args.trace, options)
    else:
        in_view(args.dataset, args.seed, options)


if __name__ == "__main__":
    main()
