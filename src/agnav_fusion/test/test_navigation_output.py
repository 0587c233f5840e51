"""base_link velocity of a navigation state: the side slip of an estimated crab in linear.y."""
import math

import numpy as np
from agnav_fusion.nav_settings import NavState
from agnav_fusion.navigation_output import body_velocity


def state(crab=0.0, crab_var=math.inf, speed=2.0):
    return NavState(0.0, np.zeros(3), np.zeros(3), np.eye(6), speed, np.zeros(3), np.eye(6) * 0.01, True, True,
                    False, crab, crab_var)


def test_no_crab_estimate_moves_along_x():
    vx, vy, cov = body_velocity(state())
    assert (vx, vy) == (2.0, 0.0) and cov[1, 1] == 0.01


def test_crab_to_the_right_slides_to_negative_y_with_its_variance():
    crab, var = math.radians(1.5), math.radians(5.0) ** 2
    vx, vy, cov = body_velocity(state(crab, var))
    assert math.isclose(math.hypot(vx, vy), 2.0) and math.isclose(math.atan2(-vy, vx), crab)
    assert math.isclose(cov[1, 1], 4.0 * var) and cov[0, 0] == 0.01
