"""The odometry motion model of the thesis (Guizilini 2008, section 4.4.2, eqs. 4.38-4.44).

A planar motion between two frames is decomposed into a first rotation ``rot1``, a translation
``trans`` and a second rotation ``rot2`` (eq. 4.39, after Thrun, Burgard & Fox 2005 sec. 5.4);
each component gets a Gaussian error whose standard deviation grows linearly with the motion,
weighted by four alpha coefficients (eqs. 4.40-4.41); sampled poses are recomposed with eq. 4.44.

Two details the thesis leaves open are fixed here and documented:

* eq. 4.41 multiplies signed displacements; a standard deviation must be non-negative, so the
  magnitudes |rot1|, |trans|, |rot2| are used (as in Thrun et al., Table 5.6).
* a robot that reverses would get ``rot1`` close to pi and a huge rotational std; a negative
  ``trans`` with ``rot1`` near zero describes the same motion, and is used when dx < 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from omnislam.core.se import se2_compose, se2_compose_jacobians, wrap_angle, wrap_angle_inplace

#: translations below this are treated as pure rotations (rot1 is then undefined) [m]
MIN_TRANSLATION_M = 1e-9

_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True, slots=True)
class MotionNoise:
    """The alpha matrix of thesis eq. 4.40 (dimensionless / rad per m / m per rad).

    Attributes:
        a_vv: translation std per metre of translation.
        a_vw: rotation std per metre of translation (enters sigma_rot1, sigma_rot2 in eq. 4.41).
        a_wv: translation std per radian of rotation (enters sigma_trans in eq. 4.41).
        a_ww: rotation std per radian of rotation.
        min_sigma: (3,) floor of the stds of (rot1, trans, rot2) [rad, m, rad], so that a robot
            standing still still has a (small) positive-definite covariance.
        reference_step_m: the step length d0 [m] at which the alphas hold; None (the
            default): eq. 4.41 for every step. A step that translates further than d0 gets eq.
            4.41's stds times sqrt(d0 / |trans|) (``OdometryMotionModel.component_sigmas``), so
            its variances grow *linearly* with its length, as n steps of d0 would add up, and as
            odometry errors that accumulate with the distance travelled do (Siegwart &
            Nourbakhsh 2004 sec. 5.2.4: wheel-travel variances proportional to the distance;
            Chong & Kleeman 1997). Eq. 4.41 alone is not step-size invariant: n pieces of a
            motion sum to 1/n of one step's variance, so alphas set at 10 Hz and 3 cm steps are
            sqrt(n) times too wide on a log whose frames lie n times further apart. Steps up to
            d0 keep eq. 4.41.
    """

    a_vv: float = 0.05
    a_vw: float = 0.01
    a_wv: float = 0.01
    a_ww: float = 0.05
    min_sigma: tuple[float, float, float] = (1e-4, 1e-4, 1e-4)
    reference_step_m: float | None = None

    def __post_init__(self) -> None:
        coefficients = (self.a_vv, self.a_vw, self.a_wv, self.a_ww, *self.min_sigma)
        if not all(0.0 <= c < math.inf for c in coefficients):  # False for NaN
            raise ValueError(
                f"motion noise coefficients must be finite and non-negative, got {coefficients}"
            )
        if self.reference_step_m is not None and not 0.0 < self.reference_step_m < math.inf:
            raise ValueError("reference_step_m must be None or positive and finite")


@runtime_checkable
class MotionModel(Protocol):
    """What an estimator needs from a motion model: ``OdometryMotionModel``,
    ``StatedOdometryMotion``, or any model with the same ``sample`` / ``predict`` /
    ``covariance`` interface.

    ``covariance`` is the step's noise as a Gaussian on the robot-frame delta: what composes the
    odometry of several steps (``compose_odometry``), accumulates the pose spread since a
    landmark was last seen and gives a particle smoother its transition density.
    """

    def sample(self, wTr: np.ndarray, delta_r: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """(P, 3) poses propagated by one odometry delta (3,) with independent noise."""
        ...

    def predict(
        self, wTr: np.ndarray, P: np.ndarray | None, delta_r: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Linearised propagation of pose means [..., 3] and covariances [..., 3, 3] (None:
        exactly known poses) by one odometry delta."""
        ...

    def covariance(self, delta_r: np.ndarray) -> np.ndarray:
        """(3, 3) covariance of the robot-frame delta (3,) [dx, dy, dtheta], in the previous
        pose's frame."""
        ...


