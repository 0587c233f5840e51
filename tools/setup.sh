#!/usr/bin/env bash
# Fresh-machine install of agnav without a system ROS: venv from pinned wheels, interface builds, packages.
# Idempotent: each step is skipped when its inputs have not changed (stamps in build/stamps).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
VENV=$ROOT/.venv
STAMPS=$ROOT/build/stamps
mkdir -p "$STAMPS"
# shellcheck source=tools/ros_env.sh
source tools/ros_env.sh

pip_q() {  # pip_q ARGS... : quiet pip whose output is shown only on failure
  local log; log=$(mktemp)
  "$VENV/bin/pip" --disable-pip-version-check "$@" > "$log" 2>&1 || { grep -v "^WARNING: Location" "$log" >&2; rm -f "$log"; return 1; }
  rm -f "$log"
}
fresh() {  # fresh NAME FILES... : true when the stamp NAME matches the checksum of FILES
  local sum; sum=$(cat "${@:2}" | sha256sum | cut -d' ' -f1)
  [ -f "$STAMPS/$1" ] && [ "$(cat "$STAMPS/$1")" = "$sum" ]
}
stamp() { cat "${@:2}" | sha256sum | cut -d' ' -f1 > "$STAMPS/$1"; }

# 1. Build tools from Debian (only what is missing).
missing=()
for tool in cmake g++ make; do command -v "$tool" >/dev/null || missing+=("$tool"); done
if [ ${#missing[@]} -gt 0 ]; then
  echo "[setup] apt-get install ${missing[*]}"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO=sudo
  $SUDO apt-get update -qq && $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq cmake g++ make
fi

# 2. Virtual environment from pinned requirements.
if [ ! -x "$VENV/bin/python" ]; then
  echo "[setup] creating $VENV"
  python3.11 -m venv "$VENV" 2>/dev/null || python3 -m venv "$VENV"
  rm -f "$STAMPS"/*
fi
if ! fresh requirements requirements.txt requirements-nodeps.txt; then
  echo "[setup] installing pinned requirements"
  pip_q install -r requirements.txt
  pip_q install --no-deps -r requirements-nodeps.txt
  ros_env_fix_wheel_paths
  rm -f "$STAMPS"/iface-* "$STAMPS"/pkg-*
  stamp requirements requirements.txt requirements-nodeps.txt
fi

# 3. Interface packages built with rosidl straight into the venv prefix.
build_interfaces() {  # build_interfaces NAME SRC_DIR
  local name=$1 src=$2
  if fresh "iface-$name" "$src"/CMakeLists.txt "$src"/package.xml "$src"/msg/* $(ls "$src"/srv/* 2>/dev/null); then return; fi
  echo "[setup] building interfaces $name"
  rm -rf "build/$name"
  ros_env_run cmake -S "$src" -B "build/$name" -DCMAKE_INSTALL_PREFIX="$VENV" -DBUILD_TESTING=OFF \
      -DPython3_EXECUTABLE="$VENV/bin/python" -DCMAKE_BUILD_TYPE=Release > "build/$name.log" 2>&1 \
    && ros_env_run cmake --build "build/$name" -j 2 >> "build/$name.log" 2>&1 \
    && cmake --install "build/$name" >> "build/$name.log" 2>&1 \
    || { tail -40 "build/$name.log" >&2; echo "[setup] build of $name failed (log: build/$name.log)" >&2; exit 1; }
  stamp "iface-$name" "$src"/CMakeLists.txt "$src"/package.xml "$src"/msg/* $(ls "$src"/srv/* 2>/dev/null)
}
# tf2_msgs: only where the environment has none (a full ROS install brings its own).
if [ -f "$STAMPS/iface-tf2_msgs" ] || ! "$VENV/bin/python" -c "import tf2_msgs.msg" 2>/dev/null; then
  build_interfaces tf2_msgs vendor/tf2_msgs
fi
build_interfaces agnav_msgs src/agnav_msgs

# 4. The Python packages, editable, so that a checkout edit is live.
PKGS=(agnav_common agnav_drivers agnav_fusion agnav_control agnav_bringup agnav_sim_eval)
for p in "${PKGS[@]}"; do
  if ! fresh "pkg-$p" "src/$p/setup.py" "src/$p/package.xml" "src/$p/pyproject.toml"; then
    echo "[setup] installing $p"
    pip_q install --no-deps --no-build-isolation -e "src/$p"
    stamp "pkg-$p" "src/$p/setup.py" "src/$p/package.xml" "src/$p/pyproject.toml"
  fi
done
"$VENV/bin/python" -c "import agnav_msgs.msg, tf2_msgs.msg, agnav_bringup" \
  || { echo "[setup] verification import failed" >&2; exit 1; }
echo "[setup] ready: $VENV"
