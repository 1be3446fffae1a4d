"""The floor tracks as metric landmarks of the final graph (``FloorConfig.landmarks``).

``FloorScale`` measures the odometry's scale with pairs of floor sightings over a trajectory;
over the graph's own trajectory (``FloorScale.refined``) a pair's scale still spreads by a few %
on lab40 (p10-p90 0.970-1.022 of the true baseline over 5-15 cm): most floor sightings are in
images between key frames, whose poses are the key frame's composed with the wheel odometry,
and ~60 inlier pairs leave the final scale ~0.3 % off (lab40 seed 0: the map 0.37 % small).

Here the floor points enter the final solve instead, so that every floor sighting is weighed
against every bearing and odometry factor (the ground-plane constraint of monocular visual
odometry, now inside the bundle adjustment rather than beside it):

* each track of the floor's mode (``FloorScale.floor_tracks``) becomes a ``Point3`` with a
  bearing factor per sighting and a prior on its height alone, z = 0 with std
  ``FLOOR_HEIGHT_SIGMA_M`` (x and y free): seen from viewpoints held at the camera height h,
  its bearings then fix its range metrically, ``h / tan(depression)``;
* with ``new_viewpoints`` (``FloorConfig.viewpoints``; not the default: the front
  end's floor tracks have sightings in every image) an image with floor sightings
  that is no key frame gets a ``Pose3`` of its own, with the
  planar prior, a between-factor of the odometry from its key frame and its bearings of the
  landmarks already in the graph (outliers gated), so the floor points hang on a viewpoint
  the bearings hold, not on odometry composed over up to ``keyframe_spacing_m``;
* with ``new_viewpoints`` off (``FloorConfig``'s default) only the key frames' floor
  sightings enter, and the joint solve stays the size of the graph whatever the number of
  floor tracks;
* a floor track's sightings whose floor point lies more than ``max(FLOOR_POINT_GATE_M,
  FLOOR_POINT_GATE_SIGMAS sigma)`` from the track's median floor point are wrong associations
  of the front end and left out; a track keeps at least two sightings or is left out.

The odometry's scale is then a fixed point (``OdometryScaling._joint_floor_scale``): its
translations are multiplied by the scale at which the solved key-frame trajectory agrees with
them (``odometry_ratio`` = 1, found by the secant method in 2-3 re-solves), so that the
odometry, which would otherwise hold the map near the wheels' scale, no longer pulls it and
the floor decides the map's scale. Nothing here changes a graph without floor tracks.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from omnislam._optional import require
from omnislam.core.se import se2_transform_points, se3_inverse
from omnislam.core.triangulation import floor_points_r
from omnislam.graphslam import factors as fx

gtsam = require("gtsam")

#: std of a floor landmark's height about the floor plane z = 0 [m]: a floor's texture lies
#: within mm of it. lab40 seeds 0/1/2, Sim2 scale error of the final map: 2 mm 0.02/0.02/0.03 %,
#: 1 mm 0.04/0.06/0.04 %, 5 mm 0.14/0.09/0.01 %, 10 mm 0.19/0.15/0.03 % (the floor's mode also
#: admits a few points 3-5 cm above the floor, which a looser prior lets pull harder)
FLOOR_HEIGHT_SIGMA_M = 0.002
#: a floor sighting whose floor point lies further than this from its track's median is dropped
FLOOR_POINT_GATE_M = 0.02
#: ... or this many of its own sigmas, when larger
FLOOR_POINT_GATE_SIGMAS = 5.0
#: a bearing of a new viewpoint further than this from its mapped landmark is not added [rad]
#: (the viewpoint's guess is the key frame's composed with at most ``keyframe_spacing_m`` of
#: odometry, a few mm off)
VIEWPOINT_GATE_RAD = np.radians(1.0)
#: ... or this many of the bearing's sigmas, when larger
VIEWPOINT_GATE_SIGMAS = 5.0


@dataclass(frozen=True, slots=True)
class Sightings:
    """One image's bearings of tracks (the graph builder's input, kept for the final solve).

    Attributes:
        ids: (M,) track ids.
        rays_s: (M, 3) unit bearings in the sensor (= robot axes) frame.
        sigmas_rad: (M,) their angular stds [rad].
    """

    ids: np.ndarray
    rays_s: np.ndarray
    sigmas_rad: np.ndarray


@dataclass(frozen=True, slots=True)
class FloorLandmarks:
    """What the floor tracks add to the final graph (module docstring).

    Attributes:
        factors: ``gtsam.NonlinearFactorGraph``: floor bearings, height priors, the new
            viewpoints' planar priors and bearings (their odometry factors depend on the
            odometry's scale: ``GraphSLAM`` adds them).
        values: ``gtsam.Values``: starting points of the new viewpoints and floor landmarks.
        frames: frames whose viewpoint is new (no key frames), ascending.
        tracks: (T,) floor tracks used, ascending.
        keys: GTSAM keys of every new variable (to leave them out of the estimate).
    """

    factors: Any
    values: Any
    frames: tuple[int, ...]
    tracks: np.ndarray
    keys: frozenset[int]


def floor_landmarks(
    floor_tracks: np.ndarray,
    sightings: dict[int, Sightings],
    planar_w: np.ndarray,
    key_frames: list[int],
    mapped_w: dict[int, np.ndarray],
    height_m: float,
    planar_prior_noise: Any,
    new_viewpoints: bool = True,
) -> FloorLandmarks:
    """The factors and variables the floor tracks add to the final graph (module docstring).

    Args:
        floor_tracks: (T,) ids of the tracks of the floor's mode.
        sightings: every image's bearings by frame.
        planar_w: (N, 3) every frame's pose [x, y, theta] in the world (the starting point).
        key_frames: frames with a pose variable in the graph.
        mapped_w: landmark id -> (3,) position of every landmark in the graph [m] (world).
        height_m: the camera viewpoint's height above the floor [m].
        planar_prior_noise: noise model of the planar prior of a viewpoint (``poses.py``).
        new_viewpoints: the floor sightings of frames that are no key frames enter with a
            viewpoint of their own (``FloorConfig.viewpoints``); False: they are
            left out.

    Returns:
        The ``FloorLandmarks``; empty when no floor track keeps two sightings.
    """
    floor = np.asarray(floor_tracks)
    keys = set(key_frames)
    per_track: dict[int, list[tuple[int, np.ndarray, float, np.ndarray, float]]] = {}
    for frame, seen in sightings.items():
        if not new_viewpoints and frame not in keys:
            continue
        down = np.isin(seen.ids, floor) & (seen.rays_s[:, 2] < 0)
        if not down.any():
            continue
        rays, sigmas = seen.rays_s[down], seen.sigmas_rad[down]
        points_r, sigmas_m = floor_points_r(rays, sigmas, height_m)
        points_w = se2_transform_points(planar_w[frame], points_r)
        for lid, ray, sigma, point, sigma_m in zip(
            seen.ids[down].tolist(),
            rays,
            sigmas.tolist(),
            points_w,
            sigmas_m.tolist(),
            strict=True,
        ):
            per_track.setdefault(lid, []).append((frame, ray, sigma, point, sigma_m))
    factors = gtsam.NonlinearFactorGraph()
    values = gtsam.Values()
    height_noise = gtsam.noiseModel.Diagonal.Precisions(
        np.array([0.0, 0.0, FLOOR_HEIGHT_SIGMA_M**-2])
    )
    used: list[int] = []
    frames: set[int] = set()
    for lid, rows in sorted(per_track.items()):
        median = np.median(np.array([row[3] for row in rows]), axis=0)
        kept = [
            row
            for row in rows
            if np.linalg.norm(row[3] - median)
            <= max(FLOOR_POINT_GATE_M, FLOOR_POINT_GATE_SIGMAS * row[4])
        ]
        if len(kept) < 2:
            continue
        used.append(lid)
        factors.add(gtsam.PriorFactorPoint3(fx.landmark_key(lid), np.zeros(3), height_noise))
        if lid in mapped_w:  # its bearings are in the graph already
            continue
        values.insert(fx.landmark_key(lid), np.array([median[0], median[1], 0.0]))
        for frame, ray, sigma, _, _ in kept:
            factors.add(fx.bearing_3d(frame, lid, ray, gtsam.noiseModel.Isotropic.Sigma(2, sigma)))
            frames.add(frame)
    new_frames = sorted(frames - keys)
    for frame in new_frames:
        viewpoint = fx.pose3_planar(planar_w[frame], height_m)
        values.insert(fx.pose_key(frame), viewpoint)
        factors.add(gtsam.PriorFactorPose3(fx.pose_key(frame), viewpoint, planar_prior_noise))
        _add_mapped_bearings(factors, frame, sightings[frame], viewpoint, mapped_w)
    new_keys = frozenset(int(key) for key in values.keys())
    return FloorLandmarks(
        factors, values, tuple(new_frames), np.array(used, dtype=np.int64), new_keys
    )


def _add_mapped_bearings(
    factors: Any, frame: int, seen: Sightings, viewpoint: Any, mapped_w: dict[int, np.ndarray]
) -> None:
    """A new viewpoint's bearings of the graph's landmarks, those pointing away from their
    landmark (``VIEWPOINT_GATE_*``) left out."""
    wRs = viewpoint.rotation().matrix()
    origin_w = np.asarray(viewpoint.translation())
    kept: list[int] = []
    for row, (lid, ray, sigma) in enumerate(
        zip(seen.ids.tolist(), seen.rays_s, seen.sigmas_rad.tolist(), strict=True)
    ):
        point_w = mapped_w.get(lid)
        if point_w is None:
            continue
        to_point = wRs.T @ (point_w - origin_w)
        cosine = ray @ to_point / max(np.linalg.norm(to_point), 1e-12)
        if cosine >= np.cos(max(VIEWPOINT_GATE_SIGMAS * sigma, VIEWPOINT_GATE_RAD)):
            kept.append(row)
    for row in kept:
        factors.add(
            fx.bearing_3d(
                frame,
                int(seen.ids[row]),
                seen.rays_s[row],
                gtsam.noiseModel.Isotropic.Sigma(2, float(seen.sigmas_rad[row])),
            )
        )


def odometry_ratio(
    key_poses_w: dict[int, np.ndarray], odometry: list[tuple[int, int, np.ndarray]]
) -> float:
    """The factor by which a solved trajectory's translations exceed the odometry's.

    ``sum_k t_k . d_k / sum_k |d_k|^2`` over the between-factors of the key frames, ``d_k``
    the odometry's translation (as the factor measures it), ``t_k`` the solved one between
    the same two poses, in the first pose's frame: the least-squares scale of ``t ~ r d``.
    The odometry's own noise dilutes it (by ~1 / (1 + sigma_rel^2), sigma_rel the odometry's
    relative noise per factor: negligible at lab40's few %, 0.2-0.3 % small maps with 30 %
    per-step noise). Regressing d on t instead (``sum |t|^2 / sum t . d``), or adding the
    new viewpoints' odometry, measured worse on lab40 (maps 0.11-0.16 % and 0.05-0.09 % off
    against 0.02-0.03 %).

    Args:
        key_poses_w: frame -> (4, 4) robot pose of that frame in the world, for every frame
            named in ``odometry``.
        odometry: (frame i, frame j, delta (3,) [x, y, theta]) of each between-factor.

    Returns:
        r (1 when there is no translation at all).
    """
    num = den = 0.0
    for i, j, delta in odometry:
        iTj = se3_inverse(key_poses_w[i]) @ key_poses_w[j]
        num += float(iTj[:2, 3] @ delta[:2])
        den += float(delta[:2] @ delta[:2])
    return num / den if den > 0 else 1.0
