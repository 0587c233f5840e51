#!/usr/bin/env bash
# Builds and tests every package of src/ in an ordinary colcon workspace (build/colcon_ws, src/ symlinked)
# against the PyPI ROS in .venv: colcon build, colcon test, colcon test-result --verbose.
# Usage: tools/colcon.sh [--no-test] [extra colcon build args, e.g. --packages-select agnav_common]
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
VENV=$ROOT/.venv
WS=${AGNAV_COLCON_WS:-$ROOT/build/colcon_ws}
# shellcheck source=tools/ros_env.sh
source tools/ros_env.sh
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_LOG_DIR=${ROS_LOG_DIR:-$ROOT/build/ros_log} MPLBACKEND=Agg
test_too=1; [ "${1:-}" = --no-test ] && { test_too=0; shift; }

"$VENV/bin/python" -c "import colcon_core" 2>/dev/null \
  || { echo "[colcon] colcon is not in $VENV: run make setup" >&2; exit 1; }
ros_env_fix_wheel_paths

mkdir -p "$WS/src"
for pkg in "$ROOT"/src/*/package.xml; do
  ln -sfn "$(dirname "$pkg")" "$WS/src/$(basename "$(dirname "$pkg")")"
done
cd "$WS"
# Same commands as README.md's colcon section; --symlink-install needs setuptools < 80 (pinned).
ros_env_run colcon build --symlink-install --event-handlers console_cohesion- "$@" \
  --cmake-args -DPython3_EXECUTABLE="$VENV/bin/python" -DBUILD_TESTING=OFF
[ $test_too = 1 ] || exit 0
ros_env_run colcon test --executor sequential --event-handlers console_cohesion- "$@" \
  --pytest-args -p no:cacheprovider --timeout=300 --timeout-method=thread
ros_env_run colcon test-result --verbose
