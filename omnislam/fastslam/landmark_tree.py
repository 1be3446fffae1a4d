"""The shared landmark tree of FastSLAM (thesis sec. 4.4.1.3; Montemerlo 2003 sec. 3.3.5).

Each particle's map is a persistent balanced binary tree over the landmark slots; particles
share every subtree they have not changed since a common ancestor, so resampling copies P root
indices instead of P maps, and an update costs O(log M) new nodes (path copying).

Because slots mean the same landmark in every particle, all trees have the same *shape*: a
slot's path from the root is a function of its index only. Node payloads therefore live in flat
arrays (mean (C, d), cov (C, d, d), ...), with child indices (C, 2) and one root index per
particle, and all particles' paths are walked together with vectorised gathers, one tree level
at a time. Row 0 is a null node (absent payload, itself as both children) that stands for every
absent subtree, so walks and copies need no special case for missing nodes.

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
by a mark-and-sweep pass into a free list when the node arrays fill up; live nodes never move,
and the arrays double when over half of them is live, so reclaiming costs amortised O(1) per
allocated node.
"""

from __future__ import annotations

from enum import Enum

import numpy as np

from omnislam.fastslam.landmark_store import LandmarkBlock

#: row 0 is the null node: absent payload (zeros), both children itself, never written
_NULL = 0
#: token that no particle ever holds (nodes shared from birth, and the null node)
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
        self._used = 1  # rows ever handed out, the null node included
        self._free = np.zeros(0, dtype=np.int64)  # reclaimed rows below _used, ascending
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
        """Node rows in use (live nodes plus garbage not yet reclaimed; the null node aside)."""
        return self._used - 1 - self._free.size

    @property
    def memory_bytes(self) -> int:
        n = self._nodes
        arrays = (n.mean, n.cov, n.status, n.existence, n.ray, self._children, self._token)
        return int(sum(a.nbytes for a in arrays) + self._roots.nbytes + self._tokens.nbytes)

    def live_nodes(self) -> int:
        """Number of nodes reachable from some particle's root (the null node aside)."""
        return int(self._mark().sum()) - 1

    # -- paths ----------------------------------------------------------------------------------

    def _paths(self, slots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Heap position and depth of each slot's node: the bits of ``key`` below its leading
        one, read from the top, steer left (0) / right (1) from the root.

        ALL_NODES: key = slot + 1, depth = floor(log2(key)).
        LEAF_ONLY: key = slot + 2**height (the leaves of the complete tree), depth = height.
        """
        slots = np.asarray(slots, dtype=np.int64)
        if self._layout is TreeLayout.ALL_NODES:
            key = slots + 1
            depth = np.frexp(key.astype(float))[1].astype(np.int64) - 1
            return key, depth
        return slots + (1 << self._height), np.full(slots.shape, self._height, dtype=np.int64)

    def _walk(self, roots: np.ndarray, prefixes: np.ndarray) -> np.ndarray:
        """Nodes (L, N) met by N walks that start at ``roots`` and follow the heap positions
        ``prefixes`` (L, N) one level per row (vectorised child lookups, one per level).

        The null node is its own child, so a walk that leaves the tree stays on it.
        """
        nodes = np.empty(prefixes.shape, dtype=np.int64)
        nodes[0] = roots
        flat = self._children.reshape(-1)
        for level in range(1, prefixes.shape[0]):
            np.take(flat, 2 * nodes[level - 1] + (prefixes[level] & 1), out=nodes[level])
        return nodes

    @staticmethod
    def _prefixes(key: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """(L, N) heap positions of the ancestors of each key at levels 0..L-1, L = max depth +
        1; past its own depth a key's row continues along left children (never used as a
        path node, see ``scatter``)."""
        max_depth = int(depth.max(initial=0))
        aligned = key << (max_depth - depth)
        return aligned[None, :] >> np.arange(max_depth, -1, -1, dtype=np.int64)[:, None]

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
                present = self._roots != _NULL
                if np.any(present):
                    self._reserve(grow * int(np.count_nonzero(present)))
                    unique_roots, inverse = np.unique(self._roots[present], return_inverse=True)
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
        """Walk all N paths level by level with vectorised child lookups (absent slots end on
        the null node, whose payload is all zeros)."""
        particles = np.asarray(particles, dtype=np.int64)
        key, depth = self._paths(slots)
        self.node_visits += int((depth + 1).sum())
        nodes = self._walk(self._roots[particles], self._prefixes(key, depth))
        return self._nodes.take(nodes[depth, np.arange(depth.size)])

    def scatter(self, particles: np.ndarray, slots: np.ndarray, block: LandmarkBlock) -> None:
        """Path copying: every node on the N paths not owned by the writing particle is copied
        once (pairs of one particle share the copies of their common prefix).

        With the pairs sorted by (particle, left-aligned key), the pairs that pass through one
        node of one particle's tree at level l form a run; the last pair of a run reaches that
        level iff any does (shallower keys sort first among equal aligned keys), so it
        represents the node. All levels are decided at once on (L, N) arrays; only the walk
        is a loop over levels.
        """
        particles = np.asarray(particles, dtype=np.int64)
        n = particles.shape[0]
        if n == 0:
            return
        key, depth = self._paths(slots)
        self.node_visits += int((depth + 1).sum())
        max_depth = int(depth.max(initial=0))
        order = np.lexsort((depth, key << (max_depth - depth), particles))
        who, key, depth = particles[order], key[order], depth[order]
        prefixes = self._prefixes(key, depth)  # (L, N)
        levels = np.arange(max_depth + 1)[:, None]
        last = np.ones(prefixes.shape, dtype=bool)  # last pair of its run, per level
        last[:, :-1] = (prefixes[:, 1:] != prefixes[:, :-1]) | (who[1:] != who[:-1])
        on_path = levels <= depth
        represents = last & on_path
        self._reserve(int(np.count_nonzero(represents)))

        nodes = self._walk(self._roots[who], prefixes)
        tokens = self._tokens[who]
        copy = represents & (self._token[nodes] != tokens)
        level, pair = np.nonzero(copy)
        source = nodes[copy]
        new = self._allocate(source.size)
        self._children[new] = self._children[source]
        self._token[new] = tokens[pair]
        self._nodes.put(new, self._nodes.take(source))
        nodes[copy] = new

        # every pair's node at each level is its run's representative
        column = np.where(last, np.arange(n), n)
        run_end = np.minimum.accumulate(column[:, ::-1], axis=1)[:, ::-1]
        linked = level > 0
        child_level, child_pair = level[linked], pair[linked]
        parent = nodes[child_level - 1, run_end[child_level - 1, child_pair]]
        flat = self._children.reshape(-1)
        flat[2 * parent + (prefixes[child_level, child_pair] & 1)] = new[linked]
        self._roots[who[pair[~linked]]] = new[~linked]

        target = np.empty(n, dtype=np.int64)
        target[order] = nodes[depth, run_end[depth, np.arange(n)]]
        self._nodes.put(target, block)

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
        """``count`` rows for new nodes: reclaimed rows first, then fresh ones (capacity must
        have been reserved)."""
        reused = self._free[:count]
        self._free = self._free[reused.size :]
        fresh = count - reused.size
        new = np.concatenate([reused, np.arange(self._used, self._used + fresh)])
        self._used += fresh
        self.nodes_allocated += count
        return new

    def _clear(self, nodes: np.ndarray) -> None:
        self._nodes.mean[nodes] = 0.0
        self._nodes.cov[nodes] = 0.0
        self._nodes.status[nodes] = 0
        self._nodes.existence[nodes] = 0
        self._nodes.ray[nodes] = 0.0
        self._children[nodes] = _NULL

    def _capacity(self) -> int:
        return int(self._children.shape[0])

    def _reserve(self, count: int) -> None:
        """Make room for ``count`` new nodes: mark-and-sweep first, grow if still over half
        full (so reclaiming stays amortised O(1) per node)."""
        if count <= self._capacity() - self._used + self._free.size:
            return
        self.collect_garbage()
        needed = self._used - self._free.size + count
        if needed > self._capacity() // 2:
            self._grow(max(2 * self._capacity(), 2 * needed))

    def _mark(self) -> np.ndarray:
        """Reachable rows, one tree level per iteration; a node met several times in one level
        (shared by several parents) is kept once without sorting: each occurrence stamps its
        position and only the occurrence whose stamp survived goes on."""
        marked = np.zeros(self._used, dtype=bool)
        marked[_NULL] = True
        stamp = np.empty(self._used, dtype=np.int64)
        frontier = self._roots[~marked[self._roots]]
        while frontier.size:
            position = np.arange(frontier.size)
            stamp[frontier] = position
            frontier = frontier[stamp[frontier] == position]
            marked[frontier] = True
            children = self._children[frontier].reshape(-1)
            frontier = children[~marked[children]]
        return marked

    def collect_garbage(self) -> int:
        """Mark the nodes reachable from the roots and put every other row on the free list
        (nodes do not move, so no pointer needs rewriting).

        Returns:
            the number of nodes reclaimed.
        """
        free = np.flatnonzero(~self._mark())
        reclaimed = free.size - self._free.size
        self._free = free
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
