"""Dead reckoning (SPEC eq 5.12-5.13) against closed-form tracks."""
import math

import numpy as np

from agnav_fusion.dead_reckoning import DeadReckoning


def test_straight_line_north_east():
    dr = DeadReckoning()
    dr.reset((1.0, 2.0), np.eye(2) * 0.01)
    for _ in range(100):
        xy, cov = dr.step(heading=math.pi / 4, speed=0.8, dt=0.01)
    d = 0.8 / math.sqrt(2)
    np.testing.assert_allclose(xy, [1.0 + d, 2.0 + d], atol=1e-12)
    assert cov[0, 0] > 0.01 and np.all(np.linalg.eigvalsh(cov) > 0)


def test_circle_closes_and_covariance_grows():
    dr = DeadReckoning()
    dr.reset((0.0, 0.0), np.zeros((2, 2)))
    n, speed, dt = 20000, 1.0, 0.001
    rate = 2 * math.pi / (n * dt)  # one full clockwise circle
    traces = []
    for k in range(n):
        xy, cov = dr.step(heading=(k + 0.5) * rate * dt, speed=speed, dt=dt)
        traces.append(np.trace(cov))
    np.testing.assert_allclose(xy, [0.0, 0.0], atol=1e-6)
    assert np.all(np.diff(traces[::1000]) > 0)
