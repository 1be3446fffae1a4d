"""Compiled kernels for FastSLAM's per-pair loops (numba, the optional extra ``fast``).

At 100 particles and ~6 sightings a step is ~600 (particle, sighting) pairs, and the numpy
path spends it in ~460 calls of 1-3 us each: the per-call overhead, not the arithmetic,
dominates. These kernels do the same work as one loop over the pairs each:

* ``tree_rows`` / ``tree_scatter``: the landmark tree's walks and its path copying
  (``landmark_tree.LandmarkTree.gather`` / ``scatter``), ``take_rows`` / ``put_rows`` the
  copies of the payload rows they address;
* ``ekf_range_bearing``: the 2-D landmark EKF update (``core.kalman.ekf_update`` with
  ``RangeBearing2D``, thesis eqs. 4.33-4.37);
* ``association_inverses`` / ``association_scores``: the (particle, sighting, candidate) part
  of maximum-likelihood association of 2-D range-bearing sightings
  (``association.association_log_likelihood``), the bulk of FastSLAM 1.0's cost on data of
  unknown association;
* ``refine_range_bearing``: FastSLAM 2.0's sequential proposal over a step's sightings of
  established landmarks (``proposal.refine_proposal``, thesis eqs. 4.45-4.46 / Montemerlo 2003,
  Joseph form);
* ``cholesky_draws``: the proposal's pose draws mean + L e (``core.gaussian.sample_gaussian``);
* ``odometry_prediction``: the odometry model's prediction from exact poses, the start of the
  FastSLAM 2.0 proposal (``core.motion.OdometryMotionModel.predict`` with P = None);
* ``weighted_moments``: the particle set's weighted mean pose (circular mean heading) and
  covariance, recorded every step (``particles.ParticleSet.mean_pose`` / ``pose_covariance``);
* ``world_rays``, ``midpoint_triangulation``, ``azimuth_elevation_arguments``,
  ``bearing_landmark_updates``, ``gated_log_likelihoods``: the rays, triangulations, landmark
  EKF updates and weight factors of omni bearings (``bearing_mapper.BearingMapper.update``,
  thesis eqs. 4.21-4.37); ``refine_bearing_elevation``: their FastSLAM 2.0 proposal, one
  sighting at a time (``proposal.refine_proposal`` with ``BearingElevation3D``). Their cos /
  sin / atan2 / arccos / log are numpy's, taken by the caller between the kernels: numpy's SIMD
  atan2, arccos and log differ from the C library's in the last bit on a few percent of
  arguments, and with numpy's these kernels give the reference's numbers exactly (the tests
  demand equality).

The numpy path stays the reference and the test oracle (``tests/fastslam/test_kernels.py``):
every kernel writes out the reference's arithmetic in the reference's order (products summed
in index order as ``core.batch_linalg.product``, the same closed-form 2x2 inverse, the same
floored-modulo angle wrap), and leaves the transcendental functions whose numpy versions are
SIMD builds (``log`` of the innovation determinant, the random draws) to numpy, so that a
filter gives the same numbers with and without them. The tree kernels only move integers and
rows and are exact; the floating-point kernels agree with the reference to the last bits of
``atan2`` / ``sqrt`` / ``cos`` (numba calls the C library, numpy may use its own SIMD loops),
which the tests bound at 1e-12 relative.

The functions are plain Python written in the subset numba compiles; ``compiled()`` compiles
them on first use (cached on disk by numba), or raises ``MissingExtraError`` when numba is not
installed.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from omnislam.core.triangulation import PARALLEL_SIN
from omnislam.errors import MissingExtraError

#: columns of the landmark tree's node table (``landmark_tree``)
_LEFT, _TOKEN, _PAYLOAD = 0, 2, 3
#: floor of a squared range (``core.measurement``'s ``_EPS``)
_EPS = 1e-12
_PI = math.pi
_TWO_PI = 2.0 * math.pi
#: sqrt(2), as ``np.sqrt(2.0)`` (both correctly rounded)
_SQRT2 = math.sqrt(2.0)

_COMPILED: SimpleNamespace | None = None


def available() -> bool:
    """True when numba can be imported."""
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def resolve(choice: object) -> SimpleNamespace | None:
    """The compiled kernels for a ``config.Kernels`` choice, or None for the numpy path.

    Raises:
        MissingExtraError: NUMBA chosen without numba installed.
    """
    value = getattr(choice, "value", choice)
    if value == "numpy" or (value == "auto" and not available()):
        return None
    return compiled()


def compiled() -> SimpleNamespace:
    """The kernels compiled with ``numba.njit`` (compiled once per process, cached on disk).

    Raises:
        MissingExtraError: numba is not installed (the ``fast`` extra).
    """
    global _COMPILED
    if _COMPILED is None:
        try:
            import numba
        except ImportError as exc:
            raise MissingExtraError("numba", "fast") from exc
        jit = numba.njit(cache=True, nogil=True)
        # the helpers the kernels call must be compiled first (numba resolves globals then)
        namespace = globals()
        namespace["_wrap"] = jit(_wrap)
        namespace["_wrap_near"] = jit(_wrap_near)
        namespace["_key_depth"] = jit(_key_depth)
        namespace["_own_copy"] = jit(_own_copy)
        namespace["_inverse_small"] = jit(_inverse_small)
        namespace["_bearing_rows"] = jit(_bearing_rows)
        _COMPILED = SimpleNamespace(
            tree_rows=jit(tree_rows),
            tree_scatter=jit(tree_scatter),
            take_rows=jit(take_rows),
            put_rows=jit(put_rows),
            ekf_range_bearing=jit(ekf_range_bearing),
            association_inverses=jit(association_inverses),
            association_scores=jit(association_scores),
            refine_range_bearing=jit(refine_range_bearing),
            cholesky_draws=jit(cholesky_draws),
            odometry_prediction=jit(odometry_prediction),
            weighted_moments=jit(weighted_moments),
            world_rays=jit(world_rays),
            midpoint_triangulation=jit(midpoint_triangulation),
            azimuth_elevation_arguments=jit(azimuth_elevation_arguments),
            bearing_landmark_updates=jit(bearing_landmark_updates),
            gated_log_likelihoods=jit(gated_log_likelihoods),
            refine_bearing_elevation=jit(refine_bearing_elevation),
        )
    return _COMPILED


def _wrap(angle: float) -> float:
    """(angle + pi) mod 2 pi - pi with floored modulo: ``core.se.wrap_angle`` bit for bit."""
    shifted = angle + _PI
    return (shifted % _TWO_PI) - _PI


def _wrap_near(angle: float) -> float:
    """``_wrap`` bit for bit, without the modulo for an angle within one turn of [-pi, pi).

    Floored modulo of s = angle + pi in [-2 pi, 4 pi) is s, s - 2 pi or s + 2 pi, each exact
    (Sterbenz's lemma; the argument of ``core.se._unshift``); ``%`` costs ~10x more.
    """
    shifted = angle + _PI
    if shifted >= _TWO_PI:
        if shifted < 2.0 * _TWO_PI:
            return (shifted - _TWO_PI) - _PI
    elif shifted < 0.0:
        if shifted >= -_TWO_PI:
            return (shifted + _TWO_PI) - _PI
    elif shifted == shifted:  # not NaN
        return shifted - _PI
    return (shifted % _TWO_PI) - _PI


# -- the landmark tree --------------------------------------------------------------------------


def _key_depth(slot: int, leaf_height: int) -> tuple[int, int]:
    """Heap key and depth of a slot (``LandmarkTree._paths``); leaf_height < 0: all-nodes."""
    if leaf_height < 0:
        key = slot + 1
        depth = 0
        k = key
        while k > 1:
            k >>= 1
            depth += 1
        return key, depth
    return slot + (1 << leaf_height), leaf_height


def _own_copy(
    links: np.ndarray,
    source: int,
    token: int,
    node_free: np.ndarray,
    node_taken: int,
    node_used: int,
) -> tuple[int, int, int]:
    """Copy-on-write of a shared tree node: a free (or the next unused) row takes ``source``'s
    links and the writer's ``token``. Returns (new row, free rows taken, rows used)."""
    if node_taken < node_free.shape[0]:
        new = node_free[node_taken]
        node_taken += 1
    else:
        if node_used >= links.shape[0]:
            raise IndexError("landmark tree: node table full (reservation too small)")
        new = node_used
        node_used += 1
    for c in range(4):
        links[new, c] = links[source, c]
    links[new, _TOKEN] = token
    return new, node_taken, node_used


def tree_rows(
    links: np.ndarray,
    roots: np.ndarray,
    particles: np.ndarray,
    slots: np.ndarray,
    leaf_height: int,
) -> tuple[np.ndarray, int]:
    """Payload rows of N (particle, slot) pairs: each pair's walk from its particle's root.

    Args:
        links: (R, 4) node table [left, right, token, payload]; row 0 the null node.
        roots: (P,) root node of each particle.
        particles: (N,) the pairs' particles.
        slots: (N,) the pairs' landmark slots.
        leaf_height: the leaf-only tree's height, or -1 for the all-nodes tree.

    Returns:
        (N,) payload rows (0: absent), and the number of nodes visited.
    """
    n = particles.shape[0]
    out = np.empty(n, dtype=np.int64)
    visits = 0
    for i in range(n):
        key, depth = _key_depth(slots[i], leaf_height)
        visits += depth + 1
        node = roots[particles[i]]
        for level in range(depth - 1, -1, -1):
            node = links[node, _LEFT + ((key >> level) & 1)]
        out[i] = links[node, _PAYLOAD]
    return out, visits


def tree_scatter(
    links: np.ndarray,
    roots: np.ndarray,
    tokens: np.ndarray,
    particles: np.ndarray,
    slots: np.ndarray,
    leaf_height: int,
    node_free: np.ndarray,
    node_used: int,
    payload_free: np.ndarray,
    payload_used: int,
) -> tuple[np.ndarray, int, int, int, int, int, int]:
    """Path copying for N written (particle, slot) pairs (``LandmarkTree.scatter``).

    Every node on a pair's path that the writing particle does not own (its token differs) is
    copied into a new row owned by it and linked from its parent (or made the root); pairs of
    one particle share the copies of their common prefix because the copies are then owned.
    Each written node gets a fresh payload row. New rows come from the free lists first, then
    from never used rows (``landmark_tree._Rows.allocate``); the caller has reserved enough.

    Returns:
        (N,) the payload row of each pair; how many rows of ``node_free`` were taken, the new
        count of used node rows, the same two for the payload table, the nodes copied and the
        nodes visited.
    """
    n = particles.shape[0]
    rows = np.empty(n, dtype=np.int64)
    node_taken = 0
    payload_taken = 0
    copies = 0
    visits = 0
    for i in range(n):
        p = particles[i]
        token = tokens[p]
        key, depth = _key_depth(slots[i], leaf_height)
        visits += depth + 1
        node = roots[p]
        if links[node, _TOKEN] != token:
            new, node_taken, node_used = _own_copy(
                links, node, token, node_free, node_taken, node_used
            )
            roots[p] = new
            node = new
            copies += 1
        for level in range(depth - 1, -1, -1):
            column = _LEFT + ((key >> level) & 1)
            child = links[node, column]
            if links[child, _TOKEN] != token:
                new, node_taken, node_used = _own_copy(
                    links, child, token, node_free, node_taken, node_used
                )
                links[node, column] = new
                child = new
                copies += 1
            node = child
        if payload_taken < payload_free.shape[0]:
            row = payload_free[payload_taken]
            payload_taken += 1
        else:
            row = payload_used
            payload_used += 1
        links[node, _PAYLOAD] = row
        rows[i] = row
    return rows, node_taken, node_used, payload_taken, payload_used, copies, visits


def take_rows(source: np.ndarray, rows: np.ndarray, out: np.ndarray) -> None:
    """out[i] = source[rows[i]] for 2-D arrays (the payload table's fields as (Q, width)
    views): ``LandmarkBlock.take`` of the gathered rows, one field per call."""
    for i in range(rows.shape[0]):
        r = rows[i]
        for j in range(source.shape[1]):
            out[i, j] = source[r, j]


def put_rows(target: np.ndarray, rows: np.ndarray, source: np.ndarray) -> None:
    """target[rows[i]] = source[i] for 2-D arrays: ``LandmarkBlock.put`` of the written rows
    (distinct), one field per call."""
    for i in range(rows.shape[0]):
        r = rows[i]
        for j in range(target.shape[1]):
            target[r, j] = source[i, j]


# -- 2-D range-bearing landmark EKF -------------------------------------------------------------


def ekf_range_bearing(
    wTr: np.ndarray,
    mean: np.ndarray,
    cov: np.ndarray,
    z: np.ndarray,
    R: np.ndarray,
    out_mean: np.ndarray,
    out_cov: np.ndarray,
    out_mahalanobis: np.ndarray,
    out_det: np.ndarray,
    gate: float = math.inf,
) -> None:
    """EKF update of N 2-D landmarks by range-bearing sightings from exact poses.

    ``core.kalman.ekf_update`` with ``RangeBearing2D`` in the plain form, per pair: predicted
    z, landmark Jacobian H, S = H Sigma H^T + R, K = Sigma H^T S^-1, mean + K y and the
    symmetrised Sigma - K (Sigma H^T)^T (thesis eqs. 4.33-4.37). Writes the updated means and
    covariances, the innovations' squared Mahalanobis distances and det S (the caller takes
    the log, as the reference does, for the likelihood of eq. 4.47).

    A pair whose innovation lies outside the validation ``gate`` (y^T S^-1 y > gate,
    ``core.gating``) leaves its landmark as it was (the outputs get the inputs).

    Args:
        wTr: (N, 3) poses; mean: (N, 2); cov: (N, 2, 2); z: (N, 2); R: (N, 2, 2).
        out_mean: (N, 2) output: the updated means (may alias ``mean``).
        out_cov: (N, 2, 2) output: the updated covariances (may alias ``cov``).
        out_mahalanobis: (N,) output: y^T S^-1 y.
        out_det: (N,) output: det S.
        gate: the validation gate on y^T S^-1 y (infinite: every pair updates).
    """
    for i in range(wTr.shape[0]):
        dx = mean[i, 0] - wTr[i, 0]
        dy = mean[i, 1] - wTr[i, 1]
        q = dx * dx
        q += dy * dy
        if q < _EPS:
            q = _EPS
        r = math.sqrt(q)
        bearing = _wrap(math.atan2(dy, dx) - wTr[i, 2])
        y0 = z[i, 0] - r
        y1 = _wrap(z[i, 1] - bearing)
        h00, h01 = dx / r, dy / r
        h10, h11 = -(dy / q), dx / q
        p00, p01, p10, p11 = cov[i, 0, 0], cov[i, 0, 1], cov[i, 1, 0], cov[i, 1, 1]
        # P H^T, then S = H P H^T + R (terms summed in index order)
        a00 = p00 * h00 + p01 * h01
        a01 = p00 * h10 + p01 * h11
        a10 = p10 * h00 + p11 * h01
        a11 = p10 * h10 + p11 * h11
        s00 = h00 * a00 + h01 * a10 + R[i, 0, 0]
        s01 = h00 * a01 + h01 * a11 + R[i, 0, 1]
        s10 = h10 * a00 + h11 * a10 + R[i, 1, 0]
        s11 = h10 * a01 + h11 * a11 + R[i, 1, 1]
        det = s00 * s11 - s01 * s10
        i00, i01, i10, i11 = s11 / det, -s01 / det, -s10 / det, s00 / det
        t0 = i00 * y0 + i01 * y1
        t1 = i10 * y0 + i11 * y1
        out_mahalanobis[i] = y0 * t0 + y1 * t1
        out_det[i] = det
        if out_mahalanobis[i] > gate:  # an outlier: the landmark stays as it was
            out_mean[i, 0], out_mean[i, 1] = mean[i, 0], mean[i, 1]
            out_cov[i, 0, 0], out_cov[i, 0, 1] = p00, p01
            out_cov[i, 1, 0], out_cov[i, 1, 1] = p10, p11
            continue
        k00 = a00 * i00 + a01 * i10
        k01 = a00 * i01 + a01 * i11
        k10 = a10 * i00 + a11 * i10
        k11 = a10 * i01 + a11 * i11
        out_mean[i, 0] = mean[i, 0] + (k00 * y0 + k01 * y1)
        out_mean[i, 1] = mean[i, 1] + (k10 * y0 + k11 * y1)
        c00 = p00 - (k00 * a00 + k01 * a01)
        c01 = p01 - (k00 * a10 + k01 * a11)
        c10 = p10 - (k10 * a00 + k11 * a01)
        c11 = p11 - (k10 * a10 + k11 * a11)
        out_cov[i, 0, 0] = 0.5 * (c00 + c00)
        out_cov[i, 0, 1] = 0.5 * (c01 + c10)
        out_cov[i, 1, 0] = 0.5 * (c10 + c01)
        out_cov[i, 1, 1] = 0.5 * (c11 + c11)


# -- maximum-likelihood association of 2-D range-bearing sightings ------------------------------


def association_inverses(
    S_landmark: np.ndarray, R: np.ndarray, out_inverse: np.ndarray, out_det: np.ndarray
) -> None:
    """Inverses and determinants of S = S_pc + R_g for G distinct sighting noises R_g.

    The first half of ``association.association_log_likelihood``'s (particle, sighting,
    candidate) algebra with ``RangeBearing2D``: the sum S[:, None] + R[None, :, None] and the
    closed-form 2x2 inverse of ``batch_linalg.inverse_and_logdet`` (det = a d - b c, then
    d / det, -b / det, -c / det, a / det), once per distinct R instead of once per sighting.

    Args:
        S_landmark: (P, C, 2, 2) the sighting-independent part of S (H_m Sigma_c H_m^T, plus
            the pose term when the pose is uncertain).
        R: (G, 2, 2) the distinct noises of the frame's sightings.
        out_inverse: (G, P, C, 4) S^-1 entries (00, 01, 10, 11); out_det: (G, P, C) det S.
    """
    for g in range(R.shape[0]):
        r00, r01, r10, r11 = R[g, 0, 0], R[g, 0, 1], R[g, 1, 0], R[g, 1, 1]
        for p in range(S_landmark.shape[0]):
            for c in range(S_landmark.shape[1]):
                a = S_landmark[p, c, 0, 0] + r00
                b = S_landmark[p, c, 0, 1] + r01
                e = S_landmark[p, c, 1, 0] + r10
                d = S_landmark[p, c, 1, 1] + r11
                det = a * d - b * e
                out_det[g, p, c] = det
                out_inverse[g, p, c, 0] = d / det
                out_inverse[g, p, c, 1] = -b / det
                out_inverse[g, p, c, 2] = -e / det
                out_inverse[g, p, c, 3] = a / det


def association_scores(
    z_hat: np.ndarray,
    inverse: np.ndarray,
    logdet: np.ndarray,
    group: np.ndarray,
    z: np.ndarray,
    valid: np.ndarray,
    log_normaliser: float,
    out_log_likelihood: np.ndarray,
    out_mahalanobis: np.ndarray,
) -> None:
    """log N(z_k; z_hat_pc, S) and y^T S^-1 y of K sightings under C candidates in P particles.

    The second half of ``association_inverses``: per (particle, sighting, candidate) the
    residual y = z_k - z_hat_pc with the bearing wrapped (``RangeBearing2D.residual``), the
    quadratic form in the order of ``gaussian.mahalanobis_squared``'s einsum,
    ((y0 S'00 y0 + y0 S'01 y1) + y1 S'10 y0) + y1 S'11 y1 with S' = S^-1 and each product
    taken left to right, the log-likelihood -0.5 ((d2 + log det S) + k log 2 pi)
    (``gaussian.log_likelihood_from_mahalanobis``), and -inf / inf where the candidate is not
    valid.

    Args:
        z_hat: (P, C, 2) predicted (range, bearing) of each candidate from each particle.
        inverse: (G, P, C, 4) and logdet: (G, P, C): ``association_inverses``' outputs, the log
            taken by the caller (numpy's, as the reference's).
        group: (K,) the noise group g of each sighting; z: (K, 2) the sightings.
        valid: (P, C) False where the particle has no estimate of the candidate.
        log_normaliser: k log 2 pi.
        out_log_likelihood: (P, K, C) output: log-likelihoods.
        out_mahalanobis: (P, K, C) output: squared Mahalanobis distances.
    """
    for p in range(z_hat.shape[0]):
        for k in range(z.shape[0]):
            g = group[k]
            z0, z1 = z[k, 0], z[k, 1]
            for c in range(z_hat.shape[1]):
                if not valid[p, c]:
                    out_log_likelihood[p, k, c] = -math.inf
                    out_mahalanobis[p, k, c] = math.inf
                    continue
                y0 = z0 - z_hat[p, c, 0]
                y1 = _wrap_near(z1 - z_hat[p, c, 1])
                i00, i01 = inverse[g, p, c, 0], inverse[g, p, c, 1]
                i10, i11 = inverse[g, p, c, 2], inverse[g, p, c, 3]
                d2 = ((y0 * i00 * y0 + y0 * i01 * y1) + y1 * i10 * y0) + y1 * i11 * y1
                out_mahalanobis[p, k, c] = d2
                out_log_likelihood[p, k, c] = -0.5 * ((d2 + logdet[g, p, c]) + log_normaliser)


# -- FastSLAM 2.0's proposal over 2-D range-bearing sightings ---------------------------------


def refine_range_bearing(
    pose_mean: np.ndarray,
    pose_cov: np.ndarray,
    who: np.ndarray,
    z: np.ndarray,
    R: np.ndarray,
    landmark_mean: np.ndarray,
    landmark_cov: np.ndarray,
    out_mahalanobis: np.ndarray,
    out_det: np.ndarray,
    gate: float = math.inf,
) -> None:
    """Refine the proposals of particles ``who`` by N sightings, one after the other, in place.

    ``proposal.refine_proposal`` with ``RangeBearing2D`` and its ``gate``, per pair in the given
    order (the reference loops over the sightings in ascending order and updates every
    particle that saw the current one: the same sequence per particle): relinearised at the
    refined mean, Q = H_m Sigma_m H_m^T + R, the Kalman form of thesis eq. 4.45 with the
    covariance in Joseph form, symmetrised, and the heading wrapped.

    Args:
        pose_mean: (P, 3), pose_cov: (P, 3, 3): the particles' proposals, updated in place.
        who: (N,) particle of each pair, in processing order.
        z: (N, 2), R: (N, 2, 2): the pairs' sightings; landmark_mean: (N, 2), landmark_cov:
            (N, 2, 2): the observed landmarks in that particle's map.
        out_mahalanobis: (N,) y^T L^-1 y of each pair's innovation (a term of the predictive
            likelihood; the caller truncates at the gate).
        out_det: (N,) det L of each pair's innovation (the other term; the caller takes the
            log).
        gate: validation gate on y^T L^-1 y: a pair outside it leaves the proposal as it was
            (infinite: every pair refines).
    """
    # scratch matrices, allocated once
    a = np.empty((3, 2))
    k = np.empty((3, 2))
    hx = np.empty((2, 3))
    ikh = np.empty((3, 3))
    bp = np.empty((3, 3))
    c = np.empty((3, 3))
    for i in range(who.shape[0]):
        p = who[i]
        x, y, theta = pose_mean[p, 0], pose_mean[p, 1], pose_mean[p, 2]
        dx = landmark_mean[i, 0] - x
        dy = landmark_mean[i, 1] - y
        q = dx * dx
        q += dy * dy
        if q < _EPS:
            q = _EPS
        r = math.sqrt(q)
        bearing = _wrap(math.atan2(dy, dx) - theta)
        y0 = z[i, 0] - r
        y1 = _wrap(z[i, 1] - bearing)
        m00, m01 = dx / r, dy / r  # landmark Jacobian H_m
        m10, m11 = -(dy / q), dx / q
        # pose Jacobian H_x = [-H_m | (0, -1)^T]
        x00, x01, x02 = -m00, -m01, 0.0
        x10, x11, x12 = -m10, -m11, -1.0
        l00, l01 = landmark_cov[i, 0, 0], landmark_cov[i, 0, 1]
        l10, l11 = landmark_cov[i, 1, 0], landmark_cov[i, 1, 1]
        # Q = (H_m Sigma_m) H_m^T + R
        b00 = m00 * l00 + m01 * l10
        b01 = m00 * l01 + m01 * l11
        b10 = m10 * l00 + m11 * l10
        b11 = m10 * l01 + m11 * l11
        q00 = b00 * m00 + b01 * m01 + R[i, 0, 0]
        q01 = b00 * m10 + b01 * m11 + R[i, 0, 1]
        q10 = b10 * m00 + b11 * m01 + R[i, 1, 0]
        q11 = b10 * m10 + b11 * m11 + R[i, 1, 1]
        P = pose_cov[p]
        # P H_x^T (3 x 2)
        for row in range(3):
            a[row, 0] = P[row, 0] * x00 + P[row, 1] * x01 + P[row, 2] * x02
            a[row, 1] = P[row, 0] * x10 + P[row, 1] * x11 + P[row, 2] * x12
        s00 = x00 * a[0, 0] + x01 * a[1, 0] + x02 * a[2, 0] + q00
        s01 = x00 * a[0, 1] + x01 * a[1, 1] + x02 * a[2, 1] + q01
        s10 = x10 * a[0, 0] + x11 * a[1, 0] + x12 * a[2, 0] + q10
        s11 = x10 * a[0, 1] + x11 * a[1, 1] + x12 * a[2, 1] + q11
        det = s00 * s11 - s01 * s10
        i00, i01, i10, i11 = s11 / det, -s01 / det, -s10 / det, s00 / det
        t0 = i00 * y0 + i01 * y1
        t1 = i10 * y0 + i11 * y1
        out_mahalanobis[i] = y0 * t0 + y1 * t1
        out_det[i] = det
        if out_mahalanobis[i] > gate:  # an outlier: the proposal stays as it was
            continue
        for row in range(3):
            k[row, 0] = a[row, 0] * i00 + a[row, 1] * i10
            k[row, 1] = a[row, 0] * i01 + a[row, 1] * i11
        step0 = k[0, 0] * y0 + k[0, 1] * y1
        step1 = k[1, 0] * y0 + k[1, 1] * y1
        step2 = k[2, 0] * y0 + k[2, 1] * y1
        # Joseph form (I - K H_x) P (I - K H_x)^T + (K Q) K^T
        hx[0, 0], hx[0, 1], hx[0, 2] = x00, x01, x02
        hx[1, 0], hx[1, 1], hx[1, 2] = x10, x11, x12
        for row in range(3):
            for col in range(3):
                ikh[row, col] = (1.0 if row == col else 0.0) - (
                    k[row, 0] * hx[0, col] + k[row, 1] * hx[1, col]
                )
        for row in range(3):
            for col in range(3):
                bp[row, col] = (
                    ikh[row, 0] * P[0, col] + ikh[row, 1] * P[1, col] + ikh[row, 2] * P[2, col]
                )
        for row in range(3):
            d0 = k[row, 0] * q00 + k[row, 1] * q10
            d1 = k[row, 0] * q01 + k[row, 1] * q11
            for col in range(3):
                joseph = (
                    bp[row, 0] * ikh[col, 0] + bp[row, 1] * ikh[col, 1] + bp[row, 2] * ikh[col, 2]
                )
                c[row, col] = joseph + (d0 * k[col, 0] + d1 * k[col, 1])
        for row in range(3):
            for col in range(3):
                P[row, col] = 0.5 * (c[row, col] + c[col, row])
        pose_mean[p, 0] = x + step0
        pose_mean[p, 1] = y + step1
        pose_mean[p, 2] = _wrap(theta + step2)


def cholesky_draws(
    mean: np.ndarray, cov: np.ndarray, normals: np.ndarray, jitter: float, out: np.ndarray
) -> None:
    """out = mean + L e per row, cov + jitter I = L L^T (3 x 3), heading wrapped.

    ``proposal.sample_poses`` with the standard normal draws ``normals`` (N, 3) taken by the
    caller from the filter's generator, so both paths consume the same random numbers.
    """
    for i in range(mean.shape[0]):
        a00 = cov[i, 0, 0] + jitter
        a11 = cov[i, 1, 1] + jitter
        a22 = cov[i, 2, 2] + jitter
        l00 = math.sqrt(a00)
        l10 = cov[i, 1, 0] / l00
        l20 = cov[i, 2, 0] / l00
        l11 = math.sqrt(a11 - l10 * l10)
        l21 = (cov[i, 2, 1] - l20 * l10) / l11
        l22 = math.sqrt(a22 - l20 * l20 - l21 * l21)
        e0, e1, e2 = normals[i, 0], normals[i, 1], normals[i, 2]
        out[i, 0] = mean[i, 0] + l00 * e0
        out[i, 1] = mean[i, 1] + (l10 * e0 + l11 * e1)
        out[i, 2] = _wrap(mean[i, 2] + (l20 * e0 + l21 * e1 + l22 * e2))


def odometry_prediction(
    wTr: np.ndarray,
    rot1: float,
    trans: float,
    rot2: float,
    variances: np.ndarray,
    out_mean: np.ndarray,
    out_cov: np.ndarray,
) -> None:
    """Mean and covariance of P exact poses moved by one odometry step, thesis eqs. 4.41-4.44.

    ``OdometryMotionModel.predict(wTr, None, delta)`` with the decomposed step (rot1, trans,
    rot2) and its component variances: x' = x + [t cos(theta + rot1), t sin(theta + rot1),
    rot1 + rot2] (heading wrapped) and V diag(variances) V^T with V the Jacobian with respect
    to (rot1, trans, rot2) (Thrun et al. 2005, Table 7.1).
    """
    m0, m1, m2 = variances[0], variances[1], variances[2]
    for i in range(wTr.shape[0]):
        heading = wTr[i, 2] + rot1
        c = math.cos(heading)
        s = math.sin(heading)
        out_mean[i, 0] = c * trans + wTr[i, 0]
        out_mean[i, 1] = s * trans + wTr[i, 1]
        out_mean[i, 2] = _wrap(heading + rot2)
        # V = [[-t s, c, 0], [t c, s, 0], [1, 0, 1]]; N = (V M) V^T, terms in index order
        v00, v01 = -trans * s, c
        v10, v11 = trans * c, s
        a00, a01 = v00 * m0, v01 * m1
        a10, a11 = v10 * m0, v11 * m1
        a20, a22 = m0, m2
        out_cov[i, 0, 0] = a00 * v00 + a01 * v01
        out_cov[i, 0, 1] = a00 * v10 + a01 * v11
        out_cov[i, 0, 2] = a00
        out_cov[i, 1, 0] = a10 * v00 + a11 * v01
        out_cov[i, 1, 1] = a10 * v10 + a11 * v11
        out_cov[i, 1, 2] = a10
        out_cov[i, 2, 0] = a20 * v00
        out_cov[i, 2, 1] = a20 * v10
        out_cov[i, 2, 2] = a20 + a22


def weighted_moments(
    weights: np.ndarray, poses: np.ndarray, out_mean: np.ndarray, out_cov: np.ndarray
) -> None:
    """Weighted mean (heading: atan2 of the weighted sines and cosines) and weighted covariance
    about it (heading residuals wrapped) of P poses; sums in particle order (the reference's
    BLAS dot products may group them differently: equal to rounding)."""
    sx = sy = ss = sc = 0.0
    for i in range(poses.shape[0]):
        w = weights[i]
        sx += w * poses[i, 0]
        sy += w * poses[i, 1]
        ss += w * math.sin(poses[i, 2])
        sc += w * math.cos(poses[i, 2])
    theta = math.atan2(ss, sc)
    out_mean[0], out_mean[1], out_mean[2] = sx, sy, theta
    c00 = c01 = c02 = c11 = c12 = c22 = 0.0
    for i in range(poses.shape[0]):
        w = weights[i]
        d0 = poses[i, 0] - sx
        d1 = poses[i, 1] - sy
        d2 = _wrap(poses[i, 2] - theta)
        c00 += w * d0 * d0
        c01 += w * d0 * d1
        c02 += w * d0 * d2
        c11 += w * d1 * d1
        c12 += w * d1 * d2
        c22 += w * d2 * d2
    out_cov[0, 0], out_cov[0, 1], out_cov[0, 2] = c00, c01, c02
    out_cov[1, 0], out_cov[1, 1], out_cov[1, 2] = c01, c11, c12
    out_cov[2, 0], out_cov[2, 1], out_cov[2, 2] = c02, c12, c22


# -- 3-D landmarks from omni bearings -----------------------------------------------------------


def world_rays(
    wTr: np.ndarray,
    cos_theta: np.ndarray,
    sin_theta: np.ndarray,
    unit_vectors_r: np.ndarray,
    obs: np.ndarray,
    sensor_height_m: float,
    out: np.ndarray,
) -> None:
    """Rays in the world of N bearings ``unit_vectors_r[obs]`` seen from the poses ``wTr``.

    ``bearing_landmarks.world_rays`` (``core.se.se2_rotate_vectors``) with the cosines and
    sines of the headings taken by the caller (numpy's): out = [x, y, h, c u0 - s u1,
    s u0 + c u1, u2] (N, 6).
    """
    for i in range(wTr.shape[0]):
        o = obs[i]
        c, s = cos_theta[i], sin_theta[i]
        u0, u1 = unit_vectors_r[o, 0], unit_vectors_r[o, 1]
        out[i, 0] = wTr[i, 0]
        out[i, 1] = wTr[i, 1]
        out[i, 2] = sensor_height_m
        out[i, 3] = c * u0 - s * u1
        out[i, 4] = s * u0 + c * u1
        out[i, 5] = unit_vectors_r[o, 2]


def midpoint_triangulation(
    rays_a: np.ndarray,
    rays_b: np.ndarray,
    rows: np.ndarray,
    out_points: np.ndarray,
    out_cosine: np.ndarray,
    out_valid: np.ndarray,
) -> None:
    """Midpoints of N pairs of rays (rows ``rows`` of both tables) and the cosines of the
    angles between them.

    ``bearing_landmarks.triangulate`` with ``TriangulationMethod.MIDPOINT`` up to the arccos of
    the parallax (numpy's, left to the caller): ``core.triangulation.triangulate_midpoint`` on
    the normalised directions, the cosine of the rays' angle clipped to [-1, 1], and valid
    where the rays are not parallel, both depths are positive and the point is finite. Dot
    products are summed as ``batch_linalg.rows_dot``, (p0 + p1) + p2.

    Args:
        rays_a: (B, 6) first rays [origin_w (3), direction_w (3)].
        rays_b: (B, 6) second rays [origin_w (3), direction_w (3)].
        rows: (N,) the rows to triangulate.
        out_points: (N, 3) the midpoints; out_cosine: (N,) clipped cosines; out_valid: (N,).
    """
    for i in range(rows.shape[0]):
        r = rows[i]
        o1x, o1y, o1z = rays_a[r, 0], rays_a[r, 1], rays_a[r, 2]
        a0, a1, a2 = rays_a[r, 3], rays_a[r, 4], rays_a[r, 5]
        o2x, o2y, o2z = rays_b[r, 0], rays_b[r, 1], rays_b[r, 2]
        b0, b1, b2 = rays_b[r, 3], rays_b[r, 4], rays_b[r, 5]
        norm_a = math.sqrt((a0 * a0 + a1 * a1) + a2 * a2)
        norm_b = math.sqrt((b0 * b0 + b1 * b1) + b2 * b2)
        u0, u1, u2 = a0 / norm_a, a1 / norm_a, a2 / norm_a
        v0, v1, v2 = b0 / norm_b, b1 / norm_b, b2 / norm_b
        w0, w1, w2 = o1x - o2x, o1y - o2y, o1z - o2z
        b = (u0 * v0 + u1 * v1) + u2 * v2
        d = (u0 * w0 + u1 * w1) + u2 * w2
        e = (v0 * w0 + v1 * w1) + v2 * w2
        denom = 1.0 - b * b
        parallel = denom <= PARALLEL_SIN
        safe = 1.0 if parallel else denom
        t1 = (b * e - d) / safe
        t2 = (e - b * d) / safe
        px = 0.5 * ((o1x + t1 * u0) + (o2x + t2 * v0))
        py = 0.5 * ((o1y + t1 * u1) + (o2y + t2 * v1))
        pz = 0.5 * ((o1z + t1 * u2) + (o2z + t2 * v2))
        out_points[i, 0], out_points[i, 1], out_points[i, 2] = px, py, pz
        cosine = ((a0 * b0 + a1 * b1) + a2 * b2) / (norm_a * norm_b)
        if cosine < -1.0:
            cosine = -1.0
        elif cosine > 1.0:
            cosine = 1.0
        out_cosine[i] = cosine
        out_valid[i] = (
            not parallel
            and t1 > 0
            and t2 > 0
            and math.isfinite(px)
            and math.isfinite(py)
            and math.isfinite(pz)
        )


def azimuth_elevation_arguments(
    wTr: np.ndarray, points_w: np.ndarray, sensor_height_m: float, out: np.ndarray
) -> None:
    """The arguments of the two atan2 of a bearing to N points: out = (dy, dx, dz, rho) (4, N).

    ``core.measurement.BearingElevation3D.predict`` / ``RangeAzimuthElevation3D.predict`` up
    to their atan2, left to numpy (its SIMD atan2 differs from the C library's in the last
    bit): azimuth = wrap(atan2(dy, dx) - theta), elevation = atan2(dz, rho), with (dx, dy, dz)
    the point from the viewpoint (x, y, sensor_height_m) and rho = sqrt(max(dx^2 + dy^2, eps)).
    Each row of ``out`` is contiguous, as the reference's arrays are.
    """
    for i in range(wTr.shape[0]):
        dx = points_w[i, 0] - wTr[i, 0]
        dy = points_w[i, 1] - wTr[i, 1]
        rho2 = dx * dx + dy * dy
        if rho2 < _EPS:
            rho2 = _EPS
        out[0, i] = dy
        out[1, i] = dx
        out[2, i] = points_w[i, 2] - sensor_height_m
        out[3, i] = math.sqrt(rho2)


def _bearing_rows(dx: float, dy: float, dz: float, h: np.ndarray) -> float:
    """The azimuth and elevation rows of a bearing's Jacobian with respect to the landmark
    (thesis eq. 4.32 without its range row), for the landmark at (dx, dy, dz) from the viewpoint,
    into ``h`` (2, 3); returns d^2 = rho^2 + dz^2, rho^2 floored at ``_EPS``. The pose's
    Jacobian is minus its first two columns with -1 / 0 for the heading."""
    rho2 = dx * dx + dy * dy
    if rho2 < _EPS:
        rho2 = _EPS
    rho = math.sqrt(rho2)
    d2 = rho2 + dz * dz
    h[0, 0], h[0, 1], h[0, 2] = -dy / rho2, dx / rho2, 0.0
    h[1, 0], h[1, 1], h[1, 2] = -dz * dx / (rho * d2), -dz * dy / (rho * d2), rho / d2
    return d2


def _inverse_small(S: np.ndarray, k: int, out: np.ndarray) -> float:
    """S^-1 of a 2x2 or 3x3 matrix into ``out``, returns det S: the closed forms of
    ``batch_linalg.inverse_entry_major`` (cofactors over the determinant for 3x3)."""
    if k == 2:
        a, b, c, d = S[0, 0], S[0, 1], S[1, 0], S[1, 1]
        det = a * d - b * c
        out[0, 0], out[0, 1] = d / det, -b / det
        out[1, 0], out[1, 1] = -c / det, a / det
        return det
    a, b, c = S[0, 0], S[0, 1], S[0, 2]
    d, e, f = S[1, 0], S[1, 1], S[1, 2]
    g, h, i = S[2, 0], S[2, 1], S[2, 2]
    adj00, adj01, adj02 = e * i - f * h, c * h - b * i, b * f - c * e
    adj10, adj11, adj12 = f * g - d * i, a * i - c * g, c * d - a * f
    adj20, adj21, adj22 = d * h - e * g, b * g - a * h, a * e - b * d
    det = a * adj00 + b * adj10 + c * adj20
    out[0, 0], out[0, 1], out[0, 2] = adj00 / det, adj01 / det, adj02 / det
    out[1, 0], out[1, 1], out[1, 2] = adj10 / det, adj11 / det, adj12 / det
    out[2, 0], out[2, 1], out[2, 2] = adj20 / det, adj21 / det, adj22 / det
    return det


def bearing_landmark_updates(
    wTr: np.ndarray,
    mean: np.ndarray,
    cov: np.ndarray,
    rows: np.ndarray,
    triangulated: np.ndarray,
    point_w: np.ndarray,
    point_angles: np.ndarray,
    sin_parallax: np.ndarray,
    sigma_rad: np.ndarray,
    ray_reuse: float,
    obs: np.ndarray,
    z: np.ndarray,
    R: np.ndarray,
    mean_angles: np.ndarray,
    sensor_height_m: float,
    gate_triangulated: float,
    gate_direct: float,
    rays: np.ndarray,
    block_ray: np.ndarray,
    out_mahalanobis: np.ndarray,
    out_det: np.ndarray,
    out_accepted: np.ndarray,
) -> None:
    """EKF updates of N established 3-D landmarks from omni bearings, outliers gated out.

    ``bearing_mapper.BearingMapper.update``'s later matches (thesis eqs. 4.29-4.37) per pair:
    where the pair triangulated, with the pseudo-measurement z = (d, theta, phi) of the
    triangulated point and its noise Q (``bearing_landmarks.triangulated_measurement``, eqs.
    4.23 / 4.25) under ``RangeAzimuthElevation3D``; elsewhere directly with z = (azimuth,
    elevation) under ``BearingElevation3D``. Each is ``core.kalman.ekf_update`` in the plain
    form: predicted z and landmark Jacobian H at the mean (eqs. 4.31-4.32), y = z - z_hat with
    the angles wrapped, S = H Sigma H^T + R, K = Sigma H^T S^-1 (cofactor / closed-form
    inverse), mean + K y and the symmetrised Sigma - K (Sigma H^T)^T, every product summed in
    index order as ``batch_linalg.product``. A pair whose y^T S^-1 y exceeds its gate leaves
    its landmark as it was. The atan2 of the point and of the mean are numpy's (the caller's,
    from ``azimuth_elevation_arguments``), as are the log of det S and the likelihood.

    Args:
        wTr: (B, 3) poses, mean: (B, 3), cov: (B, 3, 3): the block's, indexed by ``rows``;
            mean and cov are updated in place.
        rows: (N,) the block rows of the pairs.
        triangulated: (N,) bool: the pair's update uses the triangulated point.
        point_w: (N, 3) triangulated points; point_angles: (2, N) atan2(dy, dx) and
            atan2(dz, rho) of each point; sin_parallax: (N,) sin of the rays' angle
            (read where ``triangulated``).
        sigma_rad: (B,) the bearings' angular std (block rows).
        ray_reuse: Q is multiplied by this.
        obs: (B,) the sighting of each block row; z: (K, 2) and R: (K, 2, 2) the sightings.
        mean_angles: (2, N) atan2(dy, dx) and atan2(dz, rho) of each landmark mean.
        sensor_height_m: the viewpoint's height.
        gate_triangulated: the validation gate of 3-D innovations.
        gate_direct: the validation gate of 2-D innovations.
        rays: (B, 6) the new sightings' rays; block_ray: (B, 6) the stored ones: an accepted
            triangulated update stores the new ray (eq. 4.28).
        out_mahalanobis: (N,) y^T S^-1 y.
        out_det: (N,) det S.
        out_accepted: (N,) bool.
    """
    H = np.zeros((3, 3))
    hb = np.zeros((2, 3))
    Rk = np.zeros((3, 3))
    y = np.zeros(3)
    pht = np.zeros((3, 3))
    S = np.zeros((3, 3))
    S_inv = np.zeros((3, 3))
    K = np.zeros((3, 3))
    c = np.zeros((3, 3))
    for i in range(rows.shape[0]):
        r = rows[i]
        x, yy, theta = wTr[r, 0], wTr[r, 1], wTr[r, 2]
        dx = mean[r, 0] - x
        dy = mean[r, 1] - yy
        dz = mean[r, 2] - sensor_height_m
        d2 = _bearing_rows(dx, dy, dz, hb)  # the bearing rows of H
        azimuth = _wrap(mean_angles[0, i] - theta)
        elevation = mean_angles[1, i]
        if triangulated[i]:
            k = 3
            gate = gate_triangulated
            d = math.sqrt(d2)
            # z = (d, theta, phi) of the triangulated point (eq. 4.25) and its Q (eq. 4.23)
            pdx = point_w[i, 0] - x
            pdy = point_w[i, 1] - yy
            pdz = point_w[i, 2] - sensor_height_m
            prho2 = pdx * pdx + pdy * pdy
            if prho2 < _EPS:
                prho2 = _EPS
            z_d = math.sqrt(prho2 + pdz * pdz)
            z_azimuth = _wrap(point_angles[0, i] - theta)
            sigma = sigma_rad[r]
            sine = sin_parallax[i]
            if sine < 1e-6:
                sine = 1e-6
            sigma_d = _SQRT2 * z_d * sigma / sine
            for a in range(3):
                for b in range(3):
                    Rk[a, b] = ray_reuse * 0.0
            Rk[0, 0] = ray_reuse * (sigma_d * sigma_d)
            Rk[1, 1] = Rk[2, 2] = ray_reuse * (sigma * sigma)
            y[0] = z_d - d
            y[1] = _wrap(z_azimuth - azimuth)
            y[2] = _wrap(point_angles[1, i] - elevation)
            H[0, 0], H[0, 1], H[0, 2] = dx / d, dy / d, dz / d
            for b in range(3):
                H[1, b] = hb[0, b]
                H[2, b] = hb[1, b]
        else:
            k = 2
            gate = gate_direct
            o = obs[r]
            for a in range(2):
                for b in range(2):
                    Rk[a, b] = R[o, a, b]
            y[0] = _wrap(z[o, 0] - azimuth)
            y[1] = _wrap(z[o, 1] - elevation)
            for b in range(3):
                H[0, b] = hb[0, b]
                H[1, b] = hb[1, b]
        # P H^T (3 x k), S = H (P H^T) + R (k x k)
        for a in range(3):
            for b in range(k):
                acc = cov[r, a, 0] * H[b, 0]
                acc += cov[r, a, 1] * H[b, 1]
                acc += cov[r, a, 2] * H[b, 2]
                pht[a, b] = acc
        for a in range(k):
            for b in range(k):
                acc = H[a, 0] * pht[0, b]
                acc += H[a, 1] * pht[1, b]
                acc += H[a, 2] * pht[2, b]
                S[a, b] = acc + Rk[a, b]
        det = _inverse_small(S, k, S_inv)
        # y^T (S^-1 y)
        mahalanobis = 0.0
        for a in range(k):
            acc = S_inv[a, 0] * y[0]
            for b in range(1, k):
                acc += S_inv[a, b] * y[b]
            if a == 0:
                mahalanobis = y[0] * acc
            else:
                mahalanobis += y[a] * acc
        out_mahalanobis[i] = mahalanobis
        out_det[i] = det
        accepted = mahalanobis <= gate
        out_accepted[i] = accepted
        if not accepted:  # an outlier: the landmark stays as it was
            continue
        if k == 3:  # eq. 4.28: keep the latest sighting
            for a in range(6):
                block_ray[r, a] = rays[r, a]
        # K = (P H^T) S^-1, mean + K y, Sigma - K (P H^T)^T symmetrised
        for a in range(3):
            for b in range(k):
                acc = pht[a, 0] * S_inv[0, b]
                for m in range(1, k):
                    acc += pht[a, m] * S_inv[m, b]
                K[a, b] = acc
        for a in range(3):
            for b in range(3):
                acc = K[a, 0] * pht[b, 0]
                for m in range(1, k):
                    acc += K[a, m] * pht[b, m]
                c[a, b] = cov[r, a, b] - acc
        for a in range(3):
            acc = K[a, 0] * y[0]
            for m in range(1, k):
                acc += K[a, m] * y[m]
            mean[r, a] = mean[r, a] + acc
        for a in range(3):
            for b in range(3):
                cov[r, a, b] = 0.5 * (c[a, b] + c[b, a])


def gated_log_likelihoods(
    mahalanobis: np.ndarray,
    logdet: np.ndarray,
    triangulated: np.ndarray,
    log_normaliser_triangulated: float,
    log_normaliser_direct: float,
    gate_triangulated: float,
    gate_direct: float,
    rows: np.ndarray,
    out: np.ndarray,
) -> None:
    """out[rows[i]] = log N(y; 0, S) truncated at the gate, from ``bearing_landmark_updates``'
    y^T S^-1 y and numpy's log det S: ``gaussian.log_likelihood_from_mahalanobis``,
    -0.5 ((d2 + log det S) + k log 2 pi), then ``gating.gate_truncated_log_likelihood``,
    ll - 0.5 (min(d2, gate) - d2) (NaN propagating as ``np.minimum``)."""
    for i in range(rows.shape[0]):
        d2 = mahalanobis[i]
        if triangulated[i]:
            normaliser, gate = log_normaliser_triangulated, gate_triangulated
        else:
            normaliser, gate = log_normaliser_direct, gate_direct
        truncated = gate if d2 > gate else d2
        out[rows[i]] = -0.5 * ((d2 + logdet[i]) + normaliser) - 0.5 * (truncated - d2)


def refine_bearing_elevation(
    pose_mean: np.ndarray,
    pose_cov: np.ndarray,
    who: np.ndarray,
    z: np.ndarray,
    R: np.ndarray,
    landmark_mean: np.ndarray,
    landmark_cov: np.ndarray,
    angles: np.ndarray,
    sensor_height_m: float,
    gate: float,
    out_mahalanobis: np.ndarray,
    out_det: np.ndarray,
) -> None:
    """Refine the proposals of particles ``who`` (distinct) by one omni bearing each, in place.

    One step of FastSLAM 2.0's sequential proposal (``proposal.refine_proposal`` with
    ``BearingElevation3D``, thesis eqs. 4.45-4.46 / Montemerlo 2003) for every particle that saw
    one sighting: z_hat, H_x and H_m at the refined mean, Q = (H_m Sigma_m) H_m^T + R,
    L = H_x P H_x^T + Q, K = P H_x^T L^-1, mean + K y with the heading wrapped, and the
    covariance in Joseph form (I - K H_x) P (I - K H_x)^T + (K Q) K^T, symmetrised; every
    product summed in index order as ``batch_linalg.product``. A pair outside the ``gate``
    leaves the proposal as it was. The atan2 of the landmarks seen from the refined means are
    numpy's (the caller's, from ``azimuth_elevation_arguments``), as are the log of det L and
    the likelihood.

    Args:
        pose_mean: (P, 3), pose_cov: (P, 3, 3): the particles' proposals, updated in place.
        who: (N,) distinct particles; z: (2,) and R: (2, 2): the sighting (azimuth,
            elevation) and its noise; landmark_mean: (N, 3), landmark_cov: (N, 3, 3): the
            sighted landmark in each particle's map; angles: (2, N) atan2(dy, dx) and
            atan2(dz, rho) of the landmark from each particle's refined mean.
        out_mahalanobis: (N,) y^T L^-1 y.
        out_det: (N,) det L.
    """
    hm = np.zeros((2, 3))
    hx = np.zeros((2, 3))
    b = np.zeros((2, 3))
    q = np.zeros((2, 2))
    a = np.zeros((3, 2))
    k = np.zeros((3, 2))
    ikh = np.zeros((3, 3))
    bp = np.zeros((3, 3))
    c = np.zeros((3, 3))
    for i in range(who.shape[0]):
        p = who[i]
        x, y, theta = pose_mean[p, 0], pose_mean[p, 1], pose_mean[p, 2]
        dx = landmark_mean[i, 0] - x
        dy = landmark_mean[i, 1] - y
        dz = landmark_mean[i, 2] - sensor_height_m
        y0 = _wrap(z[0] - _wrap(angles[0, i] - theta))
        y1 = _wrap(z[1] - angles[1, i])
        # landmark Jacobian H_m and pose Jacobian H_x = [-H_m[:, :2] | (-1, 0)^T]
        _bearing_rows(dx, dy, dz, hm)
        hx[0, 0], hx[0, 1], hx[0, 2] = -hm[0, 0], -hm[0, 1], -1.0
        hx[1, 0], hx[1, 1], hx[1, 2] = -hm[1, 0], -hm[1, 1], 0.0
        # Q = (H_m Sigma_m) H_m^T + R
        for r in range(2):
            for col in range(3):
                acc = hm[r, 0] * landmark_cov[i, 0, col]
                acc += hm[r, 1] * landmark_cov[i, 1, col]
                acc += hm[r, 2] * landmark_cov[i, 2, col]
                b[r, col] = acc
        for r in range(2):
            for col in range(2):
                acc = b[r, 0] * hm[col, 0]
                acc += b[r, 1] * hm[col, 1]
                acc += b[r, 2] * hm[col, 2]
                q[r, col] = acc + R[r, col]
        P = pose_cov[p]
        # P H_x^T (3 x 2), L = H_x (P H_x^T) + Q
        for r in range(3):
            for col in range(2):
                acc = P[r, 0] * hx[col, 0]
                acc += P[r, 1] * hx[col, 1]
                acc += P[r, 2] * hx[col, 2]
                a[r, col] = acc
        s00 = hx[0, 0] * a[0, 0] + hx[0, 1] * a[1, 0] + hx[0, 2] * a[2, 0] + q[0, 0]
        s01 = hx[0, 0] * a[0, 1] + hx[0, 1] * a[1, 1] + hx[0, 2] * a[2, 1] + q[0, 1]
        s10 = hx[1, 0] * a[0, 0] + hx[1, 1] * a[1, 0] + hx[1, 2] * a[2, 0] + q[1, 0]
        s11 = hx[1, 0] * a[0, 1] + hx[1, 1] * a[1, 1] + hx[1, 2] * a[2, 1] + q[1, 1]
        det = s00 * s11 - s01 * s10
        i00, i01, i10, i11 = s11 / det, -s01 / det, -s10 / det, s00 / det
        t0 = i00 * y0 + i01 * y1
        t1 = i10 * y0 + i11 * y1
        mahalanobis = y0 * t0 + y1 * t1
        out_mahalanobis[i] = mahalanobis
        out_det[i] = det
        if not mahalanobis <= gate:  # an outlier: the proposal stays as it was
            continue
        for r in range(3):
            k[r, 0] = a[r, 0] * i00 + a[r, 1] * i10
            k[r, 1] = a[r, 0] * i01 + a[r, 1] * i11
        step0 = k[0, 0] * y0 + k[0, 1] * y1
        step1 = k[1, 0] * y0 + k[1, 1] * y1
        step2 = k[2, 0] * y0 + k[2, 1] * y1
        # Joseph form (I - K H_x) P (I - K H_x)^T + (K Q) K^T
        for r in range(3):
            for col in range(3):
                ikh[r, col] = (1.0 if r == col else 0.0) - (
                    k[r, 0] * hx[0, col] + k[r, 1] * hx[1, col]
                )
        for r in range(3):
            for col in range(3):
                acc = ikh[r, 0] * P[0, col]
                acc += ikh[r, 1] * P[1, col]
                acc += ikh[r, 2] * P[2, col]
                bp[r, col] = acc
        for r in range(3):
            d0 = k[r, 0] * q[0, 0] + k[r, 1] * q[1, 0]
            d1 = k[r, 0] * q[0, 1] + k[r, 1] * q[1, 1]
            for col in range(3):
                joseph = bp[r, 0] * ikh[col, 0]
                joseph += bp[r, 1] * ikh[col, 1]
                joseph += bp[r, 2] * ikh[col, 2]
                c[r, col] = joseph + (d0 * k[col, 0] + d1 * k[col, 1])
        for r in range(3):
            for col in range(3):
                P[r, col] = 0.5 * (c[r, col] + c[col, r])
        pose_mean[p, 0] = x + step0
        pose_mean[p, 1] = y + step1
        pose_mean[p, 2] = _wrap(theta + step2)
