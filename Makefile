# boat_twin: every target sets up its own virtual environment. `make demo` installs the package alone (what the
# demo needs); every other target adds the test tools, ROS 2 Jazzy's core (PyPI wheels, the `ros` extra of
# setup.py: ros-jazzy-rclpy, ros-jazzy-rmw-fastrtps-cpp and the message packages), Dask (the `fleet` extra) and
# the foxglove-sdk (the `view` extra).
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
BASE_STAMP := $(VENV)/.installed-base
STAMP := $(VENV)/.installed
RUFF := $(PY) -m ruff check  # configured in .ruff.toml
# setuptools warns on every editable install of a flat layout that a folder named like the package in the working
# directory could shadow it (a box of asterisks); here that folder is the package itself, so the warnings of that
# one setuptools module are silenced.
PIP_INSTALL := PYTHONWARNINGS=ignore:::setuptools.command.editable_wheel $(PY) -m pip install -q
OUT ?= out

.PHONY: setup test lint demo bench sample clean

setup: $(STAMP)

# The package and its required dependencies; two short simulations (open loop, and a zigzag: the closed-loop
# kernel with its compiled helm) compile the numba kernels into their cache (boat_twin/vessel/__pycache__), so
# that no later command pays the compilation (docs/model.md).
$(BASE_STAMP): setup.py setup.cfg package.xml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PIP_INSTALL) -e .
	$(VENV)/bin/boat-twin simulate thrust-steps --duration 1 --json > /dev/null
	$(VENV)/bin/boat-twin simulate zigzag-20-20 --duration 1 --json > /dev/null
	touch $(BASE_STAMP)

$(STAMP): $(BASE_STAMP)
	$(PIP_INSTALL) -e '.[test,ros,fleet,view]'
	touch $(STAMP)

lint: $(STAMP)
	$(RUFF) boat_twin test benchmarks launch setup.py
	$(PY) -m mypy boat_twin  # configured in setup.cfg

# -rs: say why anything is skipped. -n auto: one pytest-xdist worker per core, an idle one taking tests queued
# for the other (--dist worksteal: the long tests do not leave one core idle at the end); then the node tests apart (a live
# recorder sharing the cores with the CPU-bound tests lags the simulated clock: test/conftest.py), in two workers
# of their own, a module each at a time (they mostly wait on their node processes: 3 min 25 s at load 1-4, 8 min
# 34 s one after another at load 5-6, for the same CPU: docs/ros.md). The long studies marked
# `slow` run with SLOW=1, which CI sets (.ci/run; also CI=true): a developer's run leaves them out.
# A test still running after TEST_TIMEOUT_S (pytest-timeout; the longest took 35 s idle, and 100.5 s, a node
# module's fixture, with two CI runs at once: PYTEST_ADDOPTS=--durations=15 .ci/run) fails with the stack of every thread, and the run goes on: a hang names itself
# instead of stalling the run until CI's own limit.
SLOW ?= $(if $(filter true,$(CI)),1,)
TEST_MARK := not ros_nodes$(if $(SLOW),, and not slow)
TEST_TIMEOUT_S ?= 900
PYTEST := $(PY) -m pytest -q -rs --timeout=$(TEST_TIMEOUT_S) --timeout-method=signal
test: lint
	$(PYTEST) -n auto --dist worksteal -m "$(TEST_MARK)" test
	$(PYTEST) -n 2 --dist loadfile --no-loadscope-reorder -m "ros_nodes$(if $(SLOW),, and not slow)" test

demo: $(BASE_STAMP)
	$(VENV)/bin/boat-twin demo --out $(OUT)/demo --force

bench: $(STAMP)
	@$(PY) -c "import sklearn" 2>/dev/null || $(PY) -m pip install -q "scikit-learn>=1.3"  # setup.py's bench extra
	@for b in benchmarks/bench_*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

sample: $(BASE_STAMP)
	$(VENV)/bin/boat-twin simulate thrust-steps --seed 1 --out bags/thrust_steps_sample --force

clean:
	rm -rf $(VENV) $(OUT) build *.egg-info
