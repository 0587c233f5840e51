#!/usr/bin/env bash
# Builds and tests every package of src/ in an ordinary colcon workspace (build/colcon_ws, src/ symlinked)
# against the PyPI ROS in .venv: colcon build, colcon test, colcon test-result --verbose (README: colcon section;
# test/foundation/test_colcon.py runs this and checks that the README's commands are these).
# Usage: tools/colcon.sh [--no-test]
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=$PWD/.venv
WS=${AGNAV_COLCON_WS:-$PWD/build/colcon_ws}
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_LOG_DIR=${ROS_LOG_DIR:-$PWD/build/ros_log} MPLBACKEND=Agg
"$VENV/bin/python" -c "import colcon_core" 2>/dev/null \
  || { echo "[colcon] colcon is not in $VENV: run make setup" >&2; exit 1; }
# shellcheck source=tools/ros_env.sh
source tools/ros_env.sh
ros_env_fix_wheel_paths

mkdir -p "$WS/src" && ln -sfn "$PWD"/src/* "$WS/src/" && cd "$WS"
ros_env_run colcon build --symlink-install --cmake-args -DPython3_EXECUTABLE="$VENV/bin/python" -DBUILD_TESTING=OFF
[ "${1:-}" = --no-test ] && exit 0
ros_env_run colcon test --executor sequential
ros_env_run colcon test-result --verbose
