"""Path densification and the trapezoidal speed profile."""

import numpy as np
import pytest

from hila_lang.robot.trajectory import densify, trapezoid_profile


def test_densify_keeps_every_waypoint_and_bounds_the_spacing():
    rng = np.random.default_rng(0)
    points = rng.uniform(-0.1, 0.1, size=(12, 3))
    points[5] = points[4]  # a repeated point is kept, not divided by zero
    dense, origin, arc = densify(points, 0.002)
    assert np.all(np.linalg.norm(np.diff(dense, axis=0), axis=1) <= 0.002 + 1e-12)
    for k, p in enumerate(points):
        assert np.min(np.linalg.norm(dense - p, axis=1)) < 1e-12, k
    total = np.linalg.norm(np.diff(points, axis=0), axis=1).sum()
    assert arc[0] == 0 and arc[-1] == pytest.approx(total) and np.all(np.diff(arc) >= 0)
    assert origin[0] == 0 and origin[-1] == len(points) - 2 and np.all(np.diff(origin) >= 0)


@pytest.mark.parametrize("length, speed", [(0.19, 0.05), (0.004, 0.15), (1.0, 0.15)])
def test_trapezoid_profile_reaches_the_end_without_exceeding_speed_or_acceleration(length, speed):
    dt = 1 / 240
    profile = np.array(trapezoid_profile(length, speed, 0.5, dt))
    s, v = profile[:, 0], profile[:, 1]
    assert s[-1] == pytest.approx(length) and v[-1] == pytest.approx(0, abs=1e-9)
    assert np.all(np.diff(s) >= -1e-15) and np.all(v <= speed + 1e-12)
    assert np.all(np.abs(np.diff(v)) <= 0.5 * dt + 1e-9)
    # the speed reported matches the positions' differences
    np.testing.assert_allclose(np.diff(s) / dt, (v[1:] + v[:-1]) / 2, atol=0.5 * dt)


def test_trapezoid_profile_of_nothing_is_one_still_sample():
    assert trapezoid_profile(0.0, 0.1, 0.5, 1 / 240) == [(0.0, 0.0)]
