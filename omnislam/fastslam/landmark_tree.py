"""The shared landmark tree of FastSLAM (thesis sec. 4.4.1.3; Montemerlo 2003 sec. 3.3.5).

Each particle's map is a persistent balanced binary tree over the landmark slots; particles
share every subtree they have not changed since a common ancestor, so resampling copies P root
indices instead of P maps, and an update costs O(log M) new nodes (path copying).

Because slots mean the same landmark in every particle, all trees have the same *shape*: a
slot's path from the root is a function of its index only. Node payloads therefore live in flat
arrays (mean (C, d), cov (C, d, d), ...), with child indices (C, 2) and one root index per
particle, and all particles' paths are walked together with vectorised gathers, one tree level
at a time.

Two layouts:

* ``TreeLayout.ALL_NODES`` -- the thesis's tree (Fig. 4.10): an estimate in *every* node. Slot s
  sits at heap position s + 1 (root = slot 0, children of position h are 2h and 2h + 1), so its
  path is given by the bits of s + 1 below the leading one, the tree is always balanced and grows
  without rebalancing. (The thesis keeps a binary *search* tree balanced by left rotations of the
  root, because ids arrive in ascending order; heap numbering reaches the same shape, depth
  floor(log2(M)), without rotations.) 7 landmarks take 7 nodes.
* ``TreeLayout.LEAF_ONLY`` -- Montemerlo's tree (Fig. 4.8): estimates only in the leaves of a
  complete tree of height ceil(log2(M)), internal nodes only route. 7 landmarks take 14 nodes;
  growing past a power of two puts a new root on top of every particle's tree.

Copy-on-write without reference counts: each particle holds an *ownership token* and every node
records the token of the particle that created it. A node may be written in place only by the
particle holding its token; anything else is copied first. After resampling, a particle that
was drawn exactly once keeps its token (its nodes are still its own, as the thesis notes: "its
path is already unique to that particle"); every copy of a particle drawn several times gets a
fresh token, so all of its nodes become shared and copy-on-write. Unreachable nodes are reclaimed
by a mark-and-compact pass when the node arrays fill up (amortised O(1) per allocated node).
"""

from __future__ import annotations

from enum import Enum

import numpy as np

from omnislam.fastslam.landmark_store import LandmarkBlock

_NULL = -1
#: token that no particle ever holds (nodes shared from birth)
_SHARED_TOKEN = 0


class TreeLayout(Enum):
    """Where the landmark estimates live in the tree (see the module docstring)."""

    ALL_NODES = "all_nodes"
    LEAF_ONLY = "leaf_only"


