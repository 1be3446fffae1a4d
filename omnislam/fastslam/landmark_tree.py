"""The shared landmark tree of FastSLAM (thesis sec. 4.4.1.3; Montemerlo 2003 sec. 3.3.5).

Each particle's map is a persistent balanced binary tree over the landmark slots; particles
share every subtree they have not changed since a common ancestor, so resampling copies P root
indices instead of P maps, and an update costs O(log M) new nodes (path copying).

Because slots mean the same landmark in every particle, all trees have the same *shape*: a
slot's path from the root is a function of its index only. Nodes therefore live in one flat
table of int64 rows [left child, right child, owner token, payload row] with one root index per
particle, and all particles' paths are walked together with vectorised gathers, one tree level
at a time. Row 0 is a null node (both children itself, payload row 0 = absent) that stands for
every absent subtree, so walks and copies need no special case for missing nodes.

The landmark estimates (mean (Q, d), cov (Q, d, d), ...) live in a separate payload table that
nodes point into: a copied node shares its source's payload row, and a write gives the written
node a fresh payload row. Path copying thus moves 32 bytes per copied node whatever the
landmark's size, and the payload is moved only where it changes.

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
fresh token, so all of its nodes become shared and copy-on-write. Unreachable nodes and payload
rows are reclaimed by a mark-and-sweep pass into free lists when a table fills up; live rows
never move, and a table doubles when over half of it is live, so reclaiming costs amortised
O(1) per allocated row.
"""

from __future__ import annotations

import math
from enum import Enum

import numpy as np

from omnislam.fastslam.landmark_store import LandmarkBlock

#: row 0 of both tables: the null node (children itself) and the absent payload (zeros)
_NULL = 0
#: token that no particle ever holds (nodes shared from birth, and the null node)
_SHARED_TOKEN = 0
#: columns of the node table
_LEFT, _TOKEN, _PAYLOAD = 0, 2, 3
_COLUMNS = 4


def _fields(block: LandmarkBlock) -> tuple[np.ndarray, ...]:
    """The fields of a block as (N, width) views, the layout of ``kernels.take_rows``."""
    fields = (block.mean, block.cov, block.status, block.existence, block.ray)
    return tuple(field.reshape(len(block), math.prod(field.shape[1:])) for field in fields)


