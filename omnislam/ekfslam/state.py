"""The EKF-SLAM Gaussian: the joint state [x_r, y_r, theta_r, l_1, l_2, ...] and its covariance.

Each landmark l_i is a point of ``landmark_dim`` coordinates: (x, y) for range-bearing
sightings, (x, y, z) for the omni camera's bearings (``ekfslam.bearings``); the measurement
model of each update or augmentation may be passed per call (the omni filter updates with
(azimuth, elevation) and augments with the triangulated (d, azimuth, elevation)).

SLAM for Dummies ("O EKF", "As matrizes"): the state X holds the robot pose and the position of
every landmark, P their joint covariance. Both live in preallocated arrays whose capacity doubles
when a landmark does not fit, so augmentation never reallocates per landmark. The three EKF steps
touch only what the sparse structure of the models requires:

* ``predict`` (tutorial "Passo 1"): the odometry moves only the robot, so only the robot block
  P_rr and the robot-map cross-covariances P_rm change: O(n) for n landmarks.
* ``update`` (tutorial "Passo 2"): a sighting of landmark i has a Jacobian H with non-zeros only
  in the robot's three and the landmark's two columns (the tutorial's H_i); P H^T is gathered
  from those five columns of P (O(n)) and the covariance is corrected by a rank-4 product: O(n^2),
  never a dense 2 x (3 + 2n) H times P.
* ``augment`` (tutorial "Passo 3", left as TODO in the translation; SEEDS.md errata): a new
  landmark l = g(x_r, z) enters with the Jacobians J_xr and J_z of "As jacobianas específicas do
  SLAM": P_ll = J_xr P_rr J_xr^T + J_z R J_z^T, P_lx = J_xr P_rx. O(n).

P is stored as its **upper triangle** only (entries P_ij with j >= i of the preallocated
array; the lower triangle is never read): the corrections of ``update`` / ``update_batch`` are
symmetric rank-2k products that BLAS's ``dsyr2k`` computes on one triangle in place
(``core.symmetric_update``), half the arithmetic of the full product and no mirroring pass,
and P is exactly symmetric by construction. Reads go through ``block`` / ``columns`` (a
symmetric sub-block or whole columns gathered from the triangle); ``cov`` is a full copy.

All angles are in radians; the robot heading stays wrapped to [-pi, pi).
"""

from __future__ import annotations

import numpy as np

from omnislam.core.measurement import MeasurementModel, RangeBearing2D
from omnislam.core.motion import OdometryMotionModel
from omnislam.core.se import se2_compose_jacobians, wrap_angle
from omnislam.core.symmetric_update import symmetric_from_upper, syr2k_upper

#: dimension of the robot pose block
POSE_DIM = 3
#: dimension of one landmark block of the 2-D (range-bearing) filter
LANDMARK_DIM = 2


def landmark_columns(slot: int, landmark_dim: int = LANDMARK_DIM) -> slice:
    """The state indices of landmark ``slot`` (0-based): 3 + dim slot ... 3 + dim (slot + 1)."""
    start = POSE_DIM + landmark_dim * slot
    return slice(start, start + landmark_dim)


