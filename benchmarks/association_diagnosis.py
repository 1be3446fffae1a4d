"""Where graphslam's association of unlabelled range-bearing sightings goes wrong.

Runs ``graphslam`` on a dataset with its landmark ids hidden (``association=unknown``, as
``omnislam run DATASET --estimator graphslam --set association=unknown``) and scores every
association decision against the hidden ids: each decided sighting is looked up by frame, range
and bearing in the same dataset loaded with ids. A landmark the association created is named
after the hidden id most of its sightings carry; a sighting given to a landmark named otherwise
is a *wrong pairing*. Printed per dataset:

* the decisions (paired / new / ambiguous / rejected) and the wrong pairings, with the first
  frames they happen in;
* true landmarks mapped more than once (*duplicates*) -- and for each duplicate pair still in the
  map, the squared Mahalanobis distance of ``x_b - x_a`` under iSAM2's final joint marginal,
  the quantity the loop closure (``graphslam.loop_closure``) tests: far beyond the 0.99 gate
  (9.2) the estimate itself holds them apart;
* the merges of the loop closure, each marked right or wrong by the hidden ids.

The estimator runs with its defaults; ``--set key=value`` overrides them, or the loader's options
(e.g. ``sigma_bearing_rad``), as ``omnislam run`` does.
The decision hook wraps ``RangeBearingGraph._add_decided`` of this process only::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/association_diagnosis.py
        [mrclam6-r1 ...] [--set key=value ...]
"""

from __future__ import annotations

import argparse
import collections
import sys

import numpy as np
from harness_cells import set_options

from omnislam.core.compatibility import Decision
from omnislam.datasets.registry import load_dataset, resolve
from omnislam.estimators import make_estimator
from omnislam.graphslam import factors as fx
from omnislam.graphslam import range_bearing
from omnislam.graphslam.window_association import Decided
from omnislam.harness.frames import sequence_info

#: chi-square 0.99 quantile, 2 dof: the loop closure's individual gate
GATE_99 = 9.21


def landmarks_decided(decision: Decided, next_id: int) -> list[int]:
    """The landmark each of a frame's decided sightings went to, -1 where it was dropped.

    ``next_id`` is the graph's next created id before the frame's decisions were added: NEW
    sightings take the ids from it on, in order (``RangeBearingGraph._add_decided``).
    """
    landmarks = []
    for i, d in enumerate(decision.decisions.tolist()):
        if d == Decision.NEW:
            lid, next_id = next_id, next_id + 1
        elif d == Decision.PAIRED:
            lid = int(decision.candidate_ids[i])
        else:
            lid = -1
        landmarks.append(lid)
    return landmarks


def hidden_ids(dataset: str, options: dict[str, str]):
    """The dataset with its ids hidden, and the ids it hides.

    Returns ``(labelled, sequence, frames, options)``: each frame's labelled sightings by frame
    index, the sequence loaded with ``association=unknown`` and its frames, and the options
    left for the estimator (the loader's options, e.g. ``sigma_bearing_rad``, taken out).
    """
    resolved = resolve(dataset)
    loader = {k: v for k, v in options.items() if k in resolved.option_names()}
    options = {k: v for k, v in options.items() if k not in loader}
    labelled = {f.index: f.range_bearing for f in load_dataset(resolved, loader).frame_inputs()}
    sequence = load_dataset(resolved, {**loader, "association": "unknown"})
    return labelled, sequence, list(sequence.frame_inputs()), options


