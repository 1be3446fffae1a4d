"""Victoria Park loader and the Guivant-Nebot Ackermann model."""

from pathlib import Path

import numpy as np
import pytest

from omnislam.core.ackermann import (
    AckermannGeometry,
    integrate_ackermann,
    integrate_unicycle,
    rear_axle_velocities,
)
from omnislam.core.se import se2_compose
from omnislam.core.types import UNKNOWN_ID, Trajectory
from omnislam.datasets.sequence import GroundTruthKind
from omnislam.datasets.victoria_park import load_victoria_park
from omnislam.errors import DataError
from omnislam.metrics.trajectory import Alignment, ate

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
PARK = DATA / "victoria_park"
needs_data = pytest.mark.skipif(not PARK.is_dir(), reason=f"Victoria Park data not in {PARK}")


def compose_all(steps):
    poses = np.zeros_like(steps)
    for k in range(1, len(steps)):
        poses[k] = se2_compose(poses[k - 1], steps[k])
    return poses


@pytest.fixture(scope="module")
def park():
    return load_victoria_park(PARK)


@needs_data
def test_dead_reckoning_stays_within_5_m_of_gps_for_60_s(park):
    gt = park.ground_truth
    assert gt.kind is GroundTruthKind.GPS_PARTIAL
    estimate = Trajectory.from_se2(park.stamps_s, compose_all(park.odometry_r))
    result = ate(estimate, gt.trajectory, Alignment.ORIGIN, truth_has_orientation=False)
    first_minute = result.stamps_s < park.stamps_s[0] + 60.0
    assert first_minute.sum() > 100
    assert result.errors_m[first_minute].max() < 5.0
    assert 0.5 < result.coverage < 0.7  # GPS is partial


@needs_data
def test_sightings_are_robot_frame_with_unknown_ids(park):
    assert len(park) == 7230
    sightings = [rb for rb in park.range_bearing if rb is not None]
    assert sum(len(rb) for rb in sightings) == 52974
    bearings = np.concatenate([rb.bearings_rad for rb in sightings])
    assert -np.pi / 2 - 1e-9 <= bearings.min() and bearings.max() <= np.pi / 2 + 1e-9
    assert all(np.all(rb.landmark_ids == UNKNOWN_ID) for rb in sightings)


def test_rear_axle_speed_from_the_encoder():
    geometry = AckermannGeometry()
    v_c, omega = rear_axle_velocities(np.array([2.0]), np.array([0.2]), geometry)
    expected = 2.0 / (1 - np.tan(0.2) * 0.76 / 2.83)
    assert v_c[0] == pytest.approx(expected)
    assert omega[0] == pytest.approx(expected * np.tan(0.2) / 2.83)


def test_closed_form_matches_fine_euler_integration_of_guivant_nebot():
    geometry = AckermannGeometry()
    stamps = np.arange(0.0, 10.0, 0.025)
    speed = 2.0 + np.sin(stamps)
    steer = 0.3 * np.sin(0.5 * stamps)
    query = np.array([0.0, 3.0, 7.5, 9.975])
    exact = integrate_ackermann(stamps, speed, steer, query, geometry)
    # Euler on the published laser-point equations with 100 sub-steps per sample
    L, H, a, b = 2.83, 0.76, 3.78, 0.50
    x, y, phi = a, b, 0.0
    out = []
    for k, t in enumerate(stamps):
        if np.any(np.isclose(query, t)):
            out.append([x, y, phi])
        v = speed[k] / (1 - np.tan(steer[k]) * H / L)
        dt = 0.025 / 100
        for _ in range(100):
            w = v * np.tan(steer[k]) / L
            x, y, phi = (
                x + dt * (v * np.cos(phi) - w * (a * np.sin(phi) + b * np.cos(phi))),
                y + dt * (v * np.sin(phi) + w * (a * np.cos(phi) - b * np.sin(phi))),
                phi + dt * w,
            )
    assert np.allclose(exact, np.array(out), atol=2e-3)


def test_unicycle_circle_and_standstill_before_first_sample():
    poses = integrate_unicycle(
        np.array([1.0]), np.array([1.0]), np.array([1.0]), np.array([0.0, 1.0, 1.0 + np.pi])
    )
    assert np.allclose(poses[1], 0.0)
    assert np.allclose(poses[2], [0.0, 2.0, np.pi], atol=1e-12)


def write_park(folder: Path, inputs: str, measurements: str, gps: str = "0 0 0\n0.2 0 0\n"):
    folder.mkdir(exist_ok=True)
    (folder / "inputs.dat").write_text(inputs)
    (folder / "measurements.dat").write_text(measurements)
    (folder / "gps.dat").write_text(gps)
    return folder


def test_small_folder_loads(tmp_path):
    folder = write_park(
        tmp_path / "vp", "0 1 0\n0.025 1 0\n", "0.1 10 1.5707963 0.3\n0.2 5 0 0.2\n"
    )
    seq = load_victoria_park(folder)
    assert len(seq) == 2
    assert seq.range_bearing[0].bearings_rad[0] == pytest.approx(0.0, abs=1e-6)
    assert seq.range_bearing[1].bearings_rad[0] == pytest.approx(-np.pi / 2)
    assert seq.odometry_r[1] == pytest.approx([0.1, 0.0, 0.0])


@pytest.mark.parametrize(
    ("inputs", "measurements", "gps", "file", "message"),
    [
        (
            "0 1 0\n0.025 1\n",
            "0.1 1 1 1\n",
            "0 0 0\n",
            "inputs.dat",
            "line 2: expected 3 columns.*truncated",
        ),
        ("0 1 0\n", "0.1 1 1\n", "0 0 0\n", "measurements.dat", "line 1: expected 4 columns"),
        ("0 1 0\n", "0.1 1 1 1\n", "0 0 0\n0.2 nan? 0\n", "gps.dat", "line 2: x.m. 'nan.' is not"),
        (
            "0 1 0\n",
            "0.2 1 1 1\n0.1 1 1 1\n",
            "0 0 0\n",
            "measurements.dat",
            "line 2: time 0.1 is earlier",
        ),
        ("0 1 0\n", "0.1 1 1 1\n", "0 0 0\n0 1 1\n", "gps.dat", "line 2: time 0.0 is equal to"),
    ],
)
def test_bad_input_names_file_and_line(tmp_path, inputs, measurements, gps, file, message):
    folder = write_park(tmp_path / "vp", inputs, measurements, gps)
    with pytest.raises(DataError, match=message) as info:
        load_victoria_park(folder)
    assert str(info.value).startswith(str(folder / file))
