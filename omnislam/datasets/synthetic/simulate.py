"""Run a preset: build its world, drive its route, sample odometry, laser and pole sightings.

The pole sightings come from the preset's ``laser`` (each visible pole's centre with noise) or,
when the preset has a ``pole_scanner``, from that second laser's scan (its local minima: the
thesis's two lasers, sec. 5.1.1), drawn after each frame's scan from the same laser stream.

Randomness is split into independent streams of one ``SeedSequence(seed)`` (world details,
odometry noise, laser noise), so limiting the number of frames or changing the laser does not
change the world or the odometry noise of the frames that remain.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from omnislam.camera.rig import CameraRig
from omnislam.core.types import RangeBearing
from omnislam.datasets.synthetic.laser import (
    pole_of_surface,
    pole_sightings,
    pole_table,
    scan,
    scanned_poles,
)
from omnislam.datasets.synthetic.presets import Preset
from omnislam.datasets.synthetic.raycast import Backend, make_ray_caster
from omnislam.datasets.synthetic.routes import drive_through, measured_odometry
from omnislam.datasets.synthetic.world import SurfaceKind, World
from omnislam.errors import ConfigError


@dataclass(frozen=True, slots=True)
class Simulation:
    """Everything of a run except the images (rendered while writing).

    Attributes:
        preset: the scenario.
        seed: the seed.
        world: the world.
        rig: the camera rig, or None.
        stamps_s: (N,) odometry / frame times [s] (10 Hz).
        poses_w: (N, 3) true poses.
        odometry_true_r: (N, 3) true robot-frame deltas (row 0 zero).
        odometry_r: (N, 3) measured deltas (systematic bias, then the thesis alpha model).
        image_frames: (K,) frame indices that get an image.
        laser_ranges_m: (N, B) noisy ranges of the preset's ``laser``.
        poles: per-frame pole sightings (of ``preset.pole_scanner`` when it has one).
    """

    preset: Preset
    seed: int
    world: World
    rig: CameraRig | None
    stamps_s: np.ndarray
    poses_w: np.ndarray
    odometry_true_r: np.ndarray
    odometry_r: np.ndarray
    image_frames: np.ndarray
    laser_ranges_m: np.ndarray
    poles: tuple[RangeBearing, ...]


@dataclass(frozen=True, slots=True)
class Drive:
    """A preset's whole route and its odometry (no world, no sensors).

    Attributes:
        stamps_s: (N,) frame times [s].
        poses_w: (N, 3) true poses.
        odometry_true_r: (N, 3) true robot-frame deltas (row 0 zero).
        odometry_r: (N, 3) measured deltas (``routes.measured_odometry`` with the preset's
            bias and alpha noise).
    """

    stamps_s: np.ndarray
    poses_w: np.ndarray
    odometry_true_r: np.ndarray
    odometry_r: np.ndarray


def drive(preset: Preset, seed: int) -> Drive:
    """The route of ``preset`` and its measured odometry for ``seed``: the same numbers as
    ``simulate(preset, seed)`` on every frame, without building the world or the sensors."""
    _, odo_ss, _ = np.random.SeedSequence(seed).spawn(3)
    path = drive_through(np.array(preset.waypoints_w), preset.drive)
    true_odo = np.zeros_like(path.poses_w)
    true_odo[1:] = path.odometry_true()[1:]
    odometry = measured_odometry(
        true_odo, preset.motion_noise, np.random.default_rng(odo_ss), preset.odometry_bias
    )
    return Drive(path.stamps_s, path.poses_w, true_odo, odometry)


def simulate(
    preset: Preset,
    seed: int,
    max_images: int | None = None,
    backend: Backend | str | None = None,
) -> Simulation:
    """Build the world and the non-image sensor data of ``preset``.

    Args:
        preset: the scenario.
        seed: master seed (world details and all noise).
        max_images: keep the run up to (and including) its ``max_images``-th image frame.
        backend: ray caster used for the laser.
    """
    if max_images is not None and max_images < 1:
        raise ConfigError(f"--frames must be >= 1, got {max_images}")
    world_ss, _, laser_ss = np.random.SeedSequence(seed).spawn(3)
    world = dataclasses.replace(preset.build_world(np.random.default_rng(world_ss)), seed=seed)
    route = drive(preset, seed)  # the odometry stream is drawn sequentially: truncating keeps it
    n = route.poses_w.shape[0]
    image_frames = np.arange(0, n, preset.image_every_k, dtype=np.int64)
    if max_images is not None and max_images < image_frames.size:
        image_frames = image_frames[:max_images]
        n = int(image_frames[-1]) + 1
    poses = route.poses_w[:n]
    stamps = route.stamps_s[:n]
    true_odo = route.odometry_true_r[:n]
    odometry = route.odometry_r[:n]
    caster = make_ray_caster(world.arrays(), backend)
    laser_rng = np.random.default_rng(laser_ss)
    table = pole_table(world)
    is_pole = np.array([q.kind is SurfaceKind.POLE for q in world.quads], dtype=bool)
    scanner = preset.pole_scanner
    surface_pole = None if scanner is None else pole_of_surface(world, table)
    ranges = np.empty((n, preset.laser.beams))
    sightings = []
    for i in range(n):
        ranges[i] = scan(caster, preset.laser, poses[i], laser_rng)
        if scanner is None:
            sightings.append(
                pole_sightings(caster, is_pole, table, preset.laser, poses[i], laser_rng))
        else:
            assert surface_pole is not None
            sightings.append(
                scanned_poles(caster, surface_pole, table, scanner, poses[i], laser_rng))
    return Simulation(
        preset=preset,
        seed=seed,
        world=world,
        rig=preset.rig(),
        stamps_s=stamps,
        poses_w=poses,
        odometry_true_r=true_odo,
        odometry_r=odometry,
        image_frames=image_frames if preset.rig() is not None else image_frames[:0],
        laser_ranges_m=ranges,
        poles=tuple(sightings),
    )
