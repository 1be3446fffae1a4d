"""The thesis's landmark tree (estimates in every node, sec. 4.4.1.3) vs Montemerlo's
leaf-only tree: nodes allocated and time per update, side by side.

For each map size M: one particle builds the static tree (thesis Fig. 4.10: 7 landmarks ->
7 vs 14 nodes), all P particles then share it; each step every particle updates 6 random
landmarks (gather + EKF-sized write = scatter with path copying) and the particles are
resampled. Reported: live nodes of the static tree, nodes allocated per step, node visits per
landmark update, and the median time of one step's gather + scatter.

Run:  .venv/bin/python benchmarks/fastslam_tree.py [--quick]
"""

from __future__ import annotations

import sys
import time

import numpy as np

from omnislam.fastslam import LandmarkBlock, LandmarkStatus, LandmarkTree, TreeLayout

PARTICLES = 100
SIGHTINGS = 6


def run(layout: TreeLayout, m: int, steps: int) -> tuple[int, float, float, float, int]:
    rng = np.random.default_rng(0)
    tree = LandmarkTree(PARTICLES, 2, initial_capacity=4 * m, layout=layout)
    tree.add_landmarks(m)
    block = LandmarkBlock.empty(m, 2, 0)
    block.status[:] = LandmarkStatus.ESTIMATED
    tree.scatter(np.zeros(m, dtype=np.int64), np.arange(m), block)
    static_nodes = tree.live_nodes()
    tree.resample(np.zeros(PARTICLES, dtype=np.int64))
    who = np.repeat(np.arange(PARTICLES), SIGHTINGS)
    allocated, visits, times = [], [], []
    for _ in range(steps):
        slots = np.concatenate(
            [rng.choice(m, size=SIGHTINGS, replace=False) for _ in range(PARTICLES)]
        )
        a0, v0 = tree.nodes_allocated, tree.node_visits
        t0 = time.perf_counter()
        landmarks = tree.gather(who, slots)
        landmarks.mean += 0.01
        tree.scatter(who, slots, landmarks)
        times.append(time.perf_counter() - t0)
        allocated.append(tree.nodes_allocated - a0)
        visits.append((tree.node_visits - v0) / (2 * who.size))
        tree.resample(np.sort(rng.integers(0, PARTICLES, PARTICLES)))
    return (
        static_nodes,
        float(np.mean(allocated)),
        float(np.mean(visits)),
        float(np.median(times)),
        tree.live_nodes(),
    )


def main() -> None:
    steps = 10 if "--quick" in sys.argv else 50
    lines = [
        f"{PARTICLES} particles, {SIGHTINGS} landmark updates per particle per step, "
        f"resampling every step, {steps} steps",
        "| landmarks | tree | static nodes | nodes allocated / step | node visits / update "
        "| gather+scatter ms / step | live nodes at end |",
        "|---:|---|---:|---:|---:|---:|---:|",
    ]
    for m in (7, 1_000, 10_000, 100_000):
        for layout in TreeLayout:
            static, allocated, visits, seconds, live = run(layout, m, steps)
            lines.append(
                f"| {m} | {layout.value} | {static} | {allocated:.0f} | {visits:.2f} | "
                f"{seconds * 1e3:.2f} | {live} |"
            )
    sys.stdout.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
