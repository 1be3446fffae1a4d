"""FastSLAM speed and memory scaling.

1. Cost per particle-observation on a small 2-D world (8 landmarks, ~6 sightings per step) at
   100 and 1000 particles, FastSLAM 1.0 and 2.0 (sequential and joint proposal), tree store,
   each with the numpy path (the reference) and with the compiled kernels
   (``fastslam/kernels.py``, extra ``fast``; skipped without numba), all stepped interleaved in
   the same run, with the kernels' CPU time relative to the numpy path's and the largest
   difference of their trajectories. Goal: <= 1 us.
2. Step time with 1k, 10k and 100k landmarks in the map and a fixed 6 sightings per step,
   resampling every step (the worst case for the dense store): tree vs dense. Goal for the
   tree: <= 1.5x growth from 1k to 100k.
3. Memory: bytes held by the landmark store and peak bytes allocated during a step.

Run:  .venv/bin/python benchmarks/fastslam_scaling.py [--quick]
Medians over the timed steps are reported, of wall-clock time and of the thread's CPU time
(``time.thread_time``): on a shared machine a step that is preempted loses a whole time slice
of wall-clock time, so the CPU time is the stable figure. The map-size table also gives the
mean CPU time over the same steps, which includes the tree's node reclamation and table growth
(with 100k landmarks, the one doubling that follows writing the whole map at once falls inside
the timed steps).
"""

from __future__ import annotations

import sys
import time
import tracemalloc

import numpy as np

from omnislam.core.measurement import RangeBearing2D
from omnislam.core.modality import Modality
from omnislam.core.motion import MotionNoise
from omnislam.core.se import se2_between, se2_compose
from omnislam.core.types import FrameInput, Odometry, RangeBearing
from omnislam.fastslam import (
    FastSLAM,
    FastSLAMConfig,
    Kernels,
    LandmarkBlock,
    LandmarkStatus,
    ParticlesConfig,
    ProposalConfig,
    ProposalUpdateMode,
    ResamplingConfig,
    StoreKind,
    Variant,
    make_fastslam,
)
from omnislam.fastslam.kernels import available as kernels_available

NOISE = MotionNoise(a_vv=0.05, a_vw=0.02, a_wv=0.01, a_ww=0.05)
SIGMA_R, SIGMA_B = 0.05, 0.01


def small_world(steps: int, seed: int = 0) -> list[FrameInput]:
    """A circle of radius 4 m with 8 landmarks around it; ~6 within the 9 m sensor range."""
    rng = np.random.default_rng(seed)
    angles = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    landmarks = np.column_stack([6 * np.cos(angles), 4 + 6 * np.sin(angles)])
    sensor = RangeBearing2D()
    d = 0.3 / 4
    delta = np.array([4 * np.sin(d), 4 * (1 - np.cos(d)), d])
    pose = np.zeros(3)
    frames = []
    for t in range(steps):
        new = se2_compose(pose, delta)
        z, _, _ = sensor.predict(np.broadcast_to(new, (8, 3)), landmarks)
        seen = np.flatnonzero(z[:, 0] < 9.0)
        noisy = z[seen] + rng.normal(0, [SIGMA_R, SIGMA_B], (seen.size, 2))
        frames.append(
            FrameInput(
                t,
                Odometry(se2_between(pose, new), 0.1 * (t + 1)),
                range_bearing=RangeBearing(seen, noisy[:, 0], noisy[:, 1], SIGMA_R, SIGMA_B),
            )
        )
        pose = new
    return frames


def timed_step(slam: FastSLAM, frame: FrameInput) -> tuple[float, float]:
    """Wall-clock and thread CPU seconds of one filter step."""
    wall, cpu = time.perf_counter(), time.thread_time()
    slam.step(frame)
    return time.perf_counter() - wall, time.thread_time() - cpu


