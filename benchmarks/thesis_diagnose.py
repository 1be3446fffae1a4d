"""Why FastSLAM does not close route 1's loop: its particle set measured frame by frame.

Runs FastSLAM on ``thesis-route1`` exactly as ``benchmarks/thesis.py``'s cells do (the same
frames, options and seeded generator as ``omnislam run thesis-route1 --seed S --estimator E
--set particles.n_particles=P --set existence.max_range_m=4``; checked: the same trajectory),
with recording proxies round three of the filter's collaborators, which pass every call through
unchanged and draw no random number of the filter's:

* the association (``SightingAssociation.pairs``): at the route's first revisit, the squared
  Mahalanobis distance of each revisit sighting under the landmark each particle made of the
  same pole on its first visit (the pose terms and noise the association uses), against the
  distance at which the pole's log-likelihood falls below log p0 and the particle makes a new
  landmark instead; and whether the existence index had deleted that landmark;
* the landmark update (``LandmarkUpdate``): per (particle, sighting) of an established
  landmark, the innovation log-likelihood (thesis eq. 4.47, FastSLAM 1.0's weight factor) with
  the sighting's stated noise and with the noise the sightings have (their error against the
  truth, measured on the run's own sightings); which landmark each new slot is made of;
* the resampler: the effective sample size (eq. 4.51) before each resampling decision and the
  ancestors of each resampling, from which the paths' distinct ancestors at several lags.

Alongside, two clouds the filter never sees are moved by its own motion model: one from the
particles of the last resampling (the spread the motion model alone adds since then) and one
from the start (dead reckoning's spread, the prior the sightings should narrow).

    python benchmarks/thesis_diagnose.py [--seeds 0 1 2] [--configs fs1-50 fs2-10]

Prints one markdown table per measurement: a row per figure, a column per run (configuration
and seed). ~25 s of CPU a run.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, field

import numpy as np
import thesis_metrics as tm

from omnislam.core.gaussian import log_likelihood_from_mahalanobis
from omnislam.core.measurement import RangeBearing2D
from omnislam.core.se import se2_compose, se2_inverse, se2_transform_points, wrap_angle
from omnislam.datasets.registry import load_dataset, resolve
from omnislam.estimators import make_estimator
from omnislam.fastslam.config import Variant
from omnislam.fastslam.filter import FastSLAM
from omnislam.fastslam.landmark_store import ABSENT, ESTIMATED
from omnislam.fastslam.sightings import Pairs, Sightings
from omnislam.harness.cache import cache_dir
from omnislam.harness.execute import frontend_log_for
from omnislam.harness.frames import fed_frames
from omnislam.harness.layout import LOGS
from omnislam.harness.renders import render_spec

DATASET = "thesis-route1"
#: the configurations (benchmarks/thesis.py's labels): the thesis's two, and its most particles
CONFIGS = {"fs1-50": ("fastslam1", 50), "fs2-10": ("fastslam2", 10),
           "fs1-1000": ("fastslam1", 1000)}
#: the lags at which the paths' distinct ancestors are counted [frames] (10 Hz)
LAGS = (1, 10, 50, 100, 300, 1000)
#: the odometry-alone cloud from the start has this many poses (its share inside the gate at
#: the revisit is ~1e-3: ~20 of them)
PRIOR_CLOUD = 20_000


@dataclass(frozen=True, slots=True)
class RouteTruth:
    """What the render says of the frames the filter steps through.

    Attributes:
        wTr: (N, 3) true poses per frame, in the filter's world (the first pose the origin).
        poles_w: {pole id: (2,) true position} in the same world.
        ids: per frame, (K,) the true pole of each sighting (in the frame's order).
        sightings: every sighting with its true pole (``thesis_metrics.Sightings``).
        revisits: the route's revisits (``thesis_metrics.revisits``).
        first_revisit: the first of them.
        sigma_range_m, sigma_bearing_rad: the sightings' RMS error against the truth.
        stated_R: (2, 2) the noise the sightings state (range [m], bearing [rad]).
    """

    wTr: np.ndarray
    poles_w: dict[int, np.ndarray]
    ids: list[np.ndarray]
    sightings: tm.Sightings
    revisits: list[tm.Revisit]
    first_revisit: tm.Revisit
    sigma_range_m: float
    sigma_bearing_rad: float
    stated_R: np.ndarray


@dataclass
class Trace:
    """What the proxies record over one run (per frame with sightings unless stated)."""

    frames: list[int] = field(default_factory=list)
    ess: list[float] = field(default_factory=list)
    resampled: list[bool] = field(default_factory=list)
    ancestors: dict[int, np.ndarray] = field(default_factory=dict)  # frame -> (P,)
    log_weights: list[np.ndarray] = field(default_factory=list)  # (P,) before resampling
    log_weights_before: list[np.ndarray] = field(default_factory=list)  # (P,) before the step
    sighting_frame: list[int] = field(default_factory=list)  # per sighting of a mapped pole
    sighting_factors: list[np.ndarray] = field(default_factory=list)  # (P,) its ll, stated R
    sighting_factors_true: list[np.ndarray] = field(default_factory=list)  # measured R
    slot_pole: dict[int, int] = field(default_factory=dict)  # slot -> the pole it was made of
    slot_frame: dict[int, int] = field(default_factory=dict)  # slot -> frame it was made at
    revisit: list[dict[str, np.ndarray]] = field(default_factory=list)


def route_truth(seed: int) -> RouteTruth:
    """The true poses, poles and sighting ids of ``seed``'s render, the first revisit and the
    sightings' measured noise."""
    sequence = load_dataset(resolve(str(render_spec(DATASET, seed).path(cache_dir() / "renders"))),
                            {"association": "known"})
    gt = sequence.ground_truth
    # the filter's world is anchored at the first pose (its initial pose is the origin)
    oTw = se2_inverse(gt.trajectory.se2[0])
    wTr = se2_compose(oTw, gt.trajectory.se2)
    poles = se2_transform_points(oTw, gt.landmarks_w[:, :2])
    poles_w = {int(i): poles[k] for k, i in enumerate(gt.landmark_ids)}
    ids = [np.zeros(0, np.int64) if rb is None else np.asarray(rb.landmark_ids)
           for rb in sequence.range_bearing]
    rows = [(k, j) for k, frame_ids in enumerate(ids) for j in range(len(frame_ids))]
    k_of = np.array([k for k, _ in rows])
    rb = sequence.range_bearing
    sightings = tm.Sightings(
        k_of, np.array([ids[k][j] for k, j in rows]),
        np.array([rb[k].ranges_m[j] for k, j in rows]),
        np.array([rb[k].bearings_rad[j] for k, j in rows]))
    true_w = np.array([poles_w[int(p)] for p in sightings.poles])
    delta = true_w - wTr[k_of, :2]
    range_error = sightings.ranges_m - np.hypot(delta[:, 0], delta[:, 1])
    bearing_error = wrap_angle(sightings.bearings_rad
                               - (np.arctan2(delta[:, 1], delta[:, 0]) - wTr[k_of, 2]))
    travel = tm.travelled_m(wTr[:, :2])
    found = tm.revisits(sightings, travel)
    seen = next(r for r in rb if r is not None and len(r))
    stated = np.diag([seen.sigma_range_m[0] ** 2, seen.sigma_bearing_rad[0] ** 2])
    return RouteTruth(wTr, poles_w, ids, sightings, found, found[0],
                      float(np.sqrt(np.mean(range_error**2))),
                      float(np.sqrt(np.mean(bearing_error**2))), stated)


class _Resampling:
    """Proxy of the filter's ``Resampler``: records the ESS and the ancestors, passes through."""

    def __init__(self, inner: object, trace: Trace, clock: list[int]) -> None:
        self._inner, self._trace, self._clock = inner, trace, clock

    def __getattr__(self, name: str) -> object:
        return getattr(self._inner, name)

    def __call__(self, particles, store, history, ess):
        """``Resampler.__call__``, the weights, ESS and ancestors recorded."""
        self._trace.log_weights.append(particles.log_weights.copy())
        ancestors = self._inner(particles, store, history, ess)
        frame = self._clock[0]
        self._trace.frames.append(frame)
        self._trace.ess.append(float(ess))
        self._trace.resampled.append(ancestors is not None)
        if ancestors is not None:
            self._trace.ancestors[frame] = np.asarray(ancestors).copy()
        return ancestors


class _Update:
    """Proxy of the filter's ``LandmarkUpdate``: per (particle, sighting) log-likelihoods of the
    established landmarks before the update (stated and measured noise), the poles of new slots."""

    def __init__(self, inner: object, store: object, log_p0: float, trace: Trace,
                 truth: RouteTruth, clock: list[int]) -> None:
        self._inner, self._store, self._trace, self._truth = inner, store, trace, truth
        self._log_p0, self._clock = log_p0, clock
        self._model = RangeBearing2D()

    def __call__(self, poses, sightings: Sightings, pairs: Pairs, gathered=None):
        """``LandmarkUpdate.__call__``, the pairs' log-likelihoods recorded first."""
        frame = self._clock[0]
        block = self._store.gather(pairs.particle, pairs.slot)
        ids = self._truth.ids[frame]
        for slot, obs in zip(pairs.slot[pairs.new_unknown], pairs.obs[pairs.new_unknown],
                             strict=True):
            self._trace.slot_pole.setdefault(int(slot), int(ids[obs]))
            self._trace.slot_frame.setdefault(int(slot), frame)
        known = block.status == ESTIMATED
        stated = self._log_likelihood(poses, sightings, pairs, block, known, None)
        measured = self._log_likelihood(poses, sightings, pairs, block, known, self._truth)
        stated = np.where(pairs.new_unknown, self._log_p0, stated)
        measured = np.where(pairs.new_unknown, self._log_p0, measured)
        p = len(poses)
        for k in range(len(sightings.z)):
            rows = np.flatnonzero(pairs.obs == k)
            if not known[rows].any():
                continue  # a pole no particle has mapped yet: every particle weighs p0
            factor, factor_true = np.full(p, np.nan), np.full(p, np.nan)
            factor[pairs.particle[rows]] = stated[rows]
            factor_true[pairs.particle[rows]] = measured[rows]
            self._trace.sighting_frame.append(frame)
            self._trace.sighting_factors.append(factor)
            self._trace.sighting_factors_true.append(factor_true)
        return self._inner(poses, sightings, pairs, gathered)

    def _log_likelihood(self, poses, sightings, pairs, block, known, truth):
        """log N(z; h(x, mu), H Sigma H^T + R) of the pairs (R stated, or the measured noise)."""
        wTr = poses[pairs.particle]
        z_hat, _, H_m = self._model.predict(wTr, block.mean)
        R = sightings.R[pairs.obs].copy()
        if truth is not None:
            R[:] = np.diag([truth.sigma_range_m**2, truth.sigma_bearing_rad**2])
        S = H_m @ block.cov @ np.swapaxes(H_m, -1, -2) + R
        S[~known] = np.eye(2)
        y = self._model.residual(sightings.z[pairs.obs], z_hat)
        d2 = np.einsum("ni,nij,nj->n", y, np.linalg.inv(S), y)
        return np.where(known, log_likelihood_from_mahalanobis(d2, np.log(np.linalg.det(S)), 2),
                        np.nan)


class _Association:
    """Proxy of the filter's ``SightingAssociation``: at the first revisit's frames, the squared
    Mahalanobis distance of the revisited pole's sightings under each particle's old landmark."""

    def __init__(self, inner: object, store: object, log_p0: float, trace: Trace,
                 truth: RouteTruth, clock: list[int]) -> None:
        self._inner, self._store, self._log_p0 = inner, store, log_p0
        self._trace, self._truth, self._clock = trace, truth, clock
        self._model = RangeBearing2D()
        revisit = truth.first_revisit
        self._frames = set(truth.sightings.frames[revisit.window].tolist())

    def __getattr__(self, name: str) -> object:
        return getattr(self._inner, name)

    def pairs(self, sightings, poses, pose_cov, weights):
        """``SightingAssociation.pairs``, measured first at the revisit's frames."""
        frame = self._clock[0]
        if frame in self._frames:
            self._measure(frame, sightings, poses, pose_cov, weights)
        return self._inner.pairs(sightings, poses, pose_cov, weights)

    def _measure(self, frame, sightings, poses, pose_cov, weights):
        """The revisited pole's first sighting of ``frame`` under each particle's old landmark
        of it, with the association's pose terms and noise (FastSLAM 2.0: the prediction's
        covariance)."""
        pole = self._truth.first_revisit.pole
        first_visit_end = int(self._truth.sightings.frames[self._truth.first_revisit.first_visit]
                              .max())
        old = [s for s, p in self._trace.slot_pole.items()
               if p == pole and self._trace.slot_frame[s] <= first_visit_end]
        obs = np.flatnonzero(self._truth.ids[frame] == pole)
        if not old or not obs.size:
            return
        p = len(poses)
        block = self._store.gather(np.repeat(np.arange(p), len(old)), np.tile(old, p))
        mean = block.mean.reshape(p, len(old), 2)
        cov = block.cov.reshape(p, len(old), 2, 2)
        alive = (block.status == ESTIMATED).reshape(p, len(old))
        z_hat, H_x, H_m = self._model.predict(poses[:, None, :], mean)
        S = H_m @ cov @ np.swapaxes(H_m, -1, -2) + sightings.R[obs[0]]
        if pose_cov is not None:
            S = S + H_x @ pose_cov[:, None] @ np.swapaxes(H_x, -1, -2)
        S = np.where(alive[..., None, None], S, np.eye(2))
        y = self._model.residual(sightings.z[obs[0]], z_hat)
        d2 = np.einsum("pci,pcij,pcj->pc", y, np.linalg.inv(S), y)
        logdet = np.log(np.linalg.det(S))
        gate = -2.0 * self._log_p0 - logdet - 2 * np.log(2 * np.pi)  # d2 where ll = log p0
        d2 = np.where(alive, d2, np.inf)
        best = np.argmin(d2, axis=1)
        rows = np.arange(p)
        true_pole = self._truth.poles_w[pole]
        self._trace.revisit.append({
            "frame": np.array(frame),
            "d2": d2[rows, best],
            "gate": gate[rows, best],
            "deleted": (~alive).all(axis=1) & (block.status.reshape(p, len(old)) == ABSENT).all(
                axis=1),
            "weights": np.asarray(weights).copy(),
            "pose_error_m": np.hypot(*(poses[:, :2] - self._truth.wTr[frame, :2]).T),
            "map_error_m": np.hypot(*(mean[rows, best] - true_pole).T),
            "miss_m": np.hypot(*(mean[rows, best] - _placed(poses, sightings.z[obs[0]])).T),
            "existence": block.existence.reshape(p, len(old))[rows, best],
            "new_slots": np.array(sum(
                1 for s, q in self._trace.slot_pole.items()
                if q == pole and self._trace.slot_frame[s] > first_visit_end)),
        })


def _placed(poses: np.ndarray, z: np.ndarray) -> np.ndarray:
    """(P, 2) where a (range, bearing) sighting puts its pole from each pose [m]."""
    angle = poses[:, 2] + z[1]
    return poses[:, :2] + z[0] * np.column_stack([np.cos(angle), np.sin(angle)])


def instrumented(estimator: str, particles: int, seed: int) -> tuple[FastSLAM, list, RouteTruth,
                                                                        Trace, list[int]]:
    """A FastSLAM built as the thesis grid's cell (seed, options, frames) with the proxies."""
    dataset = str(render_spec(DATASET, seed).path(cache_dir() / "renders"))
    sequence = load_dataset(resolve(dataset), {})
    log = frontend_log_for(sequence, dataset, cache_dir() / LOGS)
    fed = fed_frames(sequence, estimator, None if log is None else str(log), seed=seed)
    options = {"particles.n_particles": str(particles), "existence.max_range_m": "4"}
    filt = make_estimator(estimator, fed.info, options, np.random.default_rng(seed))
    assert isinstance(filt, FastSLAM)
    truth = route_truth(seed)
    trace, clock = Trace(), [0]
    filt._resampler = _Resampling(filt._resampler, trace, clock)
    log_p0 = filt.config.association.new_landmark_log_likelihood
    filt._landmarks = _Update(filt._landmarks, filt.store, log_p0, trace, truth, clock)
    filt._association = _Association(filt._association, filt.store, log_p0, trace, truth,
                                     clock)
    return filt, fed.frames, truth, trace, clock


@dataclass(frozen=True, slots=True)
class Spreads:
    """Per frame [m, rad]: the particles' weighted position and heading std, the position std
    of the two motion-only clouds, and the weighted mean's true position and heading error."""

    filter_m: np.ndarray
    filter_rad: np.ndarray
    since_resampling_m: np.ndarray
    from_start_m: np.ndarray
    error_m: np.ndarray
    error_rad: np.ndarray
    prior_at_revisit: np.ndarray


def position_std(poses: np.ndarray) -> float:
    """sqrt(var x + var y) of a cloud of poses (N, 3) [m]."""
    return float(np.sqrt(np.sum(np.var(poses[:, :2], axis=0))))


def run(filt: FastSLAM, frames: list, truth: RouteTruth, trace: Trace, clock: list[int],
        seed: int) -> Spreads:
    """Step the filter through ``frames`` (``clock``: the frame index the proxies read), moving
    the motion-only clouds beside it, each with a generator of its own (the cloud from the
    start is the same whatever the filter)."""
    rng_since, rng_start = np.random.default_rng([seed, 1]), np.random.default_rng([seed, 2])
    motion = filt._motion
    n = len(frames)
    out = {name: np.zeros(n) for name in Spreads.__slots__}
    revisit = truth.first_revisit.frame
    since = filt.particles.poses.copy()
    start = np.repeat(since[:1], PRIOR_CLOUD, axis=0)
    for frame in frames:
        clock[0] = k = frame.index
        before = filt.particles.log_weights.copy()
        filt.step(frame)
        since = motion.sample(since, frame.odometry.delta, rng_since)
        start = motion.sample(start, frame.odometry.delta, rng_start)
        if trace.frames and trace.frames[-1] == k:
            trace.log_weights_before.append(before)
            if trace.resampled[-1]:
                since = filt.particles.poses.copy()
        out["since_resampling_m"][k] = position_std(since)
        out["from_start_m"][k] = position_std(start)
        if k == revisit:
            out["prior_at_revisit"] = start.copy()
    trajectory, covs = filt.history.mean_trajectory()
    mean = trajectory.se2
    out["filter_m"] = np.sqrt(covs[:, 0, 0] + covs[:, 1, 1])
    out["filter_rad"] = np.sqrt(covs[:, 2, 2])
    out["error_m"] = np.hypot(*(mean[:, :2] - truth.wTr[:, :2]).T)
    out["error_rad"] = np.abs(wrap_angle(mean[:, 2] - truth.wTr[:, 2]))
    return Spreads(**out)


# -- the measurements of one run ------------------------------------------------------------
def ess_alone(log_factors: np.ndarray) -> float:
    """Effective sample size (thesis eq. 4.51) of equal weights times exp(log_factors)."""
    w = np.exp(log_factors - np.nanmax(log_factors))
    w = np.nan_to_num(w) / np.nansum(w)
    return float(1.0 / np.sum(w * w))


def lineages(ancestors: dict[int, np.ndarray], p: int, t: int, max_lag: int) -> np.ndarray:
    """(max_lag + 1,) distinct particles of frame t - L that the set after frame t descends
    from, L = 0..max_lag (``particles.PathHistory.lineages`` over the recorded resamplings)."""
    index = np.arange(p)
    counts = np.empty(max_lag + 1, dtype=np.int64)
    for lag in range(max_lag + 1):
        resampling = ancestors.get(t - lag)
        if resampling is not None:
            index = np.unique(resampling[index])
        counts[lag] = index.size
    return counts


@dataclass(frozen=True, slots=True)
class Measured:
    """One run's figures (the tables' rows)."""

    label: str
    seed: int
    resampling: dict[str, float]
    coalescence: dict[str, float]
    spreads: dict[str, float]
    weights: dict[str, float]
    revisit: dict[str, float]


def measure(label: str, filt: FastSLAM, trace: Trace, spreads: Spreads, truth: RouteTruth,
            seed: int) -> Measured:
    """The tables' figures of one instrumented run."""
    p = len(filt.particles)
    revisit = _revisit(trace)
    revisit["odometry-alone cloud inside the gate"] = prior_inside_gate(
        spreads.prior_at_revisit, truth, truth.stated_R,
        filt.config.association.new_landmark_log_likelihood)
    # benchmarks/thesis.py's criterion: the revisit's placements within 0.5 m of the first's
    errors = tm.revisit_errors(truth.sightings, truth.revisits, filt.estimate().trajectory.se2)
    revisit["first: placement error (thesis_metrics) [m]"] = float(errors[0])
    revisit["revisits placed within 0.5 m (thesis_metrics)"] = float(
        np.sum(errors <= tm.CLOSE_M))
    revisit["revisits"] = float(len(errors))
    return Measured(label, seed, _resampling(trace, p), _coalescence(trace, p, truth),
                    _spreads(spreads, truth),
                    _weights(trace, p, filt.config.variant is Variant.FASTSLAM1), revisit)


def _resampling(trace: Trace, p: int) -> dict[str, float]:
    ess = np.array(trace.ess)
    resampled = np.array(trace.resampled)
    frames = np.array(trace.frames)
    at = frames[resampled]
    distinct = [np.unique(trace.ancestors[f]).size for f in at]
    frame_alone = [ess_alone(after - before) for after, before in
                   zip(trace.log_weights, trace.log_weights_before, strict=True)]
    frame_alone = np.array(frame_alone)
    return {
        "frames with sightings": len(frames),
        "resamplings": int(resampled.sum()),
        "share resampled": float(resampled.mean()),
        "median frames between": float(np.median(np.diff(at))) if at.size > 1 else np.nan,
        "median ESS / P": float(np.median(ess) / p),
        "median ESS / P at resampling": float(np.median(ess[resampled]) / p),
        "median distinct ancestors / P": float(np.median(distinct) / p),
        "resamplings one frame decides": float(np.mean(frame_alone[resampled] < 0.5 * p)),
        "median frame-alone ESS / P": float(np.median(frame_alone) / p),
    }


def _coalescence(trace: Trace, p: int, truth: RouteTruth) -> dict[str, float]:
    n = len(truth.wTr)
    times = np.arange(max(LAGS) + 1, n, 25)
    counts = np.array([lineages(trace.ancestors, p, t, max(LAGS)) for t in times])
    one = np.array([np.argmax(c == 1) if (c == 1).any() else np.nan for c in counts])
    out = {f"distinct at lag {lag}": float(np.median(counts[:, lag])) for lag in LAGS}
    out["median frames back to one ancestor"] = float(np.nanmedian(one))
    out["times coalesced within 1000 frames"] = float(np.mean(np.isfinite(one)))
    k = truth.first_revisit.frame
    at_revisit = lineages(trace.ancestors, p, k, min(k, 3000))
    out["revisit: frames back to one ancestor"] = (
        float(np.argmax(at_revisit == 1)) if (at_revisit == 1).any() else np.nan)
    out["revisit: distinct at the first visit"] = float(
        at_revisit[k - int(truth.sightings.frames[truth.first_revisit.first_visit].min())])
    return out


def _spreads(s: Spreads, truth: RouteTruth) -> dict[str, float]:
    k = truth.first_revisit.frame
    out = {
        "median std [m]": float(np.median(s.filter_m)),
        "median since-resampling std [m]": float(np.median(s.since_resampling_m)),
        "median error [m]": float(np.median(s.error_m)),
        "median error / std": float(np.median(s.error_m / np.maximum(s.filter_m, 1e-9))),
        "median heading std [deg]": float(np.degrees(np.median(s.filter_rad))),
        "median heading error [deg]": float(np.degrees(np.median(s.error_rad))),
    }
    for name, frame in (("half-way", len(s.error_m) // 2), ("revisit", k)):
        out[f"{name}: std [m]"] = float(s.filter_m[frame])
        out[f"{name}: since-resampling std [m]"] = float(s.since_resampling_m[frame])
        out[f"{name}: odometry-alone std [m]"] = float(s.from_start_m[frame])
        out[f"{name}: error [m]"] = float(s.error_m[frame])
    return out


def _weights(trace: Trace, p: int, weighs_innovations: bool) -> dict[str, float]:
    """The weights' figures; ``weighs_innovations``: the filter's factors are the innovation
    likelihoods (FastSLAM 1.0), checked against the recomputed ones."""
    factors = np.array(trace.sighting_factors)
    factors_true = np.array(trace.sighting_factors_true)
    spread = np.nanmax(factors, axis=1) - np.nanmin(factors, axis=1)
    spread_true = np.nanmax(factors_true, axis=1) - np.nanmin(factors_true, axis=1)
    alone = np.array([ess_alone(f) for f in factors])
    frame_spread = np.array([np.ptp(a - b) for a, b in
                             zip(trace.log_weights, trace.log_weights_before, strict=True)])
    return {
        "median frame log-factor range": float(np.median(frame_spread)),
        "p90 frame log-factor range": float(np.percentile(frame_spread, 90)),
        "median sighting log-lik range (stated R)": float(np.nanmedian(spread)),
        "median sighting log-lik range (measured R)": float(np.nanmedian(spread_true)),
        "p90 sighting log-lik range (stated R)": float(np.nanpercentile(spread, 90)),
        "sightings whose ESS alone < P/2": float(np.mean(alone < 0.5 * p)),
        "filter's factor - recomputed eq. 4.47 (max range)": (
            _recomputed_gap(trace) if weighs_innovations else np.nan),
    }


def _recomputed_gap(trace: Trace) -> float:
    """The largest range across particles of (the filter's log weight factor of a frame - the
    sum of the frame's recomputed sighting log-likelihoods): 0 up to rounding when the filter
    weighs with S = H Sigma H^T + R as stated."""
    frames = np.array(trace.sighting_frame)
    factors = np.array(trace.sighting_factors)
    gap = 0.0
    for frame, after, before in zip(trace.frames, trace.log_weights, trace.log_weights_before,
                                    strict=True):
        mine = factors[frames == frame].sum(axis=0)
        gap = max(gap, float(np.ptp(after - before - mine)))
    return gap


def prior_inside_gate(prior: np.ndarray, truth: RouteTruth, R: np.ndarray, log_p0: float) -> float:
    """Share of the odometry-alone cloud at the first revisit whose prediction of the revisit's
    first sighting, from the true pole, has a log-likelihood above log p0 under the sighting's
    noise ``R`` alone: the share of particles that would re-associate it if the filter kept
    the odometry's spread and mapped the pole exactly."""
    row = truth.first_revisit.window[0]
    z = np.array([truth.sightings.ranges_m[row], truth.sightings.bearings_rad[row]])
    z_hat, _, _ = RangeBearing2D().predict(prior, np.broadcast_to(
        truth.poles_w[truth.first_revisit.pole], (len(prior), 2)))
    y = RangeBearing2D().residual(z, z_hat)
    d2 = np.einsum("ni,ij,nj->n", y, np.linalg.inv(R), y)
    gate = -2.0 * log_p0 - np.log(np.linalg.det(R)) - 2 * np.log(2 * np.pi)
    return float(np.mean(d2 <= gate))


def _revisit(trace: Trace) -> dict[str, float]:
    if not trace.revisit:
        return {"frames measured": 0}
    first, last = trace.revisit[0], trace.revisit[-1]
    inside = [np.mean(r["d2"] <= r["gate"]) for r in trace.revisit]
    return {
        "frames measured": len(trace.revisit),
        "first: median d2": float(np.median(first["d2"])),
        "first: median gate d2": float(np.median(first["gate"])),
        "first: min d2": float(np.min(first["d2"])),
        "first: particles inside the gate": float(np.mean(first["d2"] <= first["gate"])),
        "any frame: particles inside the gate": float(np.max(inside)),
        "first: old landmark deleted": float(np.mean(first["deleted"])),
        "first: median existence index of the old landmark": float(
            np.median(first["existence"][~first["deleted"]])) if (~first["deleted"]).any()
        else np.nan,
        "last: old landmark deleted": float(np.mean(last["deleted"])),
        "last: slots made anew for the pole": float(last["new_slots"]),
        "first: median particle error [m]": float(np.median(first["pose_error_m"])),
        "first: median old landmark error [m]": float(np.median(first["map_error_m"])),
        "first: median miss [m]": float(np.median(first["miss_m"])),
        "first: min miss [m]": float(np.min(first["miss_m"])),
    }


# -- the tables -----------------------------------------------------------------------------
SECTIONS = (
    ("resampling", "Resampling (per frame with sightings; ESS before the decision)"),
    ("coalescence", "Path coalescence (distinct ancestors of the current set's paths, "
     "median over every 25th frame)"),
    ("spreads", "Pose spread against the error (weighted std of the particles; the motion "
     "model's clouds; the weighted mean's error)"),
    ("weights", "Weights' dynamic range (log-likelihood range across particles)"),
    ("revisit", "The route's first revisit (the association test of the revisited pole)"),
)


def table(section: str, runs: list[Measured]) -> str:
    """One section's markdown table: a row per figure, a column per run."""
    head = "| figure | " + " | ".join(f"{m.label} s{m.seed}" for m in runs) + " |"
    lines = [head, "|---" * (len(runs) + 1) + "|"]
    for name in getattr(runs[0], section):
        cells = [_cell(getattr(m, section).get(name, np.nan)) for m in runs]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _cell(value: float) -> str:
    """A figure as the tables write it: whole numbers whole, the rest to 3 digits."""
    return str(int(value)) if np.isfinite(value) and float(value).is_integer() else f"{value:.3g}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--configs", nargs="+", choices=sorted(CONFIGS),
                        default=["fs1-50", "fs2-10"])
    args = parser.parse_args()
    runs = []
    for label in args.configs:
        estimator, particles = CONFIGS[label]
        for seed in args.seeds:
            print(f"{label} seed {seed} ...", file=sys.stderr, flush=True)
            filt, frames, truth, trace, clock = instrumented(estimator, particles, seed)
            spreads = run(filt, frames, truth, trace, clock, seed)
            runs.append(measure(label, filt, trace, spreads, truth, seed))
            print(f"  sightings' error: range {truth.sigma_range_m:.4f} m, bearing "
                  f"{np.degrees(truth.sigma_bearing_rad):.2f} deg (stated "
                  f"{np.sqrt(truth.stated_R[0, 0]):.4f} m, "
                  f"{np.degrees(np.sqrt(truth.stated_R[1, 1])):.2f} deg)", file=sys.stderr)
    for section, title in SECTIONS:
        print(f"\n### {title}\n\n{table(section, runs)}")


if __name__ == "__main__":
    main()
