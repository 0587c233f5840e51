"""Test session guards: ROS stays on this host and in a private domain; one rclpy context per test."""
import os

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(101 + os.getpid() % 100))
os.environ.setdefault("ROS_LOG_DIR", os.path.join(os.path.dirname(__file__), "..", "build", "ros_log"))

import pytest  # noqa: E402


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
def repo_root():
    from pathlib import Path
    return Path(__file__).resolve().parents[1]
