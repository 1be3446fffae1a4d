"""How well could the graph do on a synthetic omni route if its tracks were perfect?

The renderer knows the world point behind every pixel, so every sighting of a front-end log
has a true 3-D point (``frontend.evaluation``). This benchmark replays one log five ways and
reports the estimator's ATE and landmark error for each:

``front end``
    the log as the front end wrote it.
``clean``
    every sighting whose true point lies more than ``--tol`` from its track's point (the median
    of the track's true points) is dropped: no track holds two world points.
``returns``
    ``clean``, and a track whose point an earlier track saw, with more than ``--return-gap-s``
    between the two, takes that track's id: the loop closure alone, as a front end that
    re-associates every return would give it.
``merged``
    ``clean``, and tracks whose points lie within ``--tol`` of each other become one track
    (union-find over the pairs): every re-sighting is re-associated, the loop closure included.
    Floor tracks never merge with landmark tracks; a frame keeps one sighting per track.
``noisy truth``
    ``merged``, each bearing replaced by the direction from the true viewpoint to its track's
    point, perturbed on the tangent plane by Gaussian noise of the bearing's logged sigma: what
    perfect association and bearings that match the stated noise model would give.
``exact``
    ``merged`` with the true directions and no noise.

The estimator and its weights are unchanged throughout (the logged sigmas), so ``noisy truth``
is what the estimator can reach on this route's sightings with a perfect front end: its gap to
a goal is the route's information, not the association's. Run from the repository root::

    PYTHONPATH=. .venv/bin/python benchmarks/oracle_tracks.py --dataset RENDER --log LOG \\
        [--estimator graphslam] [--tol 0.02] [--noise-seed 0] [--keep DIR]

``RENDER`` is a synthetic omni folder (``omnislam dataset synth loop150 --out RENDER``) and
``LOG`` its front-end log (``omnislam frontend RENDER --out LOG``).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from omnislam.core.types import Bearings
from omnislam.datasets.registry import load_dataset
from omnislam.datasets.synthetic.loader import SyntheticFolder
from omnislam.frontend.evaluation import Sightings, sampled_true_sightings
from omnislam.frontend.observation_log import (
    ObservationLog,
    load_observation_log,
    save_observation_log,
)
from omnislam.harness.evaluation import evaluate_run
from omnislam.harness.execute import RunSpec, execute_run

VARIANTS = ("front end", "clean", "returns", "merged", "noisy truth", "exact")


@dataclasses.dataclass(frozen=True)
class TrackTruth:
    """The sightings of a log against the renderer's truth.

    Attributes:
        keep: (S,) the sighting's true point lies within the tolerance of its track's point.
        point_of: track id -> the median true point of its kept sightings [m].
        merged_id: track id -> the id of its merged track (the smallest id of its group).
        merged_point: merged id -> the mean point of its tracks [m].
    """

    keep: np.ndarray
    point_of: dict[int, np.ndarray]
    merged_id: dict[int, int]
    merged_point: dict[int, np.ndarray]


def track_truth(s: Sightings, tol_m: float, floor_ids_from: int | None) -> TrackTruth:
    """Each track's true point, the sightings that see it, and the tracks that see one point."""
    known = np.all(np.isfinite(s.points_w), axis=1)
    keep = np.zeros(len(s.track), dtype=bool)
    point_of: dict[int, np.ndarray] = {}
    order = np.argsort(s.track, kind="stable")
    bounds = np.flatnonzero(np.diff(s.track[order])) + 1
    for rows in np.split(order, bounds):
        rows = rows[known[rows]]
        if not rows.size:
            continue
        centre = np.median(s.points_w[rows], axis=0)
        near = rows[np.linalg.norm(s.points_w[rows] - centre, axis=1) <= tol_m]
        if near.size:
            keep[near] = True
            point_of[int(s.track[near[0]])] = np.median(s.points_w[near], axis=0)
    ids = np.array(sorted(point_of), dtype=np.int64)
    points = np.array([point_of[i] for i in ids]).reshape(-1, 3)
    floor = ids >= floor_ids_from if floor_ids_from is not None else np.zeros(ids.size, bool)
    pairs = cKDTree(points).query_pairs(tol_m, output_type="ndarray")
    pairs = pairs[floor[pairs[:, 0]] == floor[pairs[:, 1]]]
    n = ids.size
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    first = {}
    for i in range(n):  # ids are sorted: the first of a group is its smallest id
        first.setdefault(label[i], int(ids[i]))
    merged_id = {int(ids[i]): first[label[i]] for i in range(n)}
    members: dict[int, list[np.ndarray]] = {}
    for i in range(n):
        members.setdefault(merged_id[int(ids[i])], []).append(points[i])
    merged_point = {k: np.mean(v, axis=0) for k, v in members.items()}
    return TrackTruth(keep, point_of, merged_id, merged_point)


