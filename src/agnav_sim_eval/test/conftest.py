"""Fixtures `ros` (one rclpy context per test) and `repo_root`, shared by every agnav test folder."""
from agnav_common.testing import repo_root, ros  # noqa: F401
