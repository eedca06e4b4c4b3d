# Two commands do all set-up from nothing on a fresh Debian machine (as root):
#   make bench   the main job: build firmware + virtual Uno and run the latency benchmark
#   make test    lint, type-check, firmware host tests and the whole pytest suite
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
APT_PACKAGES := gcc-avr avr-libc binutils-avr simavr libsimavr-dev libelf-dev avrdude make gcc
SUDO := $(shell [ "$$(id -u)" -eq 0 ] || echo sudo)

.PHONY: all setup system-deps venv firmware sim lint test test-fast bench bench-peers generate clean

all: setup firmware sim

setup: system-deps venv

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
	$(BIN)/python benchmarks/peers/peer_bench.py --json benchmarks/results/peers.json \
	  --doc docs/performance.md --readme README.md

clean:
	rm -rf firmware/build firmware/sim/build