def diagnose(dataset: str, options: dict[str, str]) -> None:
    """Run, score and print one dataset (see the module docstring)."""
    labelled, sequence, frames, estimator_options = hidden_ids(dataset, options)
    decided: list[tuple[int, int, int, str]] = []  # (frame, hidden id, landmark or -1, decision)
    original = range_bearing.RangeBearingGraph._add_decided

    def recording(self, decision, k_now, guess_w, graph, values):
        next_id = self._next_created_id
        original(self, decision, k_now, guess_w, graph, values)
        given = labelled[decision.k]
        landmarks = landmarks_decided(decision, next_id)
        for i, (d, lid) in enumerate(zip(decision.decisions.tolist(), landmarks, strict=True)):
            row = np.flatnonzero(
                (given.ranges_m == decision.sightings.ranges_m[i])
                & (given.bearings_rad == decision.sightings.bearings_rad[i])
            )[0]
            decided.append((decision.k, int(given.landmark_ids[row]), lid, Decision(d).name))

    range_bearing.RangeBearingGraph._add_decided = recording
    try:
        info = sequence_info(sequence, frames)
        estimator = make_estimator(
            "graphslam", info, dict(estimator_options), np.random.default_rng(0)
        )
        print(f"{dataset}: running graphslam without the ids ...", file=sys.stderr, flush=True)
        for frame in frames:
            estimator.step(frame)
        estimator.estimate()
    finally:
        range_bearing.RangeBearingGraph._add_decided = original
    graph = estimator._graph  # the range-bearing builder: registry, session, merger
    registry, session, merger = graph._registry, graph._session, graph._merger

    raw: dict[int, collections.Counter] = collections.defaultdict(collections.Counter)
    holds: dict[int, collections.Counter] = collections.defaultdict(collections.Counter)
    for _, true_id, lid, _ in decided:
        if lid >= 0:
            raw[lid][true_id] += 1
            holds[registry.resolve(lid)][true_id] += 1
    name = {lid: c.most_common(1)[0][0] for lid, c in holds.items()}
    wrong = [
        (k, t, lid) for k, t, lid, _ in decided if lid >= 0 and name[registry.resolve(lid)] != t
    ]
    counts = collections.Counter(d for *_, d in decided)
    active = [lid for lid in holds if registry.active(lid)]
    mapped_as: dict[int, list[int]] = collections.defaultdict(list)
    for lid in active:
        mapped_as[name[lid]].append(lid)
    base = range_bearing.CREATED_ID_BASE
    print(f"\n{dataset} {options or ''}")
    print(
        f"  decisions: {dict(counts)}; wrong pairings {len(wrong)} "
        f"(first frames {sorted({k for k, *_ in wrong})[:12]})"
    )
    # named after the sighting that started it, a landmark is wrong from its first foreign pairing
    # on (the majority name above blames a landmark's first sightings once another tree's
    # sightings outnumber them)
    creator = {lid: t for _, t, lid, d in decided if d == Decision.NEW.name}
    first = [
        (k, t, creator.get(lid, t))
        for k, t, lid, d in decided
        if d == Decision.PAIRED.name and creator.get(lid, t) != t
    ]
    print(
        f"  pairings with a landmark started by another hidden id: {len(first)}; the first "
        + ", ".join(f"frame {k}: {t} given {c}'s" for k, t, c in first[:6])
    )
    print(
        f"  landmarks in the map {len(active)} for {len(mapped_as)} true ones; true landmarks "
        f"mapped more than once: {sum(len(v) > 1 for v in mapped_as.values())}"
    )
    for true_id, lids in sorted(mapped_as.items()):
        if len(lids) < 2:
            continue
        lids = sorted(lids)
        pairs = []
        for i, a in enumerate(lids):
            for b in lids[i + 1 :]:
                keys = [fx.landmark_key(a), fx.landmark_key(b)]
                P = session.joint_marginal_covariance(keys)
                J = np.hstack([np.eye(2), -np.eye(2)])
                nu = session.point2(keys[0]) - session.point2(keys[1])
                d2 = float(nu @ np.linalg.solve(J @ P @ J.T, nu))
                pairs.append(f"{a - base}-{b - base}: {np.hypot(*nu):.2f} m, d2 {d2:.0f}")
        print(f"  true {true_id}: duplicates {[lid - base for lid in lids]}; " + "; ".join(pairs))
    if merger is not None:
        merges = [(lid, registry.resolve(lid)) for lid in raw if not registry.active(lid)]
        right = sum(
            raw[dup].most_common(1)[0][0] == raw[kept].most_common(1)[0][0] for dup, kept in merges
        )
        print(
            f"  loop closure: {merger.loop_closures} closures, {merger.merged} landmarks merged "
            f"({right} right by the hidden ids), {merger.checks} local-map matches tried"
        )
        for dup, kept in merges:
            print(f"    merged {dup - base} {dict(raw[dup])} into {kept - base} {dict(raw[kept])}")


def diagnose_each(diagnose_one, description: str) -> None:
    """The command line of a diagnosis: ``[DATASET ...] [--set KEY=VALUE ...]`` (MR.CLAM robots
    1-5 by default), ``diagnose_one(dataset, options)`` for each dataset."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("datasets", nargs="*", default=[f"mrclam6-r{i}" for i in range(1, 6)])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    options = set_options(parser, args.set)
    for dataset in args.datasets:
        diagnose_one(dataset, options)


def main() -> None:
    diagnose_each(diagnose, __doc__.splitlines()[0])


if __name__ == "__main__":
    main()
