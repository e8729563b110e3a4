# GPAtlasRRT: one-command set-up, build, test, demo and benchmarks.
#   make test    install what is missing, build (Release, ccache), run every test (and the install space)
#   make demo    install, build, run the headless simulated exploration
#   make bench   the exploration benchmark without ROS (BENCH_ARGS="...")
#   make demo OBJECT=path/to/mesh.stl SCALE=0.001   the demo on your own mesh
#   make soak    the long soak: 150 actions of the simulated loop (SOAK_ACTIONS=N), time per action
SHELL := /bin/bash
# Debian's ROS python modules live in /usr/bin/python3, not in a pyenv/venv python on PATH.
export PATH := /usr/bin:$(PATH)
export CCACHE_DIR ?= $(HOME)/.ccache
# Paths relative to the checkout in ccache's keys: a second clone (CI's) reuses the first one's objects.
export CCACHE_BASEDIR ?= $(CURDIR)

JOBS ?= 2
WS := catkin_ws
CATKIN_ARGS := -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3 \
  -DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCATKIN_ENABLE_TESTING=ON

OBJECT ?= procedural:mug
SCALE ?= 1.0
BENCH_ARGS ?= --object procedural:mug --strategy atlas_poke --strategy random --seeds 0

SOAK_ACTIONS ?= 150

.PHONY: deps build test demo bench lint bench-core soak clean

deps:
	@bash scripts/install_deps.sh

build: deps
	@echo "[build] catkin_make (Release, ccache, -j$(JOBS))"
	cd $(WS) && catkin_make $(CATKIN_ARGS) -j$(JOBS)

lint: deps
	@catkin_lint -W1 --strict $(WS)/src && echo "[lint] catkin_lint clean"
	@python3 scripts/function_lengths.py $(WS)/src --over 100 && echo "[lint] no function over 100 lines"

test: build
	@bash scripts/run_tests.sh $(JOBS)

demo: build
	@bash scripts/run_demo.sh "$(OBJECT)" "$(SCALE)" $(DEMO_ARGS)

bench: build
	$(WS)/devel/lib/probe_sim/gpatlas_bench $(BENCH_ARGS)

bench-core: build
	$(WS)/devel/lib/gpatlas_geometry/gpatlas_core_benchmark $(BENCH_CORE_ARGS)

# The soak test of make test (test/soak.test, 40 actions), longer: it prints where each action's
# wall time goes and the nodelet manager's memory, and fails if the time per action grows by half
# by action 40 (run it on an otherwise idle machine).
soak: build
	source $(WS)/devel/setup.bash && rostest --text probe_sim_ros soak.test max_actions:=$(SOAK_ACTIONS) check_wall_time:=true \
	  max_time_growth:=1.5

clean:
	rm -rf $(WS)/build $(WS)/devel $(WS)/install
