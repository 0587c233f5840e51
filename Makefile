# agnav — two commands on a fresh machine: `make run` (main job) and `make test`.
SHELL := /bin/bash
VENV := .venv
PY := $(VENV)/bin/python
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
export ROS_LOG_DIR := $(CURDIR)/build/ros_log

.PHONY: setup run test bench clean colcon

setup:
	@bash tools/setup.sh

run: setup
	$(VENV)/bin/agnav run $(or $(ARGS),--record out/run)

test: setup
	@bash tools/test.sh $(ARGS)

colcon: setup  # build + colcon test every package of src/ in build/colcon_ws (README: colcon workspace)
	@bash tools/colcon.sh

bench: setup
	$(VENV)/bin/agnav bench $(or $(NAME),replay)

clean:
	rm -rf build $(VENV) out