class LandmarkTree:
    """``LandmarkStore`` as a persistent binary tree shared between particles."""

    def __init__(
        self,
        n_particles: int,
        dim: int,
        ray_dim: int = 0,
        initial_capacity: int = 64,
        layout: TreeLayout = TreeLayout.ALL_NODES,
    ) -> None:
        """Args:
        n_particles: P.
        dim: landmark dimension d (2 or 3).
        ray_dim: 6 for bearing-only landmarks (stored ray), else 0.
        initial_capacity: node rows allocated up front (grown by doubling).
        layout: the thesis's all-nodes tree or Montemerlo's leaf-only tree.
        """
        self._p = int(n_particles)
        self._dim = int(dim)
        self._ray_dim = int(ray_dim)
        self._layout = layout
        capacity = max(4, int(initial_capacity))
        self._nodes = LandmarkBlock.empty(capacity, self._dim, self._ray_dim)
        self._children = np.full((capacity, 2), _NULL, dtype=np.int64)
        self._token = np.zeros(capacity, dtype=np.int64)
        self._used = 0
        self._roots = np.full(self._p, _NULL, dtype=np.int64)
        self._tokens = np.arange(1, self._p + 1, dtype=np.int64)
        self._next_token = self._p + 1
        self._m = 0
        self._height = 0  # LEAF_ONLY: leaves at this depth, 2**height slots addressable
        #: cumulative number of nodes created (the thesis's memory argument)
        self.nodes_allocated = 0
        #: cumulative number of nodes visited by gather and scatter (its time argument)
        self.node_visits = 0

    # -- sizes --------------------------------------------------------------------------------

    @property
    def n_particles(self) -> int:
        return self._p

    @property
    def n_landmarks(self) -> int:
        return self._m

    @property
    def layout(self) -> TreeLayout:
        return self._layout

    @property
    def nodes_in_use(self) -> int:
        """Node rows in use (live nodes plus garbage not yet reclaimed)."""
        return self._used

    @property
    def memory_bytes(self) -> int:
        n = self._nodes
        arrays = (n.mean, n.cov, n.status, n.existence, n.ray, self._children, self._token)
        return int(sum(a.nbytes for a in arrays) + self._roots.nbytes + self._tokens.nbytes)

    def live_nodes(self) -> int:
        """Number of nodes reachable from some particle's root."""
        return int(self._mark().sum())

    # -- paths ----------------------------------------------------------------------------------

    def _paths(self, slots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Path key and depth of each slot: the bits of ``key`` below ``depth`` steer left/right.

        ALL_NODES: key = slot + 1 (heap position), depth = floor(log2(key)).
        LEAF_ONLY: key = slot, depth = tree height.
        """
        slots = np.asarray(slots, dtype=np.int64)
        if self._layout is TreeLayout.ALL_NODES:
            key = slots + 1
            depth = np.frexp(key.astype(float))[1].astype(np.int64) - 1
            return key, depth
        return slots, np.full(slots.shape, self._height, dtype=np.int64)

    # -- the LandmarkStore protocol -----------------------------------------------------------

    def add_landmarks(self, count: int) -> np.ndarray:
        """Append ``count`` slots, absent everywhere.

        ALL_NODES: free (absent nodes are null children). LEAF_ONLY: when M passes a power of
        two, every distinct root gets new routing nodes above it.
        """
        new_m = self._m + int(count)
        slots = np.arange(self._m, new_m)
        self._m = new_m
        if self._layout is TreeLayout.LEAF_ONLY:
            height = max(0, int(np.ceil(np.log2(max(new_m, 1)))))
            grow = height - self._height
            if grow > 0:
                self._height = height
                present = self._roots >= 0
                if np.any(present):
                    unique_roots, inverse = np.unique(self._roots[present], return_inverse=True)
                    self._reserve(grow * unique_roots.size)
                    current = unique_roots
                    for _ in range(grow):
                        new = self._allocate(current.size)
                        self._clear(new)
                        self._children[new, 0] = current
                        self._token[new] = _SHARED_TOKEN
                        current = new
                    self._roots[present] = current[inverse]
        return slots

    def gather(self, particles: np.ndarray, slots: np.ndarray) -> LandmarkBlock:
        """Walk all N paths level by level with vectorised child lookups."""
        particles = np.asarray(particles, dtype=np.int64)
        key, depth = self._paths(slots)
        node = self._find(particles, key, depth)
        self.node_visits += int((depth + 1).sum())
        found = node >= 0
        block = self._nodes.take(np.maximum(node, 0))
        if not found.all():
            missing = ~found
            block.mean[missing] = 0.0
            block.cov[missing] = 0.0
            block.status[missing] = 0
            block.existence[missing] = 0
            block.ray[missing] = 0.0
        return block

    def _find(self, particles: np.ndarray, key: np.ndarray, depth: np.ndarray) -> np.ndarray:
        node = self._roots[particles]
        max_depth = int(depth.max(initial=0))
        for level in range(1, max_depth + 1):
            deeper = depth >= level
            bit = (key >> np.maximum(depth - level, 0)) & 1
            child = self._children[np.maximum(node, 0), bit]
            node = np.where(deeper, np.where(node >= 0, child, _NULL), node)
        return node

    def scatter(self, particles: np.ndarray, slots: np.ndarray, block: LandmarkBlock) -> None:
        """Path copying: every node on the N paths not owned by the writing particle is copied,
        level by level (pairs of one particle share the copies of their common prefix)."""
        particles = np.asarray(particles, dtype=np.int64)
        n = particles.shape[0]
        if n == 0:
            return
        key, depth = self._paths(slots)
        max_depth = int(depth.max(initial=0))
        self._reserve(n * (max_depth + 1))
        self.node_visits += int((depth + 1).sum())

        # level 0: one root per writing particle
        copies: list[tuple[np.ndarray, np.ndarray]] = []
        writers, inverse = np.unique(particles, return_inverse=True)
        roots = self._roots[writers]
        roots = self._own(roots, self._tokens[writers], copies)
        self._roots[writers] = roots
        current = roots[inverse]

        shift = np.int64(max_depth + 1)
        for level in range(1, max_depth + 1):
            active = np.flatnonzero(depth >= level)
            prefix = key[active] >> (depth[active] - level)
            _, first, inverse = np.unique(
                (particles[active] << shift) | prefix, return_index=True, return_inverse=True
            )
            heads = active[first]
            parent = current[heads]
            bit = prefix[first] & 1
            child = self._own(self._children[parent, bit], self._tokens[particles[heads]], copies)
            self._children[parent, bit] = child
            current[active] = child[inverse]
        if copies:  # one batched payload copy for every node copied on the paths
            source = np.concatenate([c[0] for c in copies])
            target = np.concatenate([c[1] for c in copies])
            payload = self._nodes.take(np.maximum(source, 0))
            absent = source < 0
            if absent.any():
                payload.mean[absent] = 0.0
                payload.cov[absent] = 0.0
                payload.status[absent] = 0
                payload.existence[absent] = 0
                payload.ray[absent] = 0.0
            self._nodes.put(target, payload)
        self._nodes.put(current, block)

    def _own(
        self, nodes: np.ndarray, tokens: np.ndarray, copies: list[tuple[np.ndarray, np.ndarray]]
    ) -> np.ndarray:
        """Nodes writable by the particles holding ``tokens``: copies of the ones they do not
        own, new absent nodes for null ones (capacity must have been reserved).

        Child pointers are copied at once (the walk needs them); the payload copies are
        appended to ``copies`` as (source, target) and done in one batch by the caller.
        """
        owned = (nodes >= 0) & (self._token[np.maximum(nodes, 0)] == tokens)
        need = np.flatnonzero(~owned)
        if need.size == 0:
            return nodes
        source = nodes[need]
        new = self._allocate(need.size)
        exists = source >= 0
        self._children[new] = np.where(
            exists[:, None], self._children[np.maximum(source, 0)], _NULL
        )
        self._token[new] = tokens[need]
        copies.append((source, new))
        out = nodes.copy()
        out[need] = new
        return out

    def resample(self, ancestors: np.ndarray) -> None:
        """O(P): particle i takes old particle ancestors[i]'s root; see the module docstring
        for how ownership tokens are handed on."""
        ancestors = np.asarray(ancestors, dtype=np.int64)
        counts = np.bincount(ancestors, minlength=self._p)
        self._roots = self._roots[ancestors]
        single = counts[ancestors] == 1
        tokens = np.empty(self._p, dtype=np.int64)
        tokens[single] = self._tokens[ancestors[single]]
        fresh = int((~single).sum())
        tokens[~single] = self._next_token + np.arange(fresh)
        self._next_token += fresh
        self._tokens = tokens

    def particle_map(self, particle: int) -> LandmarkBlock:
        slots = np.arange(self._m)
        return self.gather(np.full(self._m, int(particle)), slots)

    # -- node memory --------------------------------------------------------------------------

    def _allocate(self, count: int) -> np.ndarray:
        new = np.arange(self._used, self._used + count)
        self._used += count
        self.nodes_allocated += count
        return new

    def _clear(self, nodes: np.ndarray) -> None:
        self._nodes.mean[nodes] = 0.0
        self._nodes.cov[nodes] = 0.0
        self._nodes.status[nodes] = 0
        self._nodes.existence[nodes] = 0
        self._nodes.ray[nodes] = 0.0
        self._children[nodes] = _NULL

    def _copy(self, source: np.ndarray, target: np.ndarray) -> None:
        self._nodes.put(target, self._nodes.take(source))
        self._children[target] = self._children[source]

    def _capacity(self) -> int:
        return int(self._children.shape[0])

    def _reserve(self, count: int) -> None:
        """Make room for ``count`` new nodes: mark-and-compact first, grow if still over half
        full (so reclaiming stays amortised O(1) per node)."""
        if self._used + count <= self._capacity():
            return
        self.collect_garbage()
        if self._used + count > self._capacity() // 2:
            self._grow(max(2 * self._capacity(), 2 * (self._used + count)))

    def _mark(self) -> np.ndarray:
        marked = np.zeros(self._used, dtype=bool)
        frontier = np.unique(self._roots[self._roots >= 0])
        while frontier.size:
            marked[frontier] = True
            children = self._children[frontier].ravel()
            children = children[children >= 0]
            frontier = np.unique(children[~marked[children]])
        return marked

    def collect_garbage(self) -> int:
        """Mark the nodes reachable from the roots and compact them to the front.

        Returns:
            the number of nodes reclaimed.
        """
        live = np.flatnonzero(self._mark())
        reclaimed = self._used - live.size
        if reclaimed == 0:
            return 0
        remap = np.full(self._used, _NULL, dtype=np.int64)
        remap[live] = np.arange(live.size)
        n = live.size
        self._nodes.put(np.arange(n), self._nodes.take(live))
        children = self._children[live]
        self._children[:n] = np.where(children >= 0, remap[np.maximum(children, 0)], _NULL)
        self._token[:n] = self._token[live]
        self._roots = np.where(self._roots >= 0, remap[np.maximum(self._roots, 0)], _NULL)
        self._used = n
        return int(reclaimed)

    def _grow(self, capacity: int) -> None:
        used = self._used
        nodes = LandmarkBlock.empty(capacity, self._dim, self._ray_dim)
        nodes.put(np.arange(used), self._nodes.take(np.arange(used)))
        children = np.full((capacity, 2), _NULL, dtype=np.int64)
        children[:used] = self._children[:used]
        token = np.zeros(capacity, dtype=np.int64)
        token[:used] = self._token[:used]
        self._nodes, self._children, self._token = nodes, children, token
