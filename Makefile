# e2esim: every target creates (or reuses) a local virtual environment in .venv with what it needs.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
CORE := $(VENV)/.e2esim-core
STAMP := $(VENV)/.e2esim-installed
# CORE: e2esim and what the default scenario needs (`make demo`); STAMP: also every optional extra and the test
# tools (`make test`). pip shows what it collects and installs (no --quiet): a first install is not a silent minute.
PIP := $(BIN)/python -m pip install --progress-bar on

.PHONY: demo test test-slow reference benchmark clean

define new_venv
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 10) else "e2esim needs Python 3.10 or newer (set PYTHON=python3.x)")'
	test -x $(BIN)/python || { $(PYTHON) -m venv $(VENV) && { $(BIN)/python -c '$(PIP_IS_RECENT)' || \
		$(BIN)/python -m pip install --quiet 'pip>=21.3'; }; }
endef
# (a new venv's pip is brought to 21.3 or newer: editable installs from pyproject.toml, PEP 660; the pip that
# Python 3.11 and later bring is newer, so only 3.10's asks the package index)
PIP_IS_RECENT := import sys, pip; sys.exit(tuple(map(int, pip.__version__.split(".")[:2])) < (21, 3))

# The core is installed without compiling every module of its packages (--no-compile: two thirds of the install's
# CPU time); `make demo` writes the bytecode of the modules it imports (PYTHONDONTWRITEBYTECODE lifted for it).
$(CORE): pyproject.toml
	$(new_venv)
	$(PIP) --no-compile -e .
	$(BIN)/python -m compileall -q src  # bytecode, as a regular install has (PYTHONDONTWRITEBYTECODE may be set)
	@touch $(CORE)

# After `make demo` (CORE newer than pyproject.toml) e2esim is installed: only the requirements the extras add are
# (tools/extra_requirements.py), not e2esim's editable wheel built a second time in a fresh build environment.
# pip compiles the modules it installs one by one (about 25 s on a fresh clone), and compiling the whole venv
# afterwards takes 11 s on two cores (18 s of CPU for 6,500 modules). The suite imports about 1,800 of them: they
# are compiled on first import instead (PYTHONDONTWRITEBYTECODE is lifted for the tests, so once), about 9 s of
# CPU even where both test processes compile the 1,450 that collecting the tests imports at the same moment.
$(STAMP): pyproject.toml
	$(new_venv)
	if [ $(CORE) -nt pyproject.toml ] && $(BIN)/python tools/extra_requirements.py test > $(VENV)/.e2esim-test-requirements; \
	then $(PIP) --no-compile -r $(VENV)/.e2esim-test-requirements; else $(PIP) --no-compile -e ".[test]"; fi
	$(BIN)/python -m compileall -q -j 0 src
	@touch $(CORE) $(STAMP)

demo: $(CORE)  ## install (the core only) and run the default BIOMASS scenario
	env -u PYTHONDONTWRITEBYTECODE $(BIN)/e2esim run scenarios/biomass_default.yaml --force

# pytest rewrites the asserts of every test module it imports (about 5 s of CPU in each process of the suite) and
# keeps the result as bytecode for the next run only where bytecode may be written: PYTHONDONTWRITEBYTECODE is
# lifted for the tests, as for `make demo`.
test: $(STAMP)  ## install and run the linter and the test suite (slow tests excluded)
	$(BIN)/ruff check src tests benchmarks examples docs
	env -u PYTHONDONTWRITEBYTECODE $(BIN)/python -m pytest -n 2 --dist loadgroup

test-slow: $(STAMP)  ## the slow statistical and end-to-end tests only
	env -u PYTHONDONTWRITEBYTECODE $(BIN)/python -m pytest -m slow

reference: $(STAMP)  ## regenerate the generated documentation
	$(BIN)/python -m e2esim.docs_reference docs/scenario-reference.md

# The benchmarks time processes from their start: the venv is compiled first, so that none of them pays for
# compiling what it imports (nor compiles it again where PYTHONDONTWRITEBYTECODE is set).
benchmark: $(STAMP)  ## speed measurements (ratios against the reference implementations)
	$(BIN)/python -m compileall -q -j 0 src $(VENV)/lib
	$(BIN)/python benchmarks/bench_crosspol.py
	$(BIN)/python benchmarks/bench_calibration.py
	$(BIN)/python benchmarks/bench_retrieval.py
	$(BIN)/python benchmarks/bench_climatology.py
	$(BIN)/python benchmarks/bench_end_to_end.py
	$(BIN)/python benchmarks/bench_stack.py
	$(BIN)/python benchmarks/bench_sweeps.py --skip-map
	$(BIN)/python benchmarks/bench_scenarios.py

clean:
	rm -rf $(VENV) runs .pytest_cache src/*.egg-info
