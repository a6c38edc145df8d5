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

# make fuzz only: clang 14 and its runtimes (libclang-rt-14-dev holds libFuzzer, ASan, UBSan).
FUZZ_DEBS := clang-14 libclang-rt-14-dev
FUZZ_SECONDS ?= 60
# FUZZ_RUNS=N also ends each target after N executions (whichever of the two comes first).
FUZZ_RUNS ?=
FUZZ_BUILD := $(ROOT)/.fuzz_build
FUZZ_TARGETS := model_yaml rig_yaml motion_yaml bag messages live_messages
# Largest input per target (bytes): above the largest seed (the seed bags of 52 kB are cut, the
# 9 kB ones are whole); larger inputs add only time per execution, no new code.
FUZZ_MAX_LEN_model_yaml := 8192
FUZZ_MAX_LEN_rig_yaml := 4096
FUZZ_MAX_LEN_motion_yaml := 8192
FUZZ_MAX_LEN_bag := 12288
FUZZ_MAX_LEN_messages := 1024
FUZZ_MAX_LEN_live_messages := 4096
# ASan as usual, but freshly allocated memory is not filled with 0xbe, the quarantine of freed
# memory is 32 MB (one execution frees a few MB: a use after free within it is still caught) and
# allocation stacks are 8 frames: the 256 MB default quarantine made every allocation touch a new
# page, and filling plus deep stacks were a third of each execution's time.
FUZZ_ASAN_OPTIONS := detect_leaks=0:max_malloc_fill_size=0:quarantine_size_mb=32:malloc_context_size=8

.PHONY: deps workspace build test demo clean fuzz

# Installs the Debian packages of $(1) that are missing.
define install_missing
	@missing=$$(for p in $(1); do dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null \
	  | grep -q 'install ok installed' || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "Installing missing Debian packages: $$missing"; \
	  $(SUDO) apt-get update -qq; \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends $$missing; \
	else echo "All Debian packages present."; fi
endef

deps:
	$(call install_missing,$(DEBS))

workspace:
	@mkdir -p $(WS)/src $(ROS_LOG_DIR)
	@touch $(WS)/CATKIN_IGNORE
	@ln -sfn $(ROOT) $(WS)/src/sag_hand_tracker

build: deps workspace
	cd $(WS) && catkin_make -DCMAKE_BUILD_TYPE=Release \
	  $(if $(CCACHE),-DCMAKE_CXX_COMPILER_LAUNCHER=$(CCACHE)) -j$(JOBS)

test: build
	@# The rostests' working folders of an earlier run (a stale 'ready' file starts a replay early).
	rm -rf $(ROS_HOME)/replay_*_test
	cd $(WS) && rm -rf build/test_results && catkin_make run_tests -j$(JOBS)
	@# catkin_test_results' summary, then the plain closing line CI counts ("N passed, N failed").
	@cd $(WS) && status=0 && { catkin_test_results build/test_results > test_summary.txt || status=$$?; } \
	  && cat test_summary.txt \
	  && sed -nE 's/^Summary: ([0-9]+) tests, ([0-9]+) errors, ([0-9]+) failures, ([0-9]+) skipped.*/\1 \2 \3 \4/p' \
	    test_summary.txt | awk '{print $$1-$$2-$$3-$$4 " passed, " $$2+$$3 " failed, " $$4 " skipped"}' \
	  && exit $$status

# libFuzzer targets (test/fuzz/): built with clang 14 and ASan + UBSan in $(FUZZ_BUILD), each run
# (one at a time, one process) for FUZZ_SECONDS (or FUZZ_RUNS executions) on its seeds
# (test/fuzz/corpus/<target>/); new inputs go to
# $(FUZZ_BUILD)/corpus/<target>/, crashes to $(FUZZ_BUILD)/crashes/<target>/ (copy them into the
# seed folder: make test replays every seed). Stops at the first target that finds something.
fuzz: build
	$(call install_missing,$(FUZZ_DEBS))
	cmake -S $(ROOT)/test/fuzz -B $(FUZZ_BUILD) -DCMAKE_CXX_COMPILER=clang++-14 \
	  $(if $(CCACHE),-DCMAKE_CXX_COMPILER_LAUNCHER=$(CCACHE)) -DSAG_DEVEL_INCLUDE=$(WS)/devel/include
	cmake --build $(FUZZ_BUILD) -j$(JOBS)
	@for spec in $(foreach t,$(FUZZ_TARGETS),$(t):$(FUZZ_MAX_LEN_$(t))); do \
	  t=$${spec%%:*}; max_len=$${spec##*:}; \
	  mkdir -p $(FUZZ_BUILD)/corpus/$$t $(FUZZ_BUILD)/crashes/$$t; \
	  echo "== fuzz_$$t for $(FUZZ_SECONDS) s$(if $(FUZZ_RUNS), or $(FUZZ_RUNS) runs), inputs up to $$max_len bytes"; \
	  ASAN_OPTIONS=$(FUZZ_ASAN_OPTIONS) $(FUZZ_BUILD)/fuzz_$$t -max_total_time=$(FUZZ_SECONDS) \
	    $(if $(FUZZ_RUNS),-runs=$(FUZZ_RUNS)) -max_len=$$max_len \
	    -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 \
	    -artifact_prefix=$(FUZZ_BUILD)/crashes/$$t/ $(FUZZ_BUILD)/corpus/$$t \
	    $(ROOT)/test/fuzz/corpus/$$t 2>&1 | grep -E '^(stat::|==|SUMMARY|INFO: (Running|Done)|fuzz finding)|Test unit written' || exit 1; \
	done

demo: build
	source $(WS)/devel/setup.bash && $(ROOT)/scripts/demo

clean:
	rm -rf $(WS) $(FUZZ_BUILD)