def returns_only(truth: TrackTruth, s: Sightings, gap_s: float) -> TrackTruth:
    """``truth`` with only the merges across a gap of more than ``gap_s`` (a return): within
    each merged group, in the order the tracks started, a track that starts more than
    ``gap_s`` after the group's sightings so far joins the latest track; one that starts
    sooner keeps its id (a track broken and re-started in passing is not re-joined)."""
    first: dict[int, float] = {}
    last: dict[int, float] = {}
    for track, stamp in zip(s.track.tolist(), s.stamp_s.tolist(), strict=True):
        first[track] = min(first.get(track, np.inf), stamp)
        last[track] = max(last.get(track, -np.inf), stamp)
    groups: dict[int, list[int]] = {}
    for track, group in truth.merged_id.items():
        groups.setdefault(group, []).append(track)
    merged_id: dict[int, int] = {}
    for tracks in groups.values():
        tracks.sort(key=lambda t: first[t])
        latest, end = tracks[0], last[tracks[0]]
        merged_id[latest] = latest
        for track in tracks[1:]:
            if first[track] - end > gap_s:
                merged_id[track] = merged_id[latest]
            else:
                merged_id[track] = latest = track
            end = max(end, last[track])
    return dataclasses.replace(truth, merged_id=merged_id)


def _tangent_noise(d: np.ndarray, sigma: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Unit vectors ``d`` (K, 3) turned by Gaussian angles of std ``sigma`` (K,) on both
    tangent axes."""
    up = np.where(np.abs(d[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    a = np.cross(d, up)
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = np.cross(d, a)
    e = rng.normal(0.0, 1.0, (d.shape[0], 2)) * sigma[:, None]
    out = d + e[:, :1] * a + e[:, 1:] * b
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def variant_log(
    log: ObservationLog,
    truth: TrackTruth,
    variant: str,
    wTr: np.ndarray,
    viewpoint_r: np.ndarray,
    rng: np.random.Generator,
) -> ObservationLog:
    """``log`` with its tracks corrected as ``variant`` says (module docstring)."""
    merged = variant in ("returns", "merged", "noisy truth", "exact")
    frames, pixels, start = [], [], 0
    for frame, px in zip(log.frames, log.pixels, strict=True):
        if frame.bearings is None or len(frame.bearings) == 0:
            frames.append(frame)
            pixels.append(px)
            continue
        k = len(frame.bearings)
        kept = truth.keep[start : start + k].copy()
        start += k
        ids = frame.bearings.landmark_ids.copy()
        if merged:
            ids = np.array([truth.merged_id.get(int(t), int(t)) for t in ids], dtype=np.int64)
            seen: set[int] = set()
            for j in np.flatnonzero(kept):  # one sighting per track and frame
                kept[j] = int(ids[j]) not in seen
                seen.add(int(ids[j]))
        vectors = frame.bearings.unit_vectors_r
        if variant in ("noisy truth", "exact"):
            pose = wTr[frame.index]
            R, t = pose[:3, :3], pose[:3, 3]
            points = np.array([truth.merged_point[int(i)] for i in ids[kept]]).reshape(-1, 3)
            d = (points - (R @ viewpoint_r + t)) @ R  # world -> robot frame
            d /= np.linalg.norm(d, axis=1, keepdims=True)
            if variant == "noisy truth":
                d = _tangent_noise(d, frame.bearings.sigmas_rad[kept], rng)
            vectors = vectors.copy()
            vectors[kept] = d
        bearings = Bearings(ids[kept], vectors[kept], frame.bearings.sigmas_rad[kept])
        frames.append(dataclasses.replace(frame, bearings=bearings))
        pixels.append(px[kept])
    return dataclasses.replace(log, frames=tuple(frames), pixels=tuple(pixels))


def say(text: str) -> None:
    """Progress on stderr."""
    print(text, file=sys.stderr, flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dataset", required=True, help="synthetic omni folder")
    parser.add_argument("--log", required=True, help="its front-end log")
    parser.add_argument("--estimator", default="graphslam")
    parser.add_argument("--tol", type=float, default=0.02, help="same world point [m]")
    parser.add_argument(
        "--return-gap-s", type=float, default=60.0, help="a return: seen again after [s]"
    )
    parser.add_argument("--noise-seed", type=int, default=0)
    parser.add_argument("--seed", type=int, default=0, help="the estimator's seed")
    parser.add_argument("--keep", type=Path, help="write the variant logs here")
    args = parser.parse_args()

    sequence = load_dataset(args.dataset)
    log = load_observation_log(args.log)
    camera = sequence.calibration.camera
    say(f"true points of {sum(f.bearings is not None for f in log.frames)} images ...")
    s = sampled_true_sightings(
        log, sequence.pixel_points_loader, (int(camera.height), int(camera.width))
    )
    truth = track_truth(s, args.tol, log.floor_ids_from)
    wTr = SyntheticFolder(args.dataset).groundtruth.poses_w
    viewpoint_r = np.asarray(sequence.calibration.viewpoint_r, dtype=float)
    rng = np.random.default_rng(args.noise_seed)
    returns = returns_only(truth, s, args.return_gap_s)
    joined = {t for t, m in returns.merged_id.items() if m != t}
    returning = truth.keep & np.isin(s.track, list(joined))
    print(
        f"{args.dataset}: {len(s.track)} sightings, {truth.keep.sum()} on their track's "
        f"point (tol {args.tol} m); {len(truth.point_of)} tracks, "
        f"{len(truth.merged_point)} after merging; returns: {len(joined)} tracks of "
        f"{len({returns.merged_id[t] for t in joined})} earlier ones, {returning.sum()} "
        f"sightings in {len(np.unique(s.frame[returning]))} images"
    )
    print(
        "\n| tracks | sightings | ATE [cm] | landmark RMSE [cm] | landmark median [cm] | "
        "landmarks |\n|---|---:|---:|---:|---:|---:|"
    )
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        for variant in VARIANTS:
            path = Path(args.log)
            if variant != "front end":
                path = folder / f"{Path(args.log).stem}-{variant.replace(' ', '-')}.npz"
                used = returns if variant == "returns" else truth
                save_observation_log(variant_log(log, used, variant, wTr, viewpoint_r, rng), path)
            say(f"{args.estimator} on the {variant} tracks ...")
            record = execute_run(
                RunSpec(args.dataset, args.estimator, args.seed, {}, log=str(path))
            )
            m = evaluate_run(record)
            count = sum(
                len(f.bearings) for f in load_observation_log(path).frames if f.bearings is not None
            )
            print(
                f"| {variant} | {count} | {100 * m.ate.rmse_m:.2f} | "
                f"{100 * m.landmarks.rmse_m:.2f} | {100 * m.landmarks.median_m:.2f} | "
                f"{m.landmarks.matched} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
