"""EKF-SLAM step time against map size.

n landmarks uniformly in a disc of radius 10 m around a robot that turns on the spot and sees
every landmark in its front half-plane (range-bearing with ids): about n/2 sightings per step,
each an O(n^2) update, so a step costs O(n^3) -- the full-covariance EKF's price -- while one
update grows as n^2. Frames 0 and 1 look in opposite directions and only add the two halves of
the map (augmentation); the timed steps then turn by 0.3 rad each.

Reports the median step time (wall clock and thread CPU time, ``time.thread_time``: on a shared
machine the CPU time is the stable figure), the median time per sighting (one update), and the
growth 128 -> 2048 compared with n^2 (per update) and n^3 (per step).

BLAS runs single-threaded (set before numpy is imported): with threaded BLAS on two shared
cores the d x 4 x d product of each update spent most of its wall time waiting (n = 512: 13 s
wall for 1 s of CPU per step).

Run:  PYTHONPATH=. .venv/bin/python benchmarks/ekfslam_scaling.py [--quick]
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from omnislam.core.measurement import RangeBearing2D  # noqa: E402
from omnislam.core.types import FrameInput, Odometry, RangeBearing  # noqa: E402
from omnislam.ekfslam import EKFSLAM, EKFSLAMConfig  # noqa: E402

SIZES = (16, 64, 128, 512, 2048)
SIGMA_RANGE_M, SIGMA_BEARING_RAD = 0.05, 0.01


def frames(n: int, steps: int, seed: int = 0):
    """Frame 0 at heading 0, frame 1 at heading pi, then turns of 0.3 rad on the spot."""
    rng = np.random.default_rng(seed)
    radius = 10.0 * np.sqrt(rng.uniform(0.05, 1.0, n))
    angle = rng.uniform(-np.pi, np.pi, n)
    landmarks = np.column_stack([radius * np.cos(angle), radius * np.sin(angle)])
    sensor = RangeBearing2D()
    heading = 0.0
    for t in range(steps):
        turn = 0.0 if t == 0 else (np.pi if t == 1 else 0.3)
        heading += turn
        z, _, _ = sensor.predict(np.array([0.0, 0.0, heading])[None], landmarks)
        seen = np.flatnonzero(np.abs(z[:, 1]) < np.pi / 2)
        noisy = z[seen] + rng.standard_normal((seen.size, 2)) * [SIGMA_RANGE_M, SIGMA_BEARING_RAD]
        yield FrameInput(
            index=t,
            odometry=Odometry(np.array([0.0, 0.0, turn]), stamp_s=float(t + 1)),
            range_bearing=RangeBearing(
                seen, np.abs(noisy[:, 0]), noisy[:, 1], SIGMA_RANGE_M, SIGMA_BEARING_RAD
            ),
        )


def measure(n: int, timed_steps: int) -> dict[str, float]:
    ekf = EKFSLAM(EKFSLAMConfig())
    wall, cpu, per_sighting = [], [], []
    for frame in frames(n, timed_steps + 2):
        w0, c0 = time.perf_counter(), time.thread_time()
        ekf.step(frame)
        w1, c1 = time.perf_counter(), time.thread_time()
        if frame.index >= 2:
            wall.append(w1 - w0)
            cpu.append(c1 - c0)
            per_sighting.append((c1 - c0) / max(len(frame.range_bearing), 1))
    assert ekf.state.n_landmarks == n
    return {
        "wall_ms": 1e3 * float(np.median(wall)),
        "cpu_ms": 1e3 * float(np.median(cpu)),
        "update_us": 1e6 * float(np.median(per_sighting)),
        "sightings": float(np.mean([len(f.range_bearing) for f in frames(n, timed_steps + 2)][2:])),
    }


def main(argv: list[str]) -> None:
    quick = "--quick" in argv
    sizes = SIZES[:3] if quick else SIZES
    rows = {}
    print(
        f"{'n':>6} {'sightings':>9} {'step wall ms':>13} {'step cpu ms':>12} {'cpu us/update':>14}"
    )
    for n in sizes:
        steps = 20 if n <= 128 else (5 if n <= 512 else 2)
        rows[n] = measure(n, steps)
        r = rows[n]
        print(
            f"{n:>6} {r['sightings']:>9.0f} {r['wall_ms']:>13.2f} {r['cpu_ms']:>12.2f}"
            f" {r['update_us']:>14.1f}",
            flush=True,
        )
    print(f"step at 128 landmarks: {rows[128]['cpu_ms']:.2f} ms CPU (goal <= 10 ms)")
    if 2048 in rows:
        ratio = 2048 / 128
        step = rows[2048]["cpu_ms"] / rows[128]["cpu_ms"]
        update = rows[2048]["update_us"] / rows[128]["update_us"]
        print(
            f"growth 128 -> 2048: step x{step:.0f} (n^2 = x{ratio**2:.0f}, n^3 = x{ratio**3:.0f}); "
            f"per update x{update:.0f} (n^2 = x{ratio**2:.0f})"
        )


if __name__ == "__main__":
    main(sys.argv[1:])
