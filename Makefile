# tescalib: the two commands are `make demo` and `make test` (see README.md).
SHELL := /bin/bash
ROOT := $(abspath .)
BUILD := $(ROOT)/build
# Debian's python3 must come before any pyenv python3 (catkin needs catkin_pkg from Debian).
export PATH := /usr/bin:/bin:/usr/sbin:/sbin:$(PATH)
JOBS ?= 2
# ccache, when installed, makes rebuilds and builds of other work trees of the repository cheap.
CCACHE := $(shell command -v ccache 2>/dev/null)
export CCACHE_BASEDIR := $(abspath ..)
# The devel space lives in .devel and build/devel links to it: rosrun ignores every path under
# <package>/build/, and the package is the repository root.
DEVEL := $(ROOT)/.devel

.PHONY: all deps build test test-fast demo bench install-check format clean

all: build

deps:
	@bash scripts/install_deps.sh

$(BUILD)/Makefile: CMakeLists.txt package.xml
	@mkdir -p $(BUILD)
	@# catkin bakes PYTHONPATH into build/catkin_generated/setup_cached.sh at configure time and
	@# skips folders that do not exist yet: without this, rostests of a fresh clone cannot import
	@# the generated tescalib.msg.
	@mkdir -p $(DEVEL)/lib/python3/dist-packages
	cd $(BUILD) && cmake $(ROOT) -DCMAKE_BUILD_TYPE=Release \
	  -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 \
	  -DCATKIN_DEVEL_PREFIX=$(DEVEL) -DCATKIN_ENABLE_TESTING=ON \
	  $(if $(CCACHE),-DCMAKE_CXX_COMPILER_LAUNCHER=$(CCACHE)) > $(BUILD)/cmake.log \
	  || (cat $(BUILD)/cmake.log; exit 1)

build: deps $(BUILD)/Makefile
	@$(MAKE) --no-print-directory -C $(BUILD) -j$(JOBS) 2>&1 | grep -v -E '^\[ *[0-9]+%\] Built target' ; exit $${PIPESTATUS[0]}
	@# Python message modules too (demo_report.py, the rostest): setup.bash only puts
	@# lib/python3/dist-packages on PYTHONPATH when it exists at the time it is sourced.
	@$(MAKE) --no-print-directory -C $(BUILD) tescalib_generate_messages > /dev/null
	@ln -sfn $(DEVEL) $(BUILD)/devel
	@echo "[build] done: source build/devel/setup.bash, then rosrun tescalib NAME"

test: build
	@bash scripts/install_deps.sh --dev
	@bash scripts/run_tests.sh

# The gtests that take seconds, for everyday work (make test runs everything, as CI does).
test-fast: build
	@bash scripts/install_deps.sh --dev
	@bash scripts/run_tests.sh --fast

demo: build
	@bash scripts/demo.sh

bench: build
	@bash scripts/bench.sh

install-check: deps
	@bash scripts/check_install.sh

format:
	@bash scripts/install_deps.sh --dev
	@clang-format -i $$(git ls-files '*.cpp' '*.h')

clean:
	rm -rf $(BUILD) $(DEVEL)
