"""The presets of the thesis's two simulated routes (Guizilini 2008, sec. 5.1): corridor
networks, the two lasers, the local-minimum pole detection, the folder's loader defaults."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from omnislam.core.se import se2_integrate
from omnislam.core.types import UNKNOWN_ID
from omnislam.datasets._common import Association
from omnislam.datasets.sequence import LaserRole
from omnislam.datasets.synthetic.corridors import CorridorNetwork, PoleRow, polygon_segments
from omnislam.datasets.synthetic.laser import (
    LaserConfig,
    PoleScanner,
    pole_of_surface,
    pole_table,
    scanned_poles,
)
from omnislam.datasets.synthetic.loader import load_synthetic
from omnislam.datasets.synthetic.presets import (
    PRESETS,
    ROUTE2_COLUMNS,
    ROUTE2_ROWS,
    CameraKind,
    route2_network,
)
from omnislam.datasets.synthetic.raycast import make_ray_caster
from omnislam.datasets.synthetic.routes import NO_BIAS
from omnislam.datasets.synthetic.simulate import drive, simulate
from omnislam.datasets.synthetic.world import WorldBuilder
from omnislam.datasets.synthetic.writer import write_synthetic

THESIS = ("thesis-route1", "thesis-route2")
#: dead reckoning must end at least this far from route 1's start on every seed 0-9 [m] (the
#: thesis's Fig. 5.5a: the robot cannot return to its start on odometry alone)
ROUTE1_MIN_END_ERROR_M = 1.5


@pytest.mark.parametrize("name", THESIS)
def test_thesis_presets_are_the_thesis_sensors_without_images_or_bias(name):
    preset = PRESETS[name]
    assert preset.camera is CameraKind.NONE and preset.rig() is None
    assert preset.odometry_bias == NO_BIAS
    assert preset.association is Association.UNKNOWN
    assert preset.laser_role is LaserRole.OCCUPANCY
    lower, upper = preset.laser, preset.pole_scanner.laser
    assert (lower.fov_deg, lower.max_range_m) == (180.0, 3.0)
    assert (upper.fov_deg, upper.max_range_m) == (360.0, 4.0)
    assert upper.height_m - lower.height_m == pytest.approx(0.5)
    assert preset.drive.rate_hz == 10.0


def test_route_lengths_and_poles_follow_the_thesis():
    """Route 1 ~150 m, route 2 ten times longer with more, thicker poles and a blind corridor
    at its upper end, entered from the left."""
    lengths = {n: sum(map(math.dist, PRESETS[n].waypoints_w[:-1], PRESETS[n].waypoints_w[1:]))
               for n in THESIS}
    assert 140 < lengths["thesis-route1"] < 160
    assert 9 < lengths["thesis-route2"] / lengths["thesis-route1"] < 11
    worlds = {n: PRESETS[n].build_world(np.random.default_rng(0)) for n in THESIS}
    poles1, poles2 = (pole_table(worlds[n]) for n in THESIS)
    assert len(poles2) > 5 * len(poles1) and poles2[:, 3].min() > 2 * poles1[:, 3].max()
    top, (left, right) = ROUTE2_ROWS[-1], ROUTE2_COLUMNS[:2]
    x, y = poles2[:, 1], poles2[:, 2]
    blind = (np.abs(y - top) < 3) & (x > left + 3) & (x < right - 3)
    assert not blind.any()
    waypoints = PRESETS["thesis-route2"].waypoints_w
    enters = [k for k in range(1, len(waypoints)) if waypoints[k - 1] == (left, top)
              and waypoints[k] == (right, top)]
    assert enters and waypoints[enters[0] - 2][1] < top  # up the left column, then right
    assert route2_network().blind == frozenset({0})


def test_corridor_walls_bound_the_free_space():
    """An L of two corridors: six walls; every point of a centre line is half a width from the
    nearest wall, and no wall crosses the free space."""
    network = CorridorNetwork((((0.0, 0.0), (10.0, 0.0)), ((10.0, 0.0), (10.0, 6.0))), 2.0)
    walls = np.array(network.walls()).reshape(-1, 4)
    assert len(walls) == 6
    for x, y in [(2.0, 0.0), (8.0, 0.0), (10.0, 3.0), (10.0, 5.0)]:
        distances = [_point_segment((x, y), w) for w in walls]
        assert min(distances) == pytest.approx(1.0)
    assert not any(_point_segment((10.0, 0.0), w) < 0.99 for w in walls)  # the corner is open


def test_poles_keep_out_of_junctions_and_blind_corridors(rng):
    network = CorridorNetwork(polygon_segments(((0.0, 0.0), (30.0, 0.0), (30.0, 20.0),
                                                (0.0, 20.0))), width_m=3.0, blind=frozenset({2}))
    row = PoleRow(spacing_m=2.0, radius_m=0.15)
    sites = np.array(network.pole_sites(row, rng))
    corners = np.array([(0, 0), (30, 0), (30, 20), (0, 20)], dtype=float)
    gaps = np.min(np.hypot(*(sites[:, None, :] - corners[None]).transpose(2, 0, 1)), axis=1)
    assert gaps.min() > 1.5 + 1.0
    assert not np.any(np.abs(sites[:, 1] - 20) < 2)  # the blind top corridor
    lateral = np.minimum(np.abs(sites[:, 1] - np.round(sites[:, 1] / 20) * 20),
                         np.abs(sites[:, 0] - np.round(sites[:, 0] / 30) * 30))
    np.testing.assert_allclose(lateral, 1.5 - 0.35 - 0.15, atol=1e-9)


def _point_segment(p, wall):
    a, b = np.array(wall[:2]), np.array(wall[2:])
    t = np.clip(np.dot(np.subtract(p, a), b - a) / np.dot(b - a, b - a), 0, 1)
    return float(np.hypot(*(np.subtract(p, a + t * (b - a)))))


@pytest.mark.parametrize("guess", [0.0, 0.06])
def test_a_scanned_pole_is_its_nearest_surface_seen_along_its_beam(guess):
    """One 15 cm pole seen from four sides: the bearing is the centre's within half a beam, the
    range the nearest surface's plus the guess -- the position depends on the side seen from."""
    b = WorldBuilder("pole", 0, np.random.default_rng(0))
    b.pole(0.0, 0.0, radius=0.15, sides=32)
    world = b.build()
    table = pole_table(world)
    caster = make_ray_caster(world.arrays(), "numpy")
    scanner = PoleScanner(LaserConfig(fov_deg=360.0, beams=720, max_range_m=4.0,
                                      sigma_range_m=1e-4), radius_guess_m=guess)
    found = []
    for heading in (0.0, 0.5 * np.pi, np.pi, -0.5 * np.pi):
        wTr = np.array([2.0 * np.cos(heading), 2.0 * np.sin(heading), 1.0])
        seen = scanned_poles(caster, pole_of_surface(world, table), table, scanner, wTr,
                             np.random.default_rng(1))
        assert list(seen.landmark_ids) == [0]
        bearing_to_centre = np.arctan2(-wTr[1], -wTr[0]) - wTr[2]
        assert abs(np.angle(np.exp(1j * (seen.bearings_rad[0] - bearing_to_centre)))) <= (
            np.pi / 720 + 1e-9)
        assert seen.ranges_m[0] == pytest.approx(2.0 - 0.15 + guess, abs=0.003)
        angle = wTr[2] + seen.bearings_rad[0]
        found.append(wTr[:2] + seen.ranges_m[0] * np.array([np.cos(angle), np.sin(angle)]))
    spread = np.ptp(np.array(found), axis=0).max()
    assert spread == pytest.approx(2 * (0.15 - guess), abs=0.01)


