"""pytest fixtures shared by every agnav test folder (root test/ and each package's test/).

A conftest.py imports them: `from agnav_common.testing import repo_root, ros  # noqa: F401`. Importing this
module confines ROS to this host and to a private domain (one per xdist worker), before any test imports rclpy.
"""
import os
from pathlib import Path

import pytest

from agnav_common.checkout import find_checkout

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(101 + os.getpid() % 100))
WORKER = os.environ.get("PYTEST_XDIST_WORKER")      # "gw0", "gw1", ... under pytest -n N: a domain per worker
if WORKER:
    os.environ["ROS_DOMAIN_ID"] = str((int(os.environ["ROS_DOMAIN_ID"]) + int(WORKER[2:])) % 233)


@pytest.fixture
def ros():
    """An initialised rclpy for one test, always shut down afterwards."""
    import rclpy
    rclpy.init()
    try:
        yield rclpy
    finally:
        rclpy.try_shutdown()


@pytest.fixture
def repo_root(request):
    """The checkout the test file lives in; the test is skipped in a workspace without the bundled bags."""
    root = find_checkout(Path(str(request.path)).resolve().parent)
    if root is None:
        pytest.skip("needs the agnav checkout (bags/)")
    return root
