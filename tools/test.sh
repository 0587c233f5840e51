#!/usr/bin/env bash
# Runs the test suite in the venv with ROS confined to this host, a private domain and logs in build/; two pytest
# workers (AGNAV_TEST_WORKERS; 0: one process), each test file on one worker (module fixtures run once).
set -euo pipefail
cd "$(dirname "$0")/.."
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export ROS_DOMAIN_ID=${ROS_DOMAIN_ID:-$(( ( $$ % 100 ) + 101 ))}   # 101..200: one per test run
export ROS_LOG_DIR=$PWD/build/ros_log
export MPLBACKEND=Agg
exec .venv/bin/python -m pytest -q -p no:cacheprovider --timeout=300 --timeout-method=thread \
  -n "${AGNAV_TEST_WORKERS:-2}" --dist loadfile "$@"
