"""Test session guards: ROS stays on this host and in a private domain; one rclpy context per test."""
import os

os.environ.setdefault("ROS_LOG_DIR", os.path.join(os.path.dirname(__file__), "..", "build", "ros_log"))

from agnav_common.testing import repo_root, ros  # noqa: E402,F401  (fixtures shared with src/*/test)
