# The painting station: set-up, demo, tests.  `make demo` and `make test` each
# set up everything they need on a fresh Debian/Ubuntu machine.

VENV    ?= .venv
PYTHON  ?= python3
PY      := $(VENV)/bin/python
STATION := $(VENV)/bin/station
# Mesa headless GL (EGL + llvmpipe), Xvfb for the interactive-calibration tests,
# libusb for pyusb; libgomp1 gives numba its thread-safe OpenMP layer (the kiosk steps
# the canvas in a thread of its own; numba's fallback layer is not thread-safe).
# No compiler or headers: every Python dependency installs from a binary wheel
# (python-evdev as evdev-binary).
SYS_PKGS := libegl1 libegl-mesa0 libgl1 libgl1-mesa-dri libgles2 xvfb xauth libusb-1.0-0 \
            libgomp1 python3-venv
# Chromium for the kiosk's gallery-page test (skipped where it cannot be installed).
TEST_PKGS := chromium
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: setup sysdeps testdeps venv demo test lint lint-mapped bench clean

setup: sysdeps venv

sysdeps:
	@missing=""; for p in $(SYS_PKGS); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "installing system packages:$$missing"; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq $$missing; \
	fi

# only `make test` needs these: `make demo` stays small
testdeps: sysdeps
	@for p in $(TEST_PKGS); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "ok installed" || \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq $$p || \
	  echo "note: $$p not installed; the tests that need it are skipped"; \
	done

venv: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml
	@[ -x $(PY) ] || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip setuptools wheel
	@# a venv made before evdev-binary has the source-built evdev in the same files: replace it
	@if $(PY) -m pip show -q evdev >/dev/null 2>&1; then \
	  $(PY) -m pip uninstall -q -y evdev evdev-binary; fi
	$(PY) -m pip install -q --only-binary=:all: -e '.[test]'
	@touch $@

# the cpu step's kernels compile once into numba's cache, in two processes at once (a
# fresh checkout's first step would compile them one after another on one core)
demo: setup
	$(PY) -m station.backends.cpu.warm
	$(STATION) demo -o painting.png

# two workers: most of the suite's time is real processes and windows waiting for each
# other, which a second worker overlaps (tests/conftest.py keeps each worker's displays,
# runtime and config directories apart); the kernels are compiled first, in two processes
# each compiling half of them (otherwise both workers compile all of them at once), then
# the brushes' and the kiosk display's (~30 s from an empty cache, which each worker paid)
test: testdeps venv
	$(PY) -m station.backends.cpu.warm
	$(PY) -m station.kiosk.warm
	$(PY) -m pytest -q -n 2

lint: venv
	$(VENV)/bin/ruff check .
	$(VENV)/bin/mypy station drivers calibration
	@# the issue's --strict promise, as written (it follows imports into bus, events …)
	$(VENV)/bin/mypy --strict station/canvas station/brush station/sim station/kiosk

# `mypy station drivers calibration` cannot find station.drivers.* or station.calibration.*
# (the mapping drivers/ -> station.drivers is setuptools'), so it reads every such import
# as Any.  This checks the tree as installed: a folder of links with drivers/, calibration/
# and shaders/ inside station/, where mypy follows every import.
MAPPED := build/mypy-mapped
lint-mapped: venv
	@rm -rf $(MAPPED) && mkdir -p $(MAPPED)/station
	@for e in station/*; do ln -s "$(CURDIR)/$$e" $(MAPPED)/station/; done
	@for d in drivers calibration shaders; do ln -s "$(CURDIR)/$$d" $(MAPPED)/station/$$d; done
	cd $(MAPPED) && $(CURDIR)/$(VENV)/bin/mypy --config-file $(CURDIR)/pyproject.toml \
	  --cache-dir $(CURDIR)/.mypy_cache/mapped -p station

bench: setup
	$(STATION) bench bus --json

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .mypy_cache .ruff_cache
