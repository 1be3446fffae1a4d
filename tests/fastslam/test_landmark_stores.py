"""Both landmark stores: value semantics (map independence), equivalence, node counts."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.fastslam.dense_store import DenseLandmarkStore
from omnislam.fastslam.landmark_store import LandmarkBlock, LandmarkStatus, LandmarkStore
from omnislam.fastslam.landmark_tree import LandmarkTree, TreeLayout

STORES = {
    "tree": lambda p, d, r=0: LandmarkTree(p, d, r, initial_capacity=4),
    "leaf_tree": lambda p, d, r=0: LandmarkTree(
        p, d, r, initial_capacity=4, layout=TreeLayout.LEAF_ONLY
    ),
    "dense": lambda p, d, r=0: DenseLandmarkStore(p, d, r, initial_capacity=2),
}


def _block(values: np.ndarray, dim: int = 2) -> LandmarkBlock:
    n = len(values)
    block = LandmarkBlock.empty(n, dim, 0)
    block.mean[:] = values[:, None]
    block.cov[:] = np.eye(dim) * values[:, None, None]
    block.status[:] = LandmarkStatus.ESTIMATED
    block.existence[:] = 1
    return block


@pytest.mark.parametrize("kind", STORES)
def test_store_satisfies_protocol(kind):
    assert isinstance(STORES[kind](3, 2), LandmarkStore)


@pytest.mark.parametrize("kind", STORES)
def test_unwritten_slots_are_absent(kind):
    store = STORES[kind](3, 2)
    store.add_landmarks(5)
    block = store.gather(np.array([0, 2]), np.array([4, 1]))
    assert np.all(block.status == LandmarkStatus.ABSENT)
    assert np.all(block.mean == 0)


@pytest.mark.parametrize("kind", STORES)
def test_map_independence_after_resampling(kind):
    """After resampling, updating one particle's landmark leaves every other copy unchanged
    (the PythonRobotics resampler fails this: its particles alias one landmark array)."""
    p, m = 6, 11
    store = STORES[kind](p, 2)
    store.add_landmarks(m)
    rng = np.random.default_rng(3)
    everything_p = np.repeat(np.arange(p), m)
    everything_s = np.tile(np.arange(m), p)
    store.scatter(everything_p, everything_s, _block(rng.random(p * m)))
    store.resample(np.array([2, 2, 2, 5, 5, 0]))  # 0, 1, 2 share particle 2's map
    before = store.gather(everything_p, everything_s)
    store.scatter(np.array([1]), np.array([7]), _block(np.array([42.0])))
    after = store.gather(everything_p, everything_s)
    changed = np.flatnonzero(np.any(after.mean != before.mean, axis=1))
    np.testing.assert_array_equal(changed, [1 * m + 7])
    assert after.mean[1 * m + 7, 0] == 42.0
    # the siblings that shared the map still hold the old value
    assert after.mean[0 * m + 7, 0] == after.mean[2 * m + 7, 0] == before.mean[2 * m + 7, 0]
    # and writing a sibling afterwards does not leak back
    store.scatter(np.array([2]), np.array([7]), _block(np.array([-1.0])))
    assert store.gather(np.array([1, 0]), np.array([7, 7])).mean[:, 0].tolist() == [
        42.0,
        before.mean[7, 0],
    ]


@pytest.mark.parametrize("kind", ["tree", "leaf_tree"])
def test_tree_matches_dense_on_random_operations(kind):
    """Random interleaved scatters, resamplings and growth: the tree equals the dense oracle."""
    rng = np.random.default_rng(11)
    p = 8
    tree, dense = STORES[kind](p, 2), STORES["dense"](p, 2)
    for store in (tree, dense):
        store.add_landmarks(3)
    for step in range(60):
        if step % 7 == 3:
            grow = int(rng.integers(1, 6))
            tree.add_landmarks(grow)
            dense.add_landmarks(grow)
        m = dense.n_landmarks
        n = int(rng.integers(1, p * m))
        flat = rng.choice(p * m, size=n, replace=False)
        who, slots = flat // m, flat % m
        block = _block(rng.random(n))
        tree.scatter(who, slots, block)
        dense.scatter(who, slots, block)
        if step % 3 == 0:
            ancestors = np.sort(rng.integers(0, p, size=p))
            tree.resample(ancestors)
            dense.resample(ancestors)
    for particle in range(p):
        a, b = tree.particle_map(particle), dense.particle_map(particle)
        np.testing.assert_array_equal(a.mean, b.mean)
        np.testing.assert_array_equal(a.cov, b.cov)
        np.testing.assert_array_equal(a.status, b.status)


def test_garbage_collection_reclaims_unreachable_nodes_and_keeps_maps():
    rng = np.random.default_rng(5)
    p, m = 10, 50
    tree = LandmarkTree(p, 2, initial_capacity=8)
    dense = DenseLandmarkStore(p, 2)
    tree.add_landmarks(m)
    dense.add_landmarks(m)
    for _ in range(40):
        who = np.arange(p)
        slots = rng.integers(0, m, size=p)
        block = _block(rng.random(p))
        tree.scatter(who, slots, block)
        dense.scatter(who, slots, block)
        ancestors = np.sort(rng.integers(0, p, size=p))
        tree.resample(ancestors)
        dense.resample(ancestors)
    used = tree.nodes_in_use
    reclaimed = tree.collect_garbage()
    assert reclaimed > 0
    assert tree.nodes_in_use == used - reclaimed == tree.live_nodes()
    for particle in range(p):
        np.testing.assert_array_equal(
            tree.particle_map(particle).mean, dense.particle_map(particle).mean
        )


def _figure_4_10(layout: TreeLayout) -> LandmarkTree:
    """Seven landmarks of one particle, then a second particle sharing the tree."""
    tree = LandmarkTree(1, 2, layout=layout)
    tree.add_landmarks(7)
    tree.scatter(np.zeros(7, dtype=int), np.arange(7), _block(np.arange(1.0, 8.0)))
    return tree


def test_thesis_figure_4_10_node_counts():
    """Thesis Fig. 4.10: the all-nodes tree stores 7 landmarks in 7 nodes, the leaf-only tree
    needs 14; updating landmarks 2 and 7 copies 4 nodes instead of 7 ("three more nodes")."""
    counts = {}
    for layout in TreeLayout:
        tree = _figure_4_10(layout)
        static = tree.live_nodes()
        tree_2 = LandmarkTree(2, 2, layout=layout)
        tree_2.add_landmarks(7)
        tree_2.scatter(np.zeros(7, dtype=int), np.arange(7), _block(np.arange(1.0, 8.0)))
        tree_2.resample(np.array([0, 0]))
        before = tree_2.nodes_allocated
        tree_2.scatter(np.array([1, 1]), np.array([1, 6]), _block(np.array([20.0, 70.0])))
        counts[layout] = (static, tree_2.nodes_allocated - before)
    assert counts[TreeLayout.ALL_NODES] == (7, 4)
    assert counts[TreeLayout.LEAF_ONLY] == (14, 7)


def test_tree_update_cost_is_logarithmic():
    """One update in a 100k-landmark tree copies depth + 1 = 17 nodes, not the map."""
    tree = LandmarkTree(4, 2, initial_capacity=16)
    tree.add_landmarks(100_000)
    tree.resample(np.zeros(4, dtype=int))
    before = tree.nodes_allocated
    tree.scatter(np.array([3]), np.array([99_999]), _block(np.array([1.0])))
    assert tree.nodes_allocated - before == int(np.floor(np.log2(100_000))) + 1


def test_reclamation_keeps_memory_bounded_over_many_steps():
    """Node and payload rows are reused after mark-and-sweep: the tables stop growing once the
    live map is steady, and the maps stay equal to the dense oracle."""
    rng = np.random.default_rng(8)
    p, m = 10, 40
    tree = LandmarkTree(p, 2, initial_capacity=8)
    dense = DenseLandmarkStore(p, 2)
    tree.add_landmarks(m)
    dense.add_landmarks(m)
    memory = []
    for step in range(400):
        who = np.repeat(np.arange(p), 3)
        slots = np.concatenate([rng.choice(m, 3, replace=False) for _ in range(p)])
        block = _block(rng.random(who.size))
        tree.scatter(who, slots, block)
        dense.scatter(who, slots, block)
        ancestors = np.sort(rng.integers(0, p, size=p))
        tree.resample(ancestors)
        dense.resample(ancestors)
        if step in (199, 399):
            memory.append(tree.memory_bytes)
    assert memory[1] == memory[0]
    assert tree.live_nodes() <= p * m
    for particle in range(p):
        np.testing.assert_array_equal(
            tree.particle_map(particle).mean, dense.particle_map(particle).mean
        )