@dataclass(frozen=True, slots=True)
class OdometryMotionModel:
    """Sampling, moments and Jacobians of the rot1-trans-rot2 odometry model.

    Odometry deltas are robot-frame motions ``[dx, dy, dtheta]`` of the new pose in the frame of
    the previous one (``omnislam.core.types.Odometry.delta``).
    """

    noise: MotionNoise = MotionNoise()

    def decompose(self, delta_r: np.ndarray) -> np.ndarray:
        """Robot-frame deltas [..., 3] -> [..., 3] = (rot1, trans, rot2), thesis eq. 4.39.

        With the previous pose at the origin, eq. 4.39 reads rot1 = atan2(dy, dx),
        trans = sqrt(dx^2 + dy^2), rot2 = dtheta - rot1. Reversing motion (dx < 0) gets a
        negative trans and rot1 = atan2(-dy, -dx) (see the module docstring).
        """
        delta_r = np.asarray(delta_r, dtype=float)
        if delta_r.shape == (3,):  # one odometry delta per filter step: skip the array overhead
            return np.array(_decompose_one(*delta_r.tolist()))
        dx, dy, dtheta = delta_r[..., 0], delta_r[..., 1], delta_r[..., 2]
        trans = np.hypot(dx, dy)
        backwards = dx < 0
        sign = np.where(backwards, -1.0, 1.0)
        rot1 = np.where(trans > MIN_TRANSLATION_M, np.arctan2(sign * dy, sign * dx), 0.0)
        rot2 = wrap_angle(dtheta - rot1)
        return np.stack([rot1, sign * trans, rot2], axis=-1)

    @staticmethod
    def recompose(components: np.ndarray) -> np.ndarray:
        """(rot1, trans, rot2) [..., 3] -> robot-frame delta [..., 3] (eq. 4.44 from the origin)."""
        components = np.asarray(components, dtype=float)
        rot1, trans, rot2 = components[..., 0], components[..., 1], components[..., 2]
        return np.stack(
            [trans * np.cos(rot1), trans * np.sin(rot1), wrap_angle(rot1 + rot2)], axis=-1
        )

    def component_sigmas(self, components: np.ndarray) -> np.ndarray:
        """Standard deviations of (rot1, trans, rot2) [..., 3] (magnitudes), thesis eq. 4.41:

            sigma_rot1 = a_ww |rot1| + a_vw |trans|
            sigma_trans = a_wv (|rot1| + |rot2|) + a_vv |trans|
            sigma_rot2 = a_ww |rot2| + a_vw |trans|,

        each multiplied by sqrt(d0 / |trans|) when ``noise.reference_step_m`` = d0 is set and
        |trans| > d0 (variances linear in the step's length beyond d0); floored at
        ``noise.min_sigma``.
        """
        n = self.noise
        c = np.abs(np.asarray(components, dtype=float))
        if c.shape == (3,):
            return np.array(_component_sigmas_one(n, *c.tolist()))
        rot1, trans, rot2 = c[..., 0], c[..., 1], c[..., 2]
        sigma = np.stack(
            [
                n.a_ww * rot1 + n.a_vw * trans,
                n.a_wv * (rot1 + rot2) + n.a_vv * trans,
                n.a_ww * rot2 + n.a_vw * trans,
            ],
            axis=-1,
        )
        if n.reference_step_m is not None:
            d0 = n.reference_step_m
            sigma *= np.sqrt(d0 / np.maximum(trans, d0))[..., None]
        return np.maximum(sigma, np.asarray(n.min_sigma))

    def sample_delta(
        self, delta_r: np.ndarray, rng: np.random.Generator, size: int | None = None
    ) -> np.ndarray:
        """Draw noisy versions of one odometry delta, thesis eqs. 4.42-4.43.

        Args:
            delta_r: (3,) the measured (mean) robot-frame delta.
            rng: the random generator (normal draws replace the Box-Muller transform of 4.42).
            size: number of draws; None returns a single (3,) delta.

        Returns:
            (size, 3) or (3,) sampled robot-frame deltas.
        """
        components = self.decompose(delta_r)
        sigma = self.component_sigmas(components)
        shape = (3,) if size is None else (size, 3)
        noisy = components + sigma * rng.standard_normal(shape)
        return self.recompose(noisy)

    def sample(self, wTr: np.ndarray, delta_r: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Propagate P poses by one odometry step with independent noise, eq. 4.44.

        Args:
            wTr: (P, 3) poses [x, y, theta] in the world.
            delta_r: (3,) measured robot-frame delta.
            rng: random generator.

        Returns:
            (P, 3) sampled new poses.
        """
        wTr = np.asarray(wTr, dtype=float)
        components = self.decompose(delta_r)
        sigma = self.component_sigmas(components)
        noisy = rng.standard_normal((wTr.shape[0], 3))
        noisy *= sigma  # components + sigma * draws, without the temporaries
        noisy += components
        return self.apply(wTr, noisy)

    @staticmethod
    def apply(wTr: np.ndarray, components: np.ndarray) -> np.ndarray:
        """Thesis eq. 4.44: x' = x + [t cos(theta + rot1), t sin(theta + rot1), rot1 + rot2]."""
        wTr = np.asarray(wTr, dtype=float)
        components = np.asarray(components, dtype=float)
        out = np.empty(np.broadcast_shapes(wTr.shape, components.shape))
        # in place into the output: the same operations as the formula above, term by term
        heading = np.add(wTr[..., 2], components[..., 0], out=np.empty(out.shape[:-1]))
        x = np.cos(heading, out=out[..., 0])
        x *= components[..., 1]
        x += wTr[..., 0]
        y = np.sin(heading, out=out[..., 1])
        y *= components[..., 1]
        y += wTr[..., 1]
        heading += components[..., 2]  # theta + rot1 + rot2
        out[..., 2] = wrap_angle_inplace(heading)
        return out

    def apply_jacobians(
        self, wTr: np.ndarray, components: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Jacobians of ``apply`` w.r.t. the pose [x, y, theta] and w.r.t. (rot1, trans, rot2).

        Returns:
            (G, V): [..., 3, 3] each; G is the EKF state-transition Jacobian, V maps the
            component noise into the state (Thrun et al. 2005, Table 7.1).
        """
        wTr = np.asarray(wTr, dtype=float)
        components = np.asarray(components, dtype=float)
        shape = np.broadcast_shapes(wTr.shape, components.shape)[:-1]
        heading = wTr[..., 2] + components[..., 0]
        c, s, trans = np.cos(heading), np.sin(heading), components[..., 1]
        G = np.zeros((*shape, 3, 3))
        G[..., 0, 0] = G[..., 1, 1] = G[..., 2, 2] = 1.0
        G[..., 0, 2] = -trans * s
        G[..., 1, 2] = trans * c
        V = np.zeros((*shape, 3, 3))
        V[..., 0, 0] = -trans * s
        V[..., 0, 1] = c
        V[..., 1, 0] = trans * c
        V[..., 1, 1] = s
        V[..., 2, 0] = V[..., 2, 2] = 1.0
        return G, V

    def predict(
        self, wTr: np.ndarray, P: np.ndarray | None, delta_r: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Linearised (EKF) propagation of pose means and covariances by one odometry delta.

        Args:
            wTr: [..., 3] pose means [x, y, theta] in the world.
            P: [..., 3, 3] their covariances, or None for exactly known poses (a particle's
                sampled pose: the FastSLAM 2.0 proposal's prediction, thesis eq. 4.45).
            delta_r: (3,) measured robot-frame delta.

        Returns:
            (mean [..., 3], covariance [..., 3, 3]) = (g(x, u), G P G^T + V M V^T) with
            M = diag(sigma^2) from eq. 4.41; V M V^T alone when P is None.
        """
        components = self.decompose(delta_r)
        G, V = self.apply_jacobians(wTr, components)
        M = np.diag(self.component_sigmas(components) ** 2)
        noise = V @ M @ np.swapaxes(V, -1, -2)
        if P is None:
            return self.apply(wTr, components), noise
        return self.apply(wTr, components), G @ P @ np.swapaxes(G, -1, -2) + noise

    def covariance(self, delta_r: np.ndarray) -> np.ndarray:
        """(3, 3) covariance of the robot-frame delta [dx, dy, dtheta] (linearised).

        This is the noise of an odometry between-factor expressed in the previous pose's frame
        (used by the factor graph and by EKF-SLAM): J diag(sigma^2) J^T with J the Jacobian of
        ``recompose`` at the decomposed delta.

        The decomposition leaves the direction perpendicular to a vanishing translation without
        noise (a robot standing still would get a singular covariance), so the translation
        floor ``min_sigma[1]`` is added isotropically in x and y: the result is always positive
        definite.
        """
        components = self.decompose(delta_r)
        _, V = self.apply_jacobians(np.zeros(3), components)
        floor = self.noise.min_sigma[1] ** 2
        return V @ np.diag(self.component_sigmas(components) ** 2) @ V.T + np.diag(
            [floor, floor, 0.0]
        )


def _decompose_one(dx: float, dy: float, dtheta: float) -> tuple[float, float, float]:
    """``OdometryMotionModel.decompose`` of one delta, on Python floats.

    numpy's ``hypot`` / ``arctan2`` are kept (``math``'s differ in the last bit), and Python's
    float ``%`` is the same floored modulo as numpy's: the result equals the array version's.
    """
    trans = float(np.hypot(dx, dy))
    sign = -1.0 if dx < 0 else 1.0
    rot1 = float(np.arctan2(sign * dy, sign * dx)) if trans > MIN_TRANSLATION_M else 0.0
    rot2 = (dtheta - rot1 + math.pi) % _TWO_PI - math.pi
    return rot1, sign * trans, rot2


def _component_sigmas_one(
    n: MotionNoise, rot1: float, trans: float, rot2: float
) -> tuple[float, float, float]:
    """``OdometryMotionModel.component_sigmas`` of one (|rot1|, |trans|, |rot2|), on floats."""
    floor_rot1, floor_trans, floor_rot2 = n.min_sigma
    d0 = n.reference_step_m
    # the scale of a step longer than d0, as the array path computes it (1.0 up to d0)
    scale = 1.0 if d0 is None or not trans > d0 else float(np.sqrt(d0 / trans))
    return (
        _maximum((n.a_ww * rot1 + n.a_vw * trans) * scale, floor_rot1),
        _maximum((n.a_wv * (rot1 + rot2) + n.a_vv * trans) * scale, floor_trans),
        _maximum((n.a_ww * rot2 + n.a_vw * trans) * scale, floor_rot2),
    )


def _maximum(value: float, floor: float) -> float:
    """``np.maximum`` of two floats (a NaN ``value`` propagates)."""
    return value if value != value or value >= floor else floor


def compose_odometry(
    delta_ab: np.ndarray, cov_ab: np.ndarray, delta_bc: np.ndarray, cov_bc: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Two consecutive odometry deltas composed into one, with the first-order covariance.

    ``aTc = aTb * bTc`` (``se.se2_compose``); with independent errors on the two deltas (each
    additive on [dx, dy, dtheta] in its own start frame, as ``OdometryMotionModel.covariance``
    gives them) the covariance of ``aTc`` in frame a is ``J_a C_ab J_a^T + J_b C_bc J_b^T``
    (``se.se2_compose_jacobians``): the prediction step of thesis eq. 4.45 / ``predict`` with
    the pose taken relative to frame a. Folding the odometry of the frames between two images
    this way gives the one between-factor that replaces their chain (``graphslam.poses``).

    Args:
        delta_ab: (3,) robot-frame delta from a to b [m, m, rad].
        cov_ab: (3, 3) its covariance.
        delta_bc: (3,) delta from b to c, in frame b.
        cov_bc: (3, 3) its covariance.

    Returns:
        (delta_ac (3,), cov_ac (3, 3)), the covariance symmetric.
    """
    J_a, J_b = se2_compose_jacobians(delta_ab, delta_bc)
    cov = J_a @ cov_ab @ J_a.T + J_b @ cov_bc @ J_b.T
    return se2_compose(delta_ab, delta_bc), 0.5 * (cov + cov.T)


@dataclass(frozen=True, slots=True)
class StatedOdometryMotion:
    """The motion of one step whose odometry states its own covariance (``Odometry.covariance``).

    The delta's error is Gaussian and additive on [dx, dy, dtheta] in the previous pose's frame,
    as the factor graph's between-factor and EKF-SLAM's prediction take a stated covariance
    (``OdometryMotionModel.covariance`` is what the loaders state): a sample is
    x' = x (+) (delta + L e), e ~ N(0, I), C = L L^T, and the linearised prediction of an
    exactly known pose is (x (+) delta, J_b C J_b^T) with J_b the Jacobian of the composition
    with respect to the delta (``se.se2_compose_jacobians``; Thrun et al. 2005 Table 7.1 with
    the noise stated in the robot frame). It is a ``MotionModel`` for the one delta it was
    built with.

    Attributes:
        delta: (3,) the measured robot-frame delta [m, m, rad].
        delta_covariance: (3, 3) its covariance (symmetric positive definite), in the previous
            pose's frame.
    """

    delta: np.ndarray
    delta_covariance: np.ndarray

    def covariance(self, delta_r: np.ndarray) -> np.ndarray:
        """(3, 3) the stated covariance (``delta_r`` must be the delta the model was built
        with)."""
        return self.delta_covariance

    def sample(self, wTr: np.ndarray, delta_r: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """(P, 3) poses moved by P independent draws of the delta (``delta_r`` must be the
        delta the model was built with)."""
        wTr = np.asarray(wTr, dtype=float)
        chol = np.linalg.cholesky(self.delta_covariance)
        noisy = rng.standard_normal((wTr.shape[0], 3)) @ chol.T
        noisy += np.asarray(delta_r, dtype=float)
        return se2_compose(wTr, noisy)

    def predict(
        self, wTr: np.ndarray, P: np.ndarray | None, delta_r: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """(x (+) delta, J_a P J_a^T + J_b C J_b^T); ``J_b C J_b^T`` alone when P is None."""
        wTr = np.asarray(wTr, dtype=float)
        delta_r = np.asarray(delta_r, dtype=float)
        J_a, J_b = se2_compose_jacobians(wTr, delta_r)
        noise = J_b @ self.delta_covariance @ np.swapaxes(J_b, -1, -2)
        mean = se2_compose(wTr, delta_r)
        if P is None:
            return mean, noise
        return mean, J_a @ P @ np.swapaxes(J_a, -1, -2) + noise
