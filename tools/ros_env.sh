# Sourced by tools/setup.sh and tools/colcon.sh (needs VENV): the PyPI ROS in $VENV as an ament/CMake prefix.

ros_env_fix_wheel_paths() {  # the wheels' CMake exports name the build machine's interpreter: point them at $VENV
  local pyinc npinc
  pyinc=$("$VENV/bin/python" -c "import sysconfig; print(sysconfig.get_paths()['include'])")
  npinc=$("$VENV/bin/python" -c "import numpy; print(numpy.get_include())")
  { grep -rl "/opt/python/cp311-cp311" "$VENV/share" --include=*.cmake || true; } | xargs -r sed -i \
    -e "s#/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include#$npinc#g" \
    -e "s#/opt/python/cp311-cp311/include/python3.11#$pyinc#g"
}

ros_env_run() {  # ros_env_run CMD ARGS... : run CMD with $VENV as the ament/CMake prefix and its bin first on PATH
  AMENT_PREFIX_PATH=$VENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH} \
    CMAKE_PREFIX_PATH=$VENV${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH} \
    PATH=$VENV/bin:$PATH "$@"
}
