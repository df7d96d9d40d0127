# The two entry points of the README:
#   make run   install dependencies, build, and run the demo (synthetic flight -> glam)
#   make test  install dependencies, build, and run every test (ctest)
# Both are idempotent; dependencies come from Debian packages via scripts/setup-deps.sh.
BUILD_DIR ?= build
PRESET_FLAGS ?= -DCMAKE_BUILD_TYPE=Release
JOBS ?= $(shell nproc)

.PHONY: deps configure build run test clean

deps:
	bash scripts/setup-deps.sh
	bash scripts/setup-node.sh

configure: deps
	cmake -S . -B $(BUILD_DIR) -G Ninja $(PRESET_FLAGS)

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	bash scripts/setup-deps.sh --with-test
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) --timeout 900

run: build
	bash scripts/demo.sh $(BUILD_DIR)

clean:
	rm -rf $(BUILD_DIR)
