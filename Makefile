# GPAtlasRRT: one-command set-up, build, test, demo and benchmarks.
#   make test    install what is missing, build (Release, ccache), run every test
#   make demo    install, build, run the headless simulated exploration
#   make bench   the exploration benchmark (BENCH_ARGS="...")
SHELL := /bin/bash
# Debian's ROS python modules live in /usr/bin/python3, not in a pyenv/venv python on PATH.
export PATH := /usr/bin:$(PATH)
export CCACHE_DIR ?= $(HOME)/.ccache

JOBS ?= 2
WS := catkin_ws
CATKIN_ARGS := -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3 \
  -DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCATKIN_ENABLE_TESTING=ON

.PHONY: deps build test lint bench-core clean

deps:
	@bash scripts/install_deps.sh

build: deps
	@echo "[build] catkin_make (Release, ccache, -j$(JOBS))"
	cd $(WS) && catkin_make $(CATKIN_ARGS) -j$(JOBS)

lint: deps
	@catkin_lint -W1 --strict $(WS)/src && echo "[lint] catkin_lint clean"

test: build
	@bash scripts/run_tests.sh $(JOBS)

bench-core: build
	$(WS)/devel/lib/gpatlas_core/gpatlas_core_benchmark $(BENCH_CORE_ARGS)

clean:
	rm -rf $(WS)/build $(WS)/devel
