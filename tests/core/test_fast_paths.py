"""The fast paths of ``omnislam.core`` against the reference formulas they replace."""

import numpy as np
import pytest

from omnislam.core.se import wrap_angle, wrap_angle_inplace

PI = np.pi


def _reference_wrap(angle):
    return (np.asarray(angle, dtype=float) + np.pi) % (2.0 * np.pi) - np.pi


def _edge_angles():
    """Angles at and next to every boundary of the masked corrections."""
    centres = np.array([-5 * PI, -4 * PI, -3 * PI, -2 * PI, -PI, 0.0, PI, 2 * PI, 3 * PI, 4 * PI])
    near = [centres]
    for direction in (-np.inf, np.inf):
        step = centres
        for _ in range(3):
            step = np.nextafter(step, direction)
            near.append(step)
    return np.concatenate([*near, [0.0, -0.0, 1e-300, -1e-300, 1e-17, -1e-17]])


@pytest.mark.parametrize("size", [1, 10, 511, 512, 1000, 10_000])
@pytest.mark.parametrize("scale", [PI, 2 * PI, 3 * PI, 50.0, 1e6])
def test_wrap_angle_is_bitwise_the_reference(rng, size, scale):
    angles = np.concatenate([rng.uniform(-scale, scale, size), _edge_angles()])
    rng.shuffle(angles)
    for a in (angles, angles[:size], angles[::2]):
        expected = _reference_wrap(a)
        np.testing.assert_array_equal(wrap_angle(a), expected)
        copy = a.copy()
        assert wrap_angle_inplace(copy) is copy
        np.testing.assert_array_equal(copy, expected)
    assert np.all(wrap_angle(angles) >= -PI) and np.all(wrap_angle(angles) <= PI)


def test_wrap_angle_special_values_and_shapes():
    special = np.array([np.nan, np.inf, -np.inf, 1.0] * 100)
    with np.errstate(invalid="ignore"):
        np.testing.assert_array_equal(wrap_angle(special), _reference_wrap(special))
    grid = np.linspace(-10, 10, 600).reshape(20, 30)
    np.testing.assert_array_equal(wrap_angle(grid), _reference_wrap(grid))
    scalar = wrap_angle(7.0)
    assert isinstance(scalar, np.floating) and scalar == _reference_wrap(7.0)
    assert wrap_angle([4.0, -4.0]).tolist() == _reference_wrap([4.0, -4.0]).tolist()
    source = np.full(300, 5.0)
    wrap_angle(source)
    assert np.all(source == 5.0)  # wrap_angle never writes into its input