@pytest.mark.slow
def test_dead_reckoning_does_not_return_to_route1s_start():
    """The zero-mean noise is large enough that odometry alone misses the start (Fig. 5.5a)."""
    preset = PRESETS["thesis-route1"]
    ends = []
    for seed in range(10):
        route = drive(preset, seed)
        dr = se2_integrate(route.odometry_r, route.poses_w[0])
        ends.append(np.hypot(*(dr[-1, :2] - route.poses_w[-1, :2])))
    assert min(ends) > ROUTE1_MIN_END_ERROR_M, np.round(ends, 2)
    assert np.hypot(*(route.poses_w[-1, :2] - route.poses_w[0, :2])) < 0.1  # back at the start


def test_a_thesis_folder_hides_the_ids_and_keeps_its_laser_for_the_grid(tmp_path):
    preset = PRESETS["thesis-route1"]
    sim = simulate(dataclasses.replace(preset, image_every_k=1), 0, max_images=40,
                   backend="numpy")
    folder = write_synthetic(tmp_path / "route1", sim, backend="numpy")
    sequence = load_synthetic(folder)
    sightings = [rb for rb in sequence.range_bearing if len(rb)]
    assert sightings and all(np.all(rb.landmark_ids == UNKNOWN_ID) for rb in sightings)
    assert sequence.laser.role is LaserRole.OCCUPANCY
    assert sequence.laser.angles_rad.size == preset.laser.beams
    known = load_synthetic(folder, association=Association.KNOWN)
    assert all(np.all(rb.landmark_ids >= 0) for rb in known.range_bearing if len(rb))
    scanner = preset.pole_scanner  # a surface within the laser's range, plus the radius guess
    reach = scanner.laser.max_range_m + scanner.radius_guess_m + 4 * scanner.laser.sigma_range_m
    assert max(rb.ranges_m.max() for rb in sightings) <= reach
    assert sequence.image_loader is None


def test_the_front_end_leaves_an_occupancy_laser_alone(tmp_path):
    """No laser odometry and no laser landmarks from scans kept for the occupancy grid; the
    same scans as a sensor get both."""
    from omnislam.core.types import OdometrySource
    from omnislam.frontend.config import FrontendConfig
    from omnislam.frontend.pipeline import run_frontend

    sim = simulate(dataclasses.replace(PRESETS["thesis-route1"], image_every_k=1), 0,
                   max_images=30, backend="numpy")
    sequence = load_synthetic(write_synthetic(tmp_path / "r1", sim, backend="numpy"))
    base = FrontendConfig()
    config = dataclasses.replace(base, laser=dataclasses.replace(base.laser,
                                                                 merge_with_sightings=True))

    def fed_counts(log):
        return [0 if f.range_bearing is None else len(f.range_bearing) for f in log.frames]

    own = [len(rb) for rb in sequence.range_bearing]
    log = run_frontend(sequence, config)
    assert log.odometry_source is OdometrySource.WHEEL
    assert fed_counts(log) == own
    sensing = dataclasses.replace(sequence, laser=dataclasses.replace(sequence.laser,
                                                                      role=LaserRole.SENSOR))
    log = run_frontend(sensing, config)
    assert log.odometry_source is OdometrySource.LASER
    assert sum(fed_counts(log)) > sum(own)
