#!/usr/bin/env bash
# Runs the test suite in the venv with ROS confined to this host, a private domain and logs in build/.
set -euo pipefail
cd "$(dirname "$0")/.."
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export ROS_DOMAIN_ID=${ROS_DOMAIN_ID:-$(( ( $$ % 100 ) + 101 ))}   # 101..200: one per test run
export ROS_LOG_DIR=$PWD/build/ros_log
export MPLBACKEND=Agg
exec .venv/bin/python -m pytest -q -p no:cacheprovider --timeout=300 --timeout-method=thread "$@"
