"""nav_settings.last_at: the IMU history sample a GNSS epoch is placed on."""
from collections import deque

from agnav_fusion.nav_settings import Sample, last_at


def _history(stamps):
    return deque(Sample(t, 0.01, 0.0, None, 0.0, 0.0, 0.0, 0.0, None) for t in stamps)


def test_last_at_is_the_last_sample_at_or_before_the_epoch():
    hist = _history([10.00, 10.01, 10.02, 10.03])
    assert last_at(hist, 10.02) == 2       # a sample at the epoch itself
    assert last_at(hist, 10.025) == 2      # between two samples: the earlier one
    assert last_at(hist, 11.0) == 3        # after the newest
    assert last_at(hist, 9.99) == -1       # before the oldest: none (callers check hist[0].t first)
    assert all(last_at(hist, t) == max(i for i in range(len(hist)) if hist[i].t <= t)
               for t in (10.0, 10.005, 10.01, 10.015, 10.03, 10.5))
