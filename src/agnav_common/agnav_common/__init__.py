"""Shared agnav helpers: frames and geodesy maths, rosbag2 type store, TF buffer/broadcaster, diagnostics."""
