"""What the graph's association of unlabelled sightings is worth under another noise model.

Separates the two things a run without ids decides: *which landmark each sighting is* (the
association) and *where everything is* (the estimate). Two passes on one dataset that has ids:

1. **associate**: ``graphslam`` with the ids hidden (``association=unknown``), under the
   loader and estimator options of ``--assoc-set`` (for instance a restated sighting or
   odometry noise); every decision is recorded (the hook of ``association_diagnosis.py``);
2. **solve**: the dataset loaded *with* its own noise and the options of ``--final-set``, each
   sighting labelled with the landmark pass 1 gave it (merges of the loop closure followed;
   sightings it dropped as ambiguous or rejected left out), solved by ``--final`` (default
   ``graphslam-batch``) -- next to the same estimator on the dataset's true ids.

Printed: each pass's ATE (SE(2)-aligned, against the ground truth ``omnislam run`` scores
against: the LM optimum of the file for ``victoria-park-gtsam``, Vicon for MR.CLAM) and its
landmarks. When pass 2 lands on the with-ids solution, the association was right and only the
noise model of pass 1's estimate kept the run from the goal::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/association_two_models.py
        victoria-park-gtsam --assoc-set preset=victoria-park-gtsam --assoc-set sigma_range_m=0.25
        --assoc-set sigma_bearing_rad=0.05 --assoc-set poses.odometry_sigmas=0.01,0.002,0.011
        --final-set preset=victoria-park-gtsam
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Mapping
from dataclasses import replace

import numpy as np
from association_diagnosis import landmarks_decided
from harness_cells import set_options

from omnislam.core.types import RangeBearing
from omnislam.datasets.registry import load_dataset, resolve
from omnislam.datasets.sequence import Sequence
from omnislam.estimators import make_estimator
from omnislam.graphslam import range_bearing
from omnislam.harness.frames import sequence_info
from omnislam.harness.reference import reference_for
from omnislam.metrics.trajectory import Alignment, ate

#: a decided sighting: (frame index, range [m], bearing [rad]) -> the landmark it was given
Decisions = dict[tuple[int, float, float], int]


def relabel(sequence: Sequence, decided: Decisions, resolve_id) -> tuple[Sequence, int]:
    """``sequence`` with each sighting labelled by the association's decision.

    Args:
        sequence: the dataset loaded with its ids (its sightings are matched to the decisions by
            frame, range and bearing, which the two loads share).
        decided: the landmark each decided sighting was given, -1 where it was dropped.
        resolve_id: maps a created landmark to the one it was merged into (itself if none).

    Returns:
        The relabelled sequence (a frame whose sightings were all dropped has none) and the
        number of sightings dropped.

    Raises:
        KeyError: a sighting of ``sequence`` that the association never decided.
    """
    frames: list[RangeBearing | None] = []
    dropped = 0
    for k, sightings in enumerate(sequence.range_bearing):
        if sightings is None:
            frames.append(None)
            continue
        ids = np.array(
            [
                decided[(k, float(r), float(b))]
                for r, b in zip(sightings.ranges_m, sightings.bearings_rad, strict=True)
            ],
            dtype=np.int64,
        )
        keep = ids >= 0
        dropped += int(np.count_nonzero(~keep))
        if not keep.any():
            frames.append(None)
            continue
        frames.append(
            RangeBearing(
                landmark_ids=np.array([resolve_id(int(i)) for i in ids[keep]], dtype=np.int64),
                ranges_m=sightings.ranges_m[keep],
                bearings_rad=sightings.bearings_rad[keep],
                sigma_range_m=sightings.sigma_range_m[keep],
                sigma_bearing_rad=sightings.sigma_bearing_rad[keep],
            )
        )
    return replace(sequence, range_bearing=tuple(frames)), dropped


def split(dataset: str, options: Mapping[str, str]) -> tuple[dict, dict]:
    """(loader options, estimator options) of ``options`` for ``dataset``."""
    names = resolve(dataset).option_names()
    return (
        {k: v for k, v in options.items() if k in names},
        {k: v for k, v in options.items() if k not in names},
    )


def run(estimator: str, sequence: Sequence, options: Mapping[str, str]):
    """``estimator`` over every frame of ``sequence``: (its Estimate, the estimator, CPU s)."""
    frames = list(sequence.frame_inputs())
    start = time.process_time()
    made = make_estimator(
        estimator, sequence_info(sequence, frames), dict(options), np.random.default_rng(0)
    )
    for frame in frames:
        made.step(frame)
    return made.estimate(), made, time.process_time() - start


def associate(dataset: str, options: Mapping[str, str]):
    """Pass 1: graphslam without ids, every decision recorded. Returns (estimate, decisions,
    the landmark resolver, CPU s)."""
    loader, estimator_options = split(dataset, options)
    sequence = load_dataset(resolve(dataset), {**loader, "association": "unknown"})
    decided: Decisions = {}
    original = range_bearing.RangeBearingGraph._add_decided

    def recording(self, decision, k_now, guess_w, graph, values):
        next_id = self._next_created_id
        original(self, decision, k_now, guess_w, graph, values)
        sightings = decision.sightings
        for i, lid in enumerate(landmarks_decided(decision, next_id)):
            key = (decision.k, float(sightings.ranges_m[i]), float(sightings.bearings_rad[i]))
            decided[key] = lid

    range_bearing.RangeBearingGraph._add_decided = recording
    try:
        estimate, estimator, cpu = run("graphslam", sequence, estimator_options)
    finally:
        range_bearing.RangeBearingGraph._add_decided = original
    registry = estimator._graph._registry
    return estimate, decided, registry.resolve, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", help="a registered dataset with landmark ids")
    parser.add_argument("--assoc-set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--final-set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--final", default="graphslam-batch", help="the estimator of pass 2")
    args = parser.parse_args()
    assoc_options = set_options(parser, args.assoc_set, "--assoc-set")
    final_options = set_options(parser, args.final_set, "--final-set")
    resolved = resolve(args.dataset)

    print(f"{args.dataset}: pass 1, graphslam without ids {assoc_options} ...", file=sys.stderr)
    estimate, decided, resolve_id, cpu = associate(args.dataset, assoc_options)
    loader, estimator_options = split(args.dataset, final_options)
    labelled = load_dataset(resolved, loader)
    truth, _ = reference_for(resolved.format, resolved.path, labelled)

    def score(name: str, result, seconds: float) -> None:
        error = ate(result.trajectory, truth.trajectory, Alignment.SE2).rmse_m
        print(
            f"  {name}: ATE {error:.4f} m, {len(result.landmark_ids)} landmarks, "
            f"{seconds:.1f} s CPU"
        )

    score("pass 1, associated without ids", estimate, cpu)
    relabelled, dropped = relabel(labelled, decided, resolve_id)
    print(f"  {len(decided)} sightings decided, {dropped} dropped (ambiguous or rejected)")
    print(f"{args.dataset}: pass 2, {args.final} {final_options} ...", file=sys.stderr)
    solved, _, seconds = run(args.final, relabelled, estimator_options)
    score(f"pass 2, {args.final} on pass 1's associations", solved, seconds)
    print(f"{args.dataset}: {args.final} on the true ids {final_options} ...", file=sys.stderr)
    with_ids, _, seconds = run(args.final, labelled, estimator_options)
    score(f"{args.final} on the true ids", with_ids, seconds)
    gap = ate(solved.trajectory, with_ids.trajectory, Alignment.SE2).rmse_m
    print(f"  pass 2 against the true ids' solution: {gap:.4f} m (SE(2)-aligned RMSE)")


if __name__ == "__main__":
    main()
