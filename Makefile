# Two commands do all set-up from nothing on a fresh Debian machine (as root):
#   make bench   the main job: build firmware + virtual Uno and run the latency benchmark
#   make test    lint, type-check, firmware host tests and the whole pytest suite
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
APT_PACKAGES := gcc-avr avr-libc binutils-avr simavr libsimavr-dev libelf-dev avrdude make gcc chromium
SUDO := $(shell [ "$$(id -u)" -eq 0 ] || echo sudo)

.PHONY: all setup system-deps venv firmware sim lint test test-fast bench generate clean monitor-assets

all: setup firmware sim

setup: system-deps venv monitor-assets

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

firmware: system-deps
	$(MAKE) -C firmware

sim: system-deps firmware
	$(MAKE) -C firmware/sim

generate: venv
	$(BIN)/python -m arduinoio_async.protocol.cheader
	$(BIN)/python -m arduinoio_async.protocol.docgen

lint: venv
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy --strict

test: setup firmware sim lint
	$(MAKE) -C firmware test
	$(BIN)/pytest

bench: setup firmware sim
	$(BIN)/arduinoio bench --all --json benchmarks/results/latest.json --plot benchmarks/results/latest.png

clean:
	rm -rf firmware/build firmware/sim/build