class _Rows:
    """Row allocation of one growable table: reclaimed rows first, then never used ones.

    Row 0 (the null node / absent payload) is never handed out.
    """

    def __init__(self) -> None:
        self.used = 1  # rows ever handed out, row 0 included
        self.free = np.zeros(0, dtype=np.int64)  # reclaimed rows below ``used``, ascending

    @property
    def in_use(self) -> int:
        """Rows holding live data or garbage not yet reclaimed, row 0 included."""
        return self.used - self.free.size

    def available(self, capacity: int) -> int:
        return capacity - self.used + self.free.size

    def allocate(self, count: int) -> np.ndarray:
        reused = self.free[:count]
        self.free = self.free[reused.size :]
        fresh = count - reused.size
        rows = np.concatenate([reused, np.arange(self.used, self.used + fresh)])
        self.used += fresh
        return rows

    def sweep(self, live: np.ndarray) -> int:
        """Put every row not marked in ``live`` (used,) on the free list; returns how many
        rows that reclaimed."""
        free = np.flatnonzero(~live)
        reclaimed = free.size - self.free.size
        self.free = free
        return int(reclaimed)


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
        kernels: object | None = None,
    ) -> None:
        """Args:
        n_particles: P.
        dim: landmark dimension d (2 or 3).
        ray_dim: 6 for bearing-only landmarks (stored ray), else 0.
        initial_capacity: node rows allocated up front (grown by doubling; the payload table
            starts at a quarter of it).
        layout: the thesis's all-nodes tree or Montemerlo's leaf-only tree.
        kernels: the compiled kernels (``kernels.compiled()``) to walk and copy paths with, or
            None for the vectorised numpy walks (the reference): the same maps either way.
        """
        self._kernels = kernels
        self._p = int(n_particles)
        self._dim = int(dim)
        self._ray_dim = int(ray_dim)
        self._layout = layout
        capacity = max(4, int(initial_capacity))
        self._links = np.zeros((capacity, _COLUMNS), dtype=np.int64)
        self._node_rows = _Rows()
        self._payload = LandmarkBlock.empty(max(4, capacity // 4), self._dim, self._ray_dim)
        self._payload_rows = _Rows()
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
        return self._node_rows.in_use - 1

    @property
    def memory_bytes(self) -> int:
        n = self._payload
        arrays = (n.mean, n.cov, n.status, n.existence, n.ray, self._links)
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
        flat = self._links.reshape(-1)
        for level in range(1, prefixes.shape[0]):
            index = _COLUMNS * nodes[level - 1] + (prefixes[level] & 1)
            np.take(flat, index, out=nodes[level])
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
                    self._reserve(grow * int(np.count_nonzero(present)), 0)
                    unique_roots, inverse = np.unique(self._roots[present], return_inverse=True)
                    current = unique_roots
                    for _ in range(grow):
                        new = self._allocate(current.size)
                        self._links[new] = [_NULL, _NULL, _SHARED_TOKEN, _NULL]
                        self._links[new, _LEFT] = current
                        current = new
                    self._roots[present] = current[inverse]
        return slots

    def gather(self, particles: np.ndarray, slots: np.ndarray) -> LandmarkBlock:
        """Walk all N paths level by level with vectorised child lookups (absent slots end on
        the null node, whose payload row is all zeros)."""
        particles = np.asarray(particles, dtype=np.int64)
        if self._kernels is not None:
            rows, visits = self._kernels.tree_rows(
                self._links,
                self._roots,
                particles,
                np.asarray(slots, dtype=np.int64),
                self._leaf_height(),
            )
            self.node_visits += int(visits)
            return self._take_compiled(rows)
        key, depth = self._paths(slots)
        self.node_visits += int((depth + 1).sum())
        nodes = self._walk(self._roots[particles], self._prefixes(key, depth))
        return self._payload.take(self._links[nodes[depth, np.arange(depth.size)], _PAYLOAD])

    def scatter(self, particles: np.ndarray, slots: np.ndarray, block: LandmarkBlock) -> None:
        """Path copying: every node on the N paths not owned by the writing particle is copied
        once (pairs of one particle share the copies of their common prefix), then each
        written node gets a fresh payload row.

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
        if self._kernels is not None:
            self._scatter_compiled(particles, np.asarray(slots, dtype=np.int64), block)
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
        represents = last & (levels <= depth)
        self._reserve(int(np.count_nonzero(represents)), n)

        nodes = self._walk(self._roots[who], prefixes)
        tokens = self._tokens[who]
        copy = represents & (self._links[nodes, _TOKEN] != tokens)
        level, pair = np.nonzero(copy)
        new = self._allocate(level.size)
        copied = self._links[nodes[copy]]
        copied[:, _TOKEN] = tokens[pair]
        self._links[new] = copied
        nodes[copy] = new

        # every pair's node at each level is its run's representative
        column = np.where(last, np.arange(n), n)
        run_end = np.minimum.accumulate(column[:, ::-1], axis=1)[:, ::-1]
        linked = level > 0
        child_level, child_pair = level[linked], pair[linked]
        parent = nodes[child_level - 1, run_end[child_level - 1, child_pair]]
        flat = self._links.reshape(-1)
        flat[_COLUMNS * parent + (prefixes[child_level, child_pair] & 1)] = new[linked]
        self._roots[who[pair[~linked]]] = new[~linked]

        rows = self._payload_rows.allocate(n)
        self._payload.put(rows, block)
        target = nodes[depth, run_end[depth, np.arange(n)]]
        self._links[target, _PAYLOAD] = rows[order]

    def _leaf_height(self) -> int:
        """The leaf-only tree's height, -1 for the all-nodes tree (the kernels' layout flag)."""
        return self._height if self._layout is TreeLayout.LEAF_ONLY else -1

    def _scatter_compiled(
        self, particles: np.ndarray, slots: np.ndarray, block: LandmarkBlock
    ) -> None:
        """``scatter`` by ``kernels.tree_scatter``: one walk per pair, copying the nodes the
        particle does not own. Room is reserved for one new node per level of every pair, but
        never more than a whole tree of that height per writing particle."""
        n = particles.shape[0]
        if self._layout is TreeLayout.ALL_NODES:
            levels = int(int(slots.max()) + 1).bit_length()
        else:
            levels = self._height + 1
        writers = int(np.count_nonzero(np.bincount(particles)))
        self._reserve(min(n * levels, writers * ((1 << levels) - 1)), n)
        nodes, payloads = self._node_rows, self._payload_rows
        rows, node_taken, node_used, payload_taken, payload_used, copies, visits = (
            self._kernels.tree_scatter(
                self._links,
                self._roots,
                self._tokens,
                particles,
                slots,
                self._leaf_height(),
                nodes.free,
                nodes.used,
                payloads.free,
                payloads.used,
            )
        )
        nodes.free, nodes.used = nodes.free[node_taken:], int(node_used)
        payloads.free, payloads.used = payloads.free[payload_taken:], int(payload_used)
        self.nodes_allocated += int(copies)
        self.node_visits += int(visits)
        for table, written in zip(_fields(self._payload), _fields(block), strict=True):
            self._kernels.put_rows(table, rows, written)

    def _take_compiled(self, rows: np.ndarray) -> LandmarkBlock:
        """``self._payload.take(rows)`` by ``kernels.take_rows``, field by field (into
        uninitialised arrays: every entry is written)."""
        n, d, payload = rows.size, self._dim, self._payload
        block = LandmarkBlock(
            np.empty((n, d)),
            np.empty((n, d, d)),
            np.empty(n, dtype=payload.status.dtype),
            np.empty(n, dtype=payload.existence.dtype),
            np.empty((n, self._ray_dim)),
        )
        for table, out in zip(_fields(self._payload), _fields(block), strict=True):
            self._kernels.take_rows(table, rows, out)
        return block

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
        """Rows for ``count`` new nodes (capacity must have been reserved)."""
        self.nodes_allocated += count
        return self._node_rows.allocate(count)

    def _reserve(self, nodes: int, payloads: int) -> None:
        """Make room for new nodes and payload rows: mark-and-sweep first, then grow each
        table that is still over half full (so reclaiming stays amortised O(1) per row)."""
        node_capacity, payload_capacity = self._links.shape[0], len(self._payload)
        if nodes <= self._node_rows.available(
            node_capacity
        ) and payloads <= self._payload_rows.available(payload_capacity):
            return
        self.collect_garbage()
        needed = self._node_rows.in_use + nodes
        if needed > node_capacity // 2:
            links = np.zeros((max(2 * node_capacity, 2 * needed), _COLUMNS), dtype=np.int64)
            links[: self._node_rows.used] = self._links[: self._node_rows.used]
            self._links = links
        needed = self._payload_rows.in_use + payloads
        if needed > payload_capacity // 2:
            used = slice(0, self._payload_rows.used)
            payload = LandmarkBlock.empty(
                max(2 * payload_capacity, 2 * needed), self._dim, self._ray_dim
            )
            payload.put(used, self._payload.take(used))
            self._payload = payload

    def _mark(self) -> np.ndarray:
        """Reachable node rows, one tree level per iteration; a node met several times in one
        level (shared by several parents) is kept once without sorting: each occurrence stamps
        its position and only the occurrence whose stamp survived goes on."""
        used = self._node_rows.used
        marked = np.zeros(used, dtype=bool)
        marked[_NULL] = True
        stamp = np.empty(used, dtype=np.int64)
        frontier = self._roots[~marked[self._roots]]
        while frontier.size:
            position = np.arange(frontier.size)
            stamp[frontier] = position
            frontier = frontier[stamp[frontier] == position]
            marked[frontier] = True
            children = self._links[frontier, _LEFT : _LEFT + 2].reshape(-1)
            frontier = children[~marked[children]]
        return marked

    def collect_garbage(self) -> int:
        """Mark the nodes reachable from the roots and the payload rows they point to, and put
        every other row on the free lists (rows do not move, so no pointer needs rewriting).

        Returns:
            the number of nodes reclaimed.
        """
        marked = self._mark()
        payload_marked = np.zeros(self._payload_rows.used, dtype=bool)
        payload_marked[self._links[np.flatnonzero(marked), _PAYLOAD]] = True
        self._payload_rows.sweep(payload_marked)
        return self._node_rows.sweep(marked)
