"""Step time of the vertical-line UKF against the size of its map, with and without the pre-gate.

corridor21 (rendered, front end and MC survey as in ``ukf_corridor21.py``) with M extra
landmarks added to its map at random places in the corridors (random MC
descriptors, so the photometric stage has work), and the localiser run on the whole sequence.
Reported per processed frame (steps 3-5 and the update; the front end's line extraction is
separate and does not depend on the map): median CPU time (``time.process_time``) and median
wall time, for the default step 4 (pre-gate by the predicted covariance before the photometric
stage, joint gate) and for the paper's step 4 alone (``association.gate_probability=none``,
``association.largest_set_first=false``), whose time grows with the number of pairs in the
u_shift windows. Runs of the paper's step 4 stop after ``--paper-frames`` processed frames
(it takes seconds per frame in large maps).

    PYTHONPATH=. python benchmarks/ukf_step_scaling.py [--out DIR] [--sizes 0 100 1000 ...]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
import warnings
from pathlib import Path

import numpy as np

warnings.filterwarnings("ignore", category=UserWarning)
sys.path.insert(0, str(Path(__file__).parent))

SIZES = (0, 100, 1000, 10_000, 100_000)
PAPER = {"association.gate_probability": "none", "association.largest_set_first": "false"}


def in_corridors(xy: np.ndarray) -> np.ndarray:
    """True inside corridor21's U (y in [0, 2] or [5, 7], or x in [8, 10]), off the walls."""
    x, y = xy[:, 0], xy[:, 1]
    inside = (x > 0.05) & (x < 9.95) & (y > 0.05) & (y < 6.95)
    return inside & ((y < 1.95) | (y > 5.05) | (x > 8.05))


def grown_map(prior, extra: int, rng: np.random.Generator):
    """``prior`` with ``extra`` vertical-line landmarks at random places in the corridors (where
    no wall hides them: the candidates grow with the map, as with a SLAM run's map)."""
    if extra == 0:
        return prior
    xy = np.zeros((0, 2))
    while len(xy) < extra:
        draw = rng.uniform([0.0, 0.0], [10.0, 7.0], (2 * extra, 2))
        xy = np.vstack([xy, draw[in_corridors(draw)]])
    points = np.column_stack([xy[:extra], np.zeros(extra)])
    ids = np.arange(extra) + int(prior.landmark_ids.max()) + 1
    colours = rng.uniform(0.0, 255.0, (2, extra, 3))
    return dataclasses.replace(
        prior,
        source=f"{prior.source} + {extra} random landmarks",
        landmark_ids=np.concatenate([prior.landmark_ids, ids]),
        points_w=np.vstack([prior.points_w, points]),
        vertical_line=np.concatenate([prior.vertical_line, np.ones(extra, dtype=bool)]),
        means_left=np.vstack([prior.means_left, colours[0]]),
        means_right=np.vstack([prior.means_right, colours[1]]),
    )


def time_run(setup, prior, options: dict[str, str], max_frames: int | None) -> dict:
    """Median CPU / wall time per processed frame, and the candidates and pairs per frame."""
    from omnislam.core.modality import Modality
    from omnislam.options import apply_options
    from omnislam.ukf import UKFConfig, VerticalLineUKF

    config = apply_options(UKFConfig(), options)
    ukf = VerticalLineUKF(prior, config, Modality.VERTICAL_LINES, setup.line)
    cpu, wall = [], []
    for frame in setup.log.frames:
        c0, w0 = time.process_time(), time.perf_counter()
        ukf.step(frame)
        c1, w1 = time.process_time(), time.perf_counter()
        if ukf.associations and ukf.associations[-1].index == frame.index:
            cpu.append(c1 - c0)
            wall.append(w1 - w0)
            if max_frames is not None and len(cpu) >= max_frames:
                break
    info = ukf.info()
    k = max(info.frames_processed, 1)
    return dict(
        cpu_ms=float(np.median(cpu)) * 1e3,
        wall_ms=float(np.median(wall)) * 1e3,
        frames=len(cpu),
        candidates=info.candidates_total / k,
        pregated=info.pairs_pregated / k,
    )


def main() -> None:
    import ukf_corridor21

    parser = argparse.ArgumentParser()
    parser.add_argument("--out", default="/tmp/ukf_corridor21")
    parser.add_argument("--noise", type=float, default=1.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--sizes", nargs="*", type=int, default=list(SIZES))
    parser.add_argument("--paper-frames", type=int, default=5)
    parser.add_argument("--paper-max-size", type=int, default=10_000)
    args = parser.parse_args()
    print(
        f"corridor21: rendering (once, into {args.out}) and the front end (cached) ...",
        file=sys.stderr,
        flush=True,
    )
    setup = ukf_corridor21.prepare(Path(args.out), args.noise, args.seed)
    print(f"data: {setup.folder}; {len(setup.prior)} landmarks in the world's map")
    print(
        "| extra landmarks | candidates / frame | pre-gated pairs / frame | default: CPU ms"
        " (wall) | paper's step 4: CPU ms (wall), frames |"
    )
    print("|---|---|---|---|---|")
    for size in args.sizes:
        prior = grown_map(setup.prior, size, np.random.default_rng(size))
        print(
            f"{size} extra landmarks: running the UKF over the sequence ...",
            file=sys.stderr,
            flush=True,
        )
        ours = time_run(setup, prior, {}, None)
        if size <= args.paper_max_size:
            print(
                f"{size} extra landmarks: the paper's step 4 on {args.paper_frames} frames ...",
                file=sys.stderr,
                flush=True,
            )
            paper = time_run(setup, prior, PAPER, args.paper_frames)
            paper_cell = f"{paper['cpu_ms']:.1f} ({paper['wall_ms']:.1f}), {paper['frames']}"
        else:
            paper_cell = "not run"
        print(
            f"| {size} | {ours['candidates']:.0f} | {ours['pregated']:.1f}"
            f" | {ours['cpu_ms']:.2f} ({ours['wall_ms']:.2f}) | {paper_cell} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