def per_particle_observation(quick: bool) -> list[str]:
    """FastSLAM 1.0, 2.0 with the sequential proposal and 2.0 with the joint one, each on the
    numpy path and with the compiled kernels, stepped interleaved frame by frame (each filter on
    its own rng, the same seed for both paths) so that all see the same load of a shared
    machine. "CPU vs sequential" compares a joint row with the sequential row of the same
    path; "CPU vs numpy" a kernel row with its numpy row; "max |diff|" is the largest
    difference [m or rad] between the two paths' trajectories. "least" is the smallest CPU
    time of any step: on a loaded machine every other step is inflated by preemption and
    cache pollution, so it is the closest to the unloaded cost."""
    steps, warm = (60, 10) if quick else (200, 20)
    frames = small_world(steps)
    sightings = np.mean([len(f.range_bearing) for f in frames])
    paths = [Kernels.NUMPY, *([Kernels.NUMBA] if kernels_available() else [])]
    rows = [
        f"## cost per particle-observation (8 landmarks, {sightings:.1f} sightings/step, "
        f"tree store, median of {steps - warm} steps, all filters stepped interleaved)",
        "| variant | proposal | path | particles | step ms | CPU ms | us / particle-observation "
        "| CPU us / p-o | least CPU us / p-o | CPU vs sequential | CPU vs numpy | max diff |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    if len(paths) == 1:
        rows.insert(1, "(numba not installed: numpy path only; pip install 'omnislam[fast]')")
    k = np.array([len(f.range_bearing) for f in frames[warm:]])
    kinds = [
        (variant, mode, path)
        for variant, mode in (
            (Variant.FASTSLAM1, ProposalUpdateMode.SEQUENTIAL),
            (Variant.FASTSLAM2, ProposalUpdateMode.SEQUENTIAL),
            (Variant.FASTSLAM2, ProposalUpdateMode.JOINT),
        )
        for path in paths
    ]
    for n in (100, 1000):
        filters = [
            make_fastslam(
                FastSLAMConfig(
                    variant=variant,
                    particles=ParticlesConfig(n_particles=n),
                    motion_noise=NOISE,
                    proposal=ProposalConfig(update=mode),
                    kernels=path,
                ),
                Modality.RANGE_BEARING_2D,
                np.random.default_rng(1),
            )
            for variant, mode, path in kinds
        ]
        if len(paths) > 1:  # compile outside the timed steps
            warmup = make_fastslam(
                FastSLAMConfig(
                    variant=Variant.FASTSLAM2,
                    particles=ParticlesConfig(n_particles=4),
                    kernels=Kernels.NUMBA,
                ),
                Modality.RANGE_BEARING_2D,
                np.random.default_rng(0),
            )
            for frame in frames[:3]:
                warmup.step(frame)
        times = np.array([[timed_step(slam, frame) for slam in filters] for frame in frames])
        times = times[warm:]  # (steps, filter, wall/CPU)
        index = {kind: i for i, kind in enumerate(kinds)}
        for i, (variant, mode, path) in enumerate(kinds):
            per = np.median(times[:, i] / (n * k)[:, None], axis=0) * 1e6
            least = np.min(times[:, i, 1] / (n * k)) * 1e6
            ms = np.median(times[:, i], axis=0) * 1e3
            proposal = mode.value if variant is Variant.FASTSLAM2 else "-"
            ratio = numpy_ratio = diff = ""
            if mode is ProposalUpdateMode.JOINT:
                sequential = index[(variant, ProposalUpdateMode.SEQUENTIAL, path)]
                ratio = f"{np.median(times[:, i, 1] / times[:, sequential, 1]):.2f}x"
            if path is Kernels.NUMBA:
                reference = index[(variant, mode, Kernels.NUMPY)]
                numpy_ratio = f"{np.median(times[:, i, 1] / times[:, reference, 1]):.2f}x"
                a = filters[i].estimate().trajectory.se2
                b = filters[reference].estimate().trajectory.se2
                diff = f"{np.abs(a - b).max():.1e}"
            rows.append(
                f"| {variant.value} | {proposal} | {path.value} | {n} | {ms[0]:.2f} | "
                f"{ms[1]:.2f} | {per[0]:.2f} | {per[1]:.2f} | {least:.2f} | {ratio} | "
                f"{numpy_ratio} | {diff} |"
            )
    return rows


def populated_filter(store: StoreKind, n_landmarks: int, n_particles: int):
    """A filter whose particles all share a map of ``n_landmarks`` landmarks on a grid."""
    config = FastSLAMConfig(
        variant=Variant.FASTSLAM1,
        particles=ParticlesConfig(n_particles=n_particles, store=store),
        motion_noise=NOISE,
        # resample every step: the dense store's worst case
        resampling=ResamplingConfig(ess_fraction=1.0),
    )
    slam = make_fastslam(config, Modality.RANGE_BEARING_2D, np.random.default_rng(2))
    slots = slam.add_known_landmarks(np.arange(n_landmarks))
    block = LandmarkBlock.empty(n_landmarks, 2, 0)
    side = int(np.ceil(np.sqrt(n_landmarks)))
    block.mean[:] = np.column_stack([slots % side, slots // side]) * 3.0
    block.cov[:] = 0.01 * np.eye(2)
    block.status[:] = LandmarkStatus.ESTIMATED
    block.existence[:] = 1
    slam.store.scatter(np.zeros(n_landmarks, dtype=np.int64), slots, block)
    slam.store.resample(np.zeros(n_particles, dtype=np.int64))
    return slam, block.mean


def map_size_scaling(quick: bool) -> list[str]:
    n_particles, steps = 100, (8 if quick else 25)
    sizes = (1_000, 10_000, 100_000)
    rows = [
        f"## step time vs map size ({n_particles} particles, 6 sightings/step, resampling "
        f"every step, median of {steps} steps)",
        "| store | landmarks | step ms | growth vs 1k | CPU ms | CPU growth | CPU mean ms "
        "| store MB | peak alloc in step MB |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    sensor = RangeBearing2D()
    for store in (StoreKind.TREE, StoreKind.LEAF_TREE, StoreKind.DENSE):
        base = None
        for m in sizes:
            slam, landmarks = populated_filter(store, m, n_particles)
            rng = np.random.default_rng(3)
            times, peaks = [], []
            pose = np.zeros(3)
            for t in range(steps + 3):
                ids = rng.choice(m, size=6, replace=False)
                z, _, _ = sensor.predict(np.broadcast_to(pose, (6, 3)), landmarks[ids])
                frame = FrameInput(
                    t,
                    Odometry(np.array([0.1, 0.0, 0.01]), 0.1 * (t + 1)),
                    range_bearing=RangeBearing(ids, z[:, 0], z[:, 1], SIGMA_R, SIGMA_B),
                )
                measure_memory = t == steps + 2
                if measure_memory:
                    tracemalloc.start()
                elapsed = timed_step(slam, frame)
                if measure_memory:
                    peaks.append(tracemalloc.get_traced_memory()[1])
                    tracemalloc.stop()
                elif t >= 2:
                    times.append(elapsed)
            median = np.median(times, axis=0)
            base = median if base is None else base
            rows.append(
                f"| {store.value} | {m} | {median[0] * 1e3:.2f} | {median[0] / base[0]:.2f}x | "
                f"{median[1] * 1e3:.2f} | {median[1] / base[1]:.2f}x | "
                f"{np.mean(times, axis=0)[1] * 1e3:.2f} | "
                f"{slam.store.memory_bytes / 1e6:.1f} | {peaks[0] / 1e6:.2f} |"
            )
    return rows


def main() -> None:
    quick = "--quick" in sys.argv
    lines = [*per_particle_observation(quick), "", *map_size_scaling(quick)]
    sys.stdout.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
