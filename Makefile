# Two commands for a fresh Debian 12 machine (as root or with sudo):
#   make demo   install missing Debian packages, build, run the main job
#   make test   the same set-up, then every test (gtest + rostest); fails on any failure
# and `make build` to build only. The catkin workspace lives in .catkin_ws/ (git-ignored).
SHELL := /bin/bash
.SHELLFLAGS := -eo pipefail -c
ROOT := $(CURDIR)
WS := $(ROOT)/.catkin_ws
JOBS ?= 2
# A python3 from another install earlier on PATH breaks catkin (doc/design.md section 7).
export PATH := /usr/bin:/bin:/usr/sbin:/sbin:$(PATH)
export ROS_HOME ?= $(WS)/ros_home
export ROS_LOG_DIR ?= $(WS)/ros_home/log
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
# A compiler cache when the machine has one (developers' worktrees share it); builds without it too.
CCACHE := $(shell command -v ccache 2>/dev/null)

# Debian 12's own ROS 1 packages and the libraries the package uses.
DEBS := ros-desktop-dev catkin rosbash libcv-bridge-dev libimage-geometry-dev \
  libdiagnostic-updater-dev libcamera-info-manager-dev libcamera-calibration-parsers-dev \
  librosbag-storage-dev libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure \
  libnodeletlib-dev libnodelet-dev libnodeletlib-tools libmessage-filters-dev libtf2-ros-dev \
  libimage-transport-dev python3-rostest python3-rosbag python3-roslaunch python3-rostopic rviz \
  libopencv-dev libeigen3-dev libyaml-cpp-dev libgtest-dev libbenchmark-dev xvfb \
  cmake g++ make

.PHONY: deps workspace build test demo clean

deps:
	@missing=$$(for p in $(DEBS); do dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null \
	  | grep -q 'install ok installed' || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "Installing missing Debian packages: $$missing"; \
	  $(SUDO) apt-get update -qq; \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends $$missing; \
	else echo "All Debian packages present."; fi

workspace:
	@mkdir -p $(WS)/src $(ROS_LOG_DIR)
	@touch $(WS)/CATKIN_IGNORE
	@ln -sfn $(ROOT) $(WS)/src/sag_hand_tracker

build: deps workspace
	cd $(WS) && catkin_make -DCMAKE_BUILD_TYPE=Release \
	  $(if $(CCACHE),-DCMAKE_CXX_COMPILER_LAUNCHER=$(CCACHE)) -j$(JOBS)

test: build
	cd $(WS) && rm -rf build/test_results && catkin_make run_tests -j$(JOBS)
	@# catkin_test_results' summary, then the plain closing line CI counts ("N passed, N failed").
	@cd $(WS) && status=0 && { catkin_test_results build/test_results > test_summary.txt || status=$$?; } \
	  && cat test_summary.txt \
	  && sed -nE 's/^Summary: ([0-9]+) tests, ([0-9]+) errors, ([0-9]+) failures, ([0-9]+) skipped.*/\1 \2 \3 \4/p' \
	    test_summary.txt | awk '{print $$1-$$2-$$3-$$4 " passed, " $$2+$$3 " failed, " $$4 " skipped"}' \
	  && exit $$status

demo: build
	source $(WS)/devel/setup.bash && $(ROOT)/scripts/demo

clean:
	rm -rf $(WS)
