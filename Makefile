# Two commands do all set-up from nothing on a fresh Debian machine (as root):
#   make bench   the main job: build firmware + virtual Uno and run the latency benchmark
#   make test    lint, type-check, firmware host tests and fuzz targets, the whole pytest suite
#   make package-data   regenerate the firmware images the wheel ships
#   make bench RECORD=1 also record the results in benchmarks/results/ (tracked)
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
APT_PACKAGES := gcc-avr avr-libc binutils-avr simavr libsimavr-dev libelf-dev avrdude make gcc \
                clang libclang-rt-dev \
                arduino-core-avr chromium
SUDO := $(shell [ "$$(id -u)" -eq 0 ] || echo sudo)

.PHONY: all setup system-deps venv firmware sim bootloader package-data monitor-assets lint docs \
        test test-fast bench bench-peers generate clean avr8js avr8js-check

all: setup firmware sim

setup: system-deps venv monitor-assets avr8js

# Installs only what is missing, so a second run costs a dpkg query per package.
system-deps:
	@missing=""; for p in $(APT_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "installing system packages:$$missing"; \
	  $(SUDO) apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends $$missing; \
	fi

venv: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[dev]'
	touch $@

# The monitor's browser library (uPlot), pinned by package-lock.json, installed through npm
# into the package's static dir; never committed, never fetched at run time (docs/monitor.md).
MONITOR_NPM := arduinoio_async/monitor/npm
MONITOR_VENDOR := arduinoio_async/monitor/static/vendor
monitor-assets: $(MONITOR_VENDOR)/uPlot.iife.min.js

# npm: Debian's package unless a Node.js install already brings it (they conflict).
$(MONITOR_VENDOR)/uPlot.iife.min.js: $(MONITOR_NPM)/package.json $(MONITOR_NPM)/package-lock.json
	@command -v npm >/dev/null || { $(SUDO) apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends npm; }
	cd $(MONITOR_NPM) && npm ci --no-audit --no-fund --ignore-scripts --loglevel=error
	mkdir -p $(MONITOR_VENDOR)
	cp $(MONITOR_NPM)/node_modules/uplot/dist/uPlot.iife.min.js $(MONITOR_NPM)/node_modules/uplot/dist/uPlot.min.css $(MONITOR_VENDOR)/
	cp $(MONITOR_NPM)/node_modules/uplot/LICENSE $(MONITOR_VENDOR)/uPlot.LICENSE
	touch $@

# The second emulator (firmware/avr8js/runner.js, tests/avr8js): avr8js pinned by its
# package-lock.json, installed like the monitor's uPlot (never committed, never fetched at run time).
AVR8JS_DIR := firmware/avr8js
avr8js: $(AVR8JS_DIR)/node_modules/.installed

$(AVR8JS_DIR)/node_modules/.installed: $(AVR8JS_DIR)/package.json $(AVR8JS_DIR)/package-lock.json
	@command -v npm >/dev/null || { $(SUDO) apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends npm; }
	cd $(AVR8JS_DIR) && npm ci --no-audit --no-fund --ignore-scripts --loglevel=error
	touch $@

# The avr8js checks are opt-in (tests/avr8js says why).
avr8js-check: avr8js firmware
	AIO_AVR8JS=1 $(BIN)/pytest tests/avr8js -q -p no:cacheprovider

firmware: system-deps
	$(MAKE) -C firmware

sim: system-deps firmware
	$(MAKE) -C firmware/sim

# optiboot from arduino-core-avr's source, for the flashing tests (not committed, not shipped)
bootloader: system-deps
	$(MAKE) -C firmware/bootloader

# What the wheel ships: firmware images for every baud (committed, generated here).  The
# harness's C sources are not copied: the wheel build maps firmware/sim/*.c|*.h into
# arduinoio_async/_data/sim (setup.py).
PACKAGE_DATA := arduinoio_async/_data
package-data: firmware
	$(MAKE) -C firmware package PACKAGE_DIR=$(CURDIR)/$(PACKAGE_DATA)/firmware

generate: venv
	$(BIN)/python -m arduinoio_async.protocol.cheader
	$(BIN)/python -m arduinoio_async.protocol.docgen
	$(BIN)/python -m arduinoio_async.protocol.boards_doc

lint: venv
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy --strict

# The documentation site, strict: a broken link or reference fails the build.
docs: venv
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet --site-dir site

# The fuzz step replays firmware/tests/corpus and fuzzes each target for FUZZ_TIME s (8 s
# each, about 30 s with the builds); a longer run: make -C firmware fuzz FUZZ_TIME=600.
test: setup firmware sim bootloader lint docs
	$(MAKE) -C firmware test
	$(MAKE) -C firmware fuzz
	$(BIN)/pytest

# Results go to benchmarks/results/local/ (untracked); RECORD=1 writes the tracked
# benchmarks/results/latest.* that docs/performance.md cites.
BENCH_OUT := $(if $(RECORD),benchmarks/results,benchmarks/results/local)
bench: setup firmware sim
	@mkdir -p $(BENCH_OUT)
	$(BIN)/arduinoio bench --all --json $(BENCH_OUT)/latest.json --plot $(BENCH_OUT)/latest.png

# Side by side with Firmata (docs/performance.md, "Against Firmata"): StandardFirmata is
# fetched with npm into benchmarks/peers/.cache, its Python clients go into their own
# .venv-peers; nothing of either is committed.  About 15 minutes.
PEER_VENV := .venv-peers

$(PEER_VENV)/.installed: benchmarks/peers/requirements.txt
	$(PYTHON) -m venv $(PEER_VENV)
	$(PEER_VENV)/bin/pip install -q -r benchmarks/peers/requirements.txt
	touch $@

bench-peers: setup firmware sim $(PEER_VENV)/.installed
	@command -v npm >/dev/null || { $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends npm; }
	$(BIN)/python -m benchmarks.peers.peer_bench --json benchmarks/results/peers.json \
	  --doc docs/performance.md --readme README.md

clean:
	rm -rf firmware/build firmware/sim/build firmware/bootloader/build