class SlamGaussian:
    """Mean and covariance of the EKF-SLAM state, with the three EKF steps.

    Args:
        pose_w: (3,) initial robot pose [x, y, theta] in the world.
        pose_cov: (3, 3) its covariance.
        capacity: landmark slots preallocated.
        model: the default measurement model (``core.measurement``; range-bearing by
            default); its ``dim_landmark`` sets the landmark dimension (2 or 3).
    """

    def __init__(
        self,
        pose_w: np.ndarray,
        pose_cov: np.ndarray,
        capacity: int = 64,
        model: MeasurementModel | None = None,
    ) -> None:
        self.model = RangeBearing2D() if model is None else model
        self.landmark_dim = int(getattr(self.model, "dim_landmark", LANDMARK_DIM))
        size = POSE_DIM + self.landmark_dim * max(int(capacity), 1)
        self._x = np.zeros(size)
        self._P = np.zeros((size, size))
        self._x[:POSE_DIM] = np.asarray(pose_w, dtype=float).reshape(POSE_DIM)
        self._P[:POSE_DIM, :POSE_DIM] = np.asarray(pose_cov, dtype=float).reshape(3, 3)
        self.n_landmarks = 0

    # -- views ----------------------------------------------------------------------------------

    @property
    def dim(self) -> int:
        """3 + dim n."""
        return POSE_DIM + self.landmark_dim * self.n_landmarks

    @property
    def capacity(self) -> int:
        """Landmark slots allocated."""
        return (self._x.shape[0] - POSE_DIM) // self.landmark_dim

    @property
    def mean(self) -> np.ndarray:
        """(3 + dim n,) view of X (writes change the state)."""
        return self._x[: self.dim]

    @property
    def cov(self) -> np.ndarray:
        """(3 + dim n, 3 + dim n) copy of P, made whole from its upper triangle, O(n^2)."""
        d = self.dim
        return symmetric_from_upper(self._P[:d, :d])

    @cov.setter
    def cov(self, P: np.ndarray) -> None:
        """Replace P (its upper triangle is stored; it should be symmetric)."""
        d = self.dim
        P = np.asarray(P, dtype=float)
        if P.shape != (d, d):
            raise ValueError(f"P must be ({d}, {d}), got {P.shape}")
        self._P[:d, :d] = np.triu(P)

    def block(self, idx: np.ndarray) -> np.ndarray:
        """(m, m) the symmetric sub-block ``P[idx][:, idx]`` for state indices ``idx`` (any order),
        each entry read from the stored triangle: P_ij = P[min(i, j), max(i, j)]."""
        idx = np.asarray(idx, dtype=int)
        return self._P[np.minimum.outer(idx, idx), np.maximum.outer(idx, idx)]

    def columns(self, idx: np.ndarray) -> np.ndarray:
        """(3 + dim n, m) the whole columns P[:, idx], O(n m): rows up to each index from the
        column, the rest from the row (P_ij = P_ji)."""
        idx = np.asarray(idx, dtype=int)
        d = self.dim
        out = self._P[:d, idx]  # a copy; right above and on the diagonal
        for t, j in enumerate(idx.tolist()):
            out[j + 1 :, t] = self._P[j, j + 1 : d]  # below it: row j
        return out

    def _robot_rows(self) -> np.ndarray:
        """(3, 3 + dim n) copy of the robot's rows of P (its 3 x 3 block made whole)."""
        d = self.dim
        rows = self._P[:POSE_DIM, :d].copy()
        rows[:, :POSE_DIM] = self.block(np.arange(POSE_DIM))
        return rows

    @property
    def pose(self) -> np.ndarray:
        """(3,) copy of the robot pose [x, y, theta]."""
        return self._x[:POSE_DIM].copy()

    @property
    def pose_cov(self) -> np.ndarray:
        """(3, 3) copy of P_rr."""
        return self.block(np.arange(POSE_DIM))

    @property
    def landmarks(self) -> np.ndarray:
        """(n, dim) copy of the landmark positions [m]."""
        return self._x[POSE_DIM : self.dim].reshape(-1, self.landmark_dim).copy()

    def landmark_covariances(self, slots: np.ndarray | None = None) -> np.ndarray:
        """(m, dim, dim) diagonal blocks P_ii of the given landmark slots (all by default)."""
        slots = np.arange(self.n_landmarks) if slots is None else np.asarray(slots, dtype=int)
        k, span = self.landmark_dim, np.arange(self.landmark_dim)
        rows = POSE_DIM + k * slots[:, None, None] + span[None, :, None]
        cols = POSE_DIM + k * slots[:, None, None] + span[None, None, :]
        return self._P[np.minimum(rows, cols), np.maximum(rows, cols)]

    # -- Passo 1: prediction --------------------------------------------------------------------

    def predict(
        self,
        motion: OdometryMotionModel,
        delta_r: np.ndarray,
        delta_cov: np.ndarray | None = None,
    ) -> None:
        """Move the robot by one odometry step (SLAM for Dummies "Passo 1"), O(n).

        The mean is the shared motion model's g(x_r, u) (thesis eq. 4.44); A = dg/dx_r its
        Jacobian (the tutorial's A, exact for the rot1-trans-rot2 model); the process noise is the
        odometry covariance in the robot frame rotated into the world, Q = J_u Sigma_u J_u^T, with
        Sigma_u the log's own covariance when given, else ``motion.covariance`` (thesis 4.41
        linearised). Then (tutorial, with its A P A corrected to A P A^T):

            P_rr' = A P_rr A^T + Q,    P_rm' = A P_rm    (P_mr' = P_rm'^T is not stored).

        Args:
            motion: the odometry motion model.
            delta_r: (3,) robot-frame motion [dx, dy, dtheta].
            delta_cov: (3, 3) covariance of ``delta_r`` or None.
        """
        delta_r = np.asarray(delta_r, dtype=float)
        pose = self._x[:POSE_DIM].copy()
        components = motion.decompose(delta_r)
        A, _ = motion.apply_jacobians(pose, components)
        _, J_u = se2_compose_jacobians(pose, delta_r)
        sigma_u = motion.covariance(delta_r) if delta_cov is None else delta_cov
        d = self.dim
        P = self._P
        if d > POSE_DIM:
            P[:POSE_DIM, POSE_DIM:d] = A @ P[:POSE_DIM, POSE_DIM:d]
        P_rr = A @ self.pose_cov @ A.T + J_u @ sigma_u @ J_u.T
        P[:POSE_DIM, :POSE_DIM] = np.triu(0.5 * (P_rr + P_rr.T))
        self._x[:POSE_DIM] = motion.apply(pose, components)

    # -- Passo 2: update ------------------------------------------------------------------------

    def innovation(
        self, slot: int, z: np.ndarray, model: MeasurementModel | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Innovation of one sighting of landmark ``slot`` and the sparse Jacobian.

        Args:
            slot: landmark slot.
            z: (k,) the sighting.
            model: its measurement model (the state's default when None).

        Returns:
            nu (k,) = z - h(X) (angles wrapped), Hs (k, 3 + dim) = [H_r | H_l] (for
            range-bearing the tutorial's a b c / d e f and -a -b / -d -e columns, from
            ``RangeBearing2D.predict``), and the 3 + dim state indices those columns belong to.
        """
        model = self.model if model is None else model
        cols = landmark_columns(slot, self.landmark_dim)
        z_hat, H_r, H_l = model.predict(self._x[:POSE_DIM], self._x[cols])
        Hs = np.concatenate([H_r, H_l], axis=-1)
        idx = np.array([*range(POSE_DIM), *range(cols.start, cols.stop)])
        return model.residual(z, z_hat), Hs, idx

    def innovation_covariance(self, Hs: np.ndarray, idx: np.ndarray, R: np.ndarray) -> np.ndarray:
        """S = H P H^T + R from the 3 + dim relevant rows and columns of P (tutorial "Passo 2")."""
        return Hs @ self.block(idx) @ Hs.T + R

    def update(
        self,
        slot: int,
        z: np.ndarray,
        R: np.ndarray,
        model: MeasurementModel | None = None,
        gate: float = np.inf,
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """Correct the state with one sighting of landmark ``slot`` (tutorial "Passo 2"), O(n^2).

        K = P H^T S^-1, X' = X + K (z - h), and the Joseph form

            P' = (I - K H) P (I - K H)^T + K R K^T
               = P - K (P H^T)^T - (P H^T - K S) K^T
               = P - (K B^T + B K^T),    B = P H^T - K S / 2,

        the exact expansion for any gain K, using (I - K H) P H^T = P H^T - K (S - R) and S
        symmetric. With the optimal K, P H^T - K S is zero up to rounding; keeping it is what
        makes the Joseph form insensitive (to first order) to rounding errors in K. P H^T is
        gathered from the 3 + dim columns of the robot and the landmark; the correction is
        one symmetric rank-2k product on P's upper triangle (``core.symmetric_update``), so P
        stays exactly symmetric.

        Args:
            slot: landmark slot.
            z: (k,) measured, e.g. (range [m], bearing [rad]).
            R: (k, k) sighting noise covariance.
            model: the sighting's measurement model (the state's default when None).
            gate: an outlier gate on nu^T S^-1 nu: a sighting beyond it leaves the state as it
                is (the innovation and S of the test are the update's own, computed once).

        Returns:
            (nu, S): the innovation (k,) and its covariance (k, k) before the update; None when
            the gate rejected the sighting.
        """
        nu, Hs, idx = self.innovation(slot, z, model)
        d = self.dim
        PHt = self.columns(idx) @ Hs.T  # (d, k)
        S = Hs @ PHt[idx] + R
        S = 0.5 * (S + S.T)
        S_inv = np.linalg.inv(S)
        if np.isfinite(gate) and float(nu @ S_inv @ nu) > gate:
            return None
        K = PHt @ S_inv
        self._x[:d] += K @ nu
        self._x[2] = wrap_angle(self._x[2])
        syr2k_upper(self._P[:d, :d], K, PHt - 0.5 * (K @ S))
        return nu, S

    def update_batch(
        self, slots: np.ndarray, z: np.ndarray, R: np.ndarray, model: MeasurementModel | None = None
    ) -> None:
        """Correct the state with m sightings at once, all linearised at the current state.

        The stacked H (mk x d) has non-zeros only in the robot's and each sighted landmark's
        columns; P H^T is gathered from those columns (d x mk), S = H P H^T + blockdiag(R) and
        the Joseph-form correction of ``update`` is one symmetric rank-2mk product on P's upper
        triangle: the same O(m n^2) as m sequential updates, but one pass over P instead of m
        (the omni filter's ~40 bearings per image). Equal to m sequential updates up to the
        relinearisation between them (exact for a linear model).

        Args:
            slots: (m,) distinct landmark slots.
            z: (m, k) sightings; R: (m, k, k) their noise covariances.
            model: their measurement model (the state's default when None).
        """
        model = self.model if model is None else model
        slots = np.asarray(slots, dtype=int)
        m = slots.size
        if m == 0:
            return
        k_dim, dim_l = int(model.dim_z), self.landmark_dim
        d = self.dim
        cols = POSE_DIM + dim_l * slots[:, None] + np.arange(dim_l)[None, :]  # (m, dim_l)
        z_hat, H_r, H_l = model.predict(self._x[:POSE_DIM], self._x[cols])
        nu = model.residual(np.asarray(z, dtype=float), z_hat).reshape(m * k_dim)
        # H = [H_r | the blocks H_l,i in the sighted landmarks' columns]; as matrix products
        # (BLAS), with the landmark part block-diagonal: (m dim_l, m k)
        H_r = H_r.reshape(m * k_dim, POSE_DIM)
        H_l_t = np.zeros((m * dim_l, m * k_dim))
        for i in range(m):
            H_l_t[i * dim_l : (i + 1) * dim_l, i * k_dim : (i + 1) * k_dim] = H_l[i].T
        # P H^T = P[:, robot] H_r^T + P[:, landmarks] blockdiag(H_l,i^T), (d, mk)
        PHt = self._robot_rows().T @ H_r.T + self.columns(cols.ravel()) @ H_l_t
        # H P H^T from the rows of P H^T that H touches
        HPHt = H_r @ PHt[:POSE_DIM] + H_l_t.T @ PHt[cols.ravel()]
        S = HPHt.reshape(m * k_dim, m * k_dim)
        for i in range(m):
            S[i * k_dim : (i + 1) * k_dim, i * k_dim : (i + 1) * k_dim] += R[i]
        S = 0.5 * (S + S.T)
        K = np.linalg.solve(S, PHt.T).T  # P H^T S^-1 (S symmetric)
        self._x[:d] += K @ nu
        self._x[2] = wrap_angle(self._x[2])
        syr2k_upper(self._P[:d, :d], K, PHt - 0.5 * (K @ S))

    # -- Passo 3: augmentation ------------------------------------------------------------------

    def augment(self, z: np.ndarray, R: np.ndarray, model: object | None = None) -> int:
        """Add a landmark seen at z = (range, bearing) (tutorial "Passo 3"), O(n).

        l = g(x_r, z) = (x_r + r cos(theta_r + b), y_r + r sin(theta_r + b)) with the tutorial's
        J_xr = dg/dx_r and J_z = dg/dz (``RangeBearing2D.inverse``):

            X' = [X; l],   P_ll = J_xr P_rr J_xr^T + J_z R J_z^T,   P_lx = J_xr P_rx.

        Args:
            z: the sighting the landmark is computed from.
            R: its noise covariance.
            model: a model whose ``inverse(wTr, z)`` returns (l (dim,), J_xr (dim, 3),
                J_z (dim, k)): the state's default model when None; the omni filter passes
                ``RangeAzimuthElevation3D`` with a triangulated range.

        Returns:
            the new landmark's slot.
        """
        if self.n_landmarks == self.capacity:
            self._grow(2 * self.capacity)
        inverse = (self.model if model is None else model).inverse  # type: ignore[attr-defined]
        landmark, J_xr, J_z = inverse(self._x[:POSE_DIM], np.asarray(z, dtype=float))
        d, k = self.dim, self.landmark_dim
        P = self._P
        cross = J_xr @ self._robot_rows()  # (k, d) = P_lx
        P[:d, d : d + k] = cross.T  # the new landmark's columns above the diagonal
        P_ll = J_xr @ cross[:, :POSE_DIM].T + J_z @ R @ J_z.T  # J_xr P_rr J_xr^T + J_z R J_z^T
        P[d : d + k, d : d + k] = np.triu(0.5 * (P_ll + P_ll.T))
        self._x[d : d + k] = landmark
        self.n_landmarks += 1
        return self.n_landmarks - 1

    def _grow(self, capacity: int) -> None:
        d = self.dim
        size = POSE_DIM + self.landmark_dim * capacity
        x = np.zeros(size)
        P = np.zeros((size, size))
        x[:d] = self._x[:d]
        P[:d, :d] = self._P[:d, :d]
        self._x, self._P = x, P

    # -- association support --------------------------------------------------------------------

    def mahalanobis_all(
        self, z: np.ndarray, R: np.ndarray, slots: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """nu^T S^-1 nu of one sighting against each landmark in ``slots``, vectorised, O(m).

        S_i = H_r P_rr H_r^T + H_r P_ri H_l^T + H_l P_ir H_r^T + H_l P_ii H_l^T + R, the
        tutorial's innovation covariance of the pairing (sighting, landmark i).

        Returns:
            (d2 (m,), nu (m, 2)).
        """
        if self.landmark_dim != LANDMARK_DIM:
            raise ValueError("mahalanobis_all is for 2-D range-bearing landmarks")
        slots = np.asarray(slots, dtype=int)
        if slots.size == 0:
            return np.zeros(0), np.zeros((0, 2))
        lm = self._x[POSE_DIM + LANDMARK_DIM * slots[:, None] + np.arange(2)[None, :]]
        z_hat, H_r, H_l = self.model.predict(self._x[:POSE_DIM], lm)
        nu = self.model.residual(np.asarray(z, dtype=float)[None, :], z_hat)
        P_rr = self.pose_cov
        cols = POSE_DIM + LANDMARK_DIM * slots[:, None] + np.arange(2)[None, :]  # (m, 2)
        P_ri = np.moveaxis(self._P[:POSE_DIM][:, cols], 0, 1)  # (m, 3, 2), above the diagonal
        P_ii = self.landmark_covariances(slots)
        cross = H_r @ P_ri @ np.swapaxes(H_l, -1, -2)
        S = (
            H_r @ P_rr @ np.swapaxes(H_r, -1, -2)
            + cross
            + np.swapaxes(cross, -1, -2)
            + H_l @ P_ii @ np.swapaxes(H_l, -1, -2)
            + R
        )
        det = S[:, 0, 0] * S[:, 1, 1] - S[:, 0, 1] * S[:, 1, 0]
        a, b, c = S[:, 1, 1], -S[:, 0, 1], S[:, 0, 0]  # adjugate of the symmetric S
        d2 = (a * nu[:, 0] ** 2 + 2 * b * nu[:, 0] * nu[:, 1] + c * nu[:, 1] ** 2) / det
        return d2, nu
