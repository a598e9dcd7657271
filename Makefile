# freefloat: `make demo`, `make test`, `make bench`, `make docs` each create .venv and install on a fresh machine.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
OUT ?= out

.PHONY: demo test test-lowest bench docs lint clean kernels

$(VENV)/.runtime: pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e .
	touch $@

$(VENV)/.test: pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e ".[test,docs]"
	touch $(VENV)/.runtime $@

demo: $(VENV)/.runtime
	$(VENV)/bin/freefloat demo --out $(OUT) --overwrite

lint: $(VENV)/.test
	$(VENV)/bin/ruff check src tests benchmarks examples tools docs/_site_hooks.py
	$(VENV)/bin/ruff format --check src tests benchmarks examples tools docs/_site_hooks.py
	$(VENV)/bin/mypy
	$(VENV)/bin/lint-imports --no-cache

# The suite includes the wheel test (tests/test_release.py) and the strict documentation build (tests/test_docs_site.py).
# The test files run on TEST_WORKERS processes (pytest-xdist; a file's tests stay on one worker, so that a module's
# compiled kernels are made once): the suite takes 20 min on one core of a 2-core machine.
TEST_WORKERS ?= 2
# Each worker's batches run on numba's threads (GNU OpenMP), which wait for the next loop spinning for a few ms: with
# two workers on two cores that spin takes the other worker's core. A shorter spin (libgomp's GOMP_SPINCOUNT; other
# runtimes ignore it) made tests/simulation, tests/control and test_engine.py 72 s instead of 84 s (measured).
TEST_SPINCOUNT ?= 10000

# The suite runs on the portable kernels freefloat ships where this machine has not compiled its own (no background
# compile beside the test workers); tests/engine/test_portable.py tests the other settings.
TEST_KERNELS ?= portable

test: lint
	FREEFLOAT_KERNELS=$(TEST_KERNELS) $(PY) tests/warm_kernels.py
	FREEFLOAT_KERNELS=$(TEST_KERNELS) GOMP_SPINCOUNT=$(TEST_SPINCOUNT) $(PY) -m pytest -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder

# make test-lowest: freefloat at the lowest versions pyproject.toml declares, in a venv of its own (.venv-lowest, made
# again when pyproject.toml changes): tests/lowest/constraints.py pins every runtime dependency, the mjcf extra and the
# test tools to their lower bounds (what those need is pip's choice: the newest that fits). Then the smoke run of the
# library, every CLI command and a campaign (tests/lowest/smoke.py) and the engine's tests at the lowest numba, with
# make test's pytest options. Its compiled kernels go into .venv-lowest/cache, apart from the user's cache.
LOWEST := .venv-lowest
LOWEST_PY := $(LOWEST)/bin/python
LOWEST_CACHE := FREEFLOAT_CACHE_DIR=$(CURDIR)/$(LOWEST)/cache
ENGINE_TESTS := tests/mechanics/test_engine.py tests/mechanics/test_numba_cache.py tests/mechanics/test_threads.py \
	$(filter-out tests/engine/test_portable.py,$(wildcard tests/engine/*.py))

$(LOWEST)/.installed: pyproject.toml tests/lowest/constraints.py
	rm -rf $(LOWEST)
	$(PYTHON) -m venv $(LOWEST)
	$(LOWEST_PY) -m pip install -q --upgrade pip
	$(LOWEST_PY) tests/lowest/constraints.py $(LOWEST)/constraints.txt
	$(LOWEST_PY) -m pip install -q -c $(LOWEST)/constraints.txt -e ".[mjcf]" pytest pytest-xdist hypothesis
	touch $@

test-lowest: $(LOWEST)/.installed
	$(LOWEST_PY) tests/lowest/constraints.py --installed
	$(LOWEST_PY) -m pip freeze --exclude-editable
	$(LOWEST_CACHE) $(LOWEST_PY) tests/warm_kernels.py
	$(LOWEST_CACHE) $(LOWEST_PY) tests/lowest/smoke.py
	$(LOWEST_CACHE) GOMP_SPINCOUNT=$(TEST_SPINCOUNT) $(LOWEST_PY) -m pytest -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder $(ENGINE_TESTS)

# make kernels: the portable kernels freefloat ships (src/freefloat/engine/portable/: the warm-up's kernels compiled
# for numba's portable CPU), built again after a change to the engine's kernel sources (until then
# tests/engine/test_portable.py fails and every user compiles on first use): minutes.
kernels: $(VENV)/.runtime
	$(PY) tools/portable_kernels.py

bench: $(VENV)/.test
	$(PY) benchmarks/run.py --out $(OUT)/bench

# The documentation site into $(OUT)/site, with make demo's figures and tables (docs/_site_hooks.py);
# --strict: a broken link or a public name without a docstring fails.
docs: demo $(VENV)/.test
	FREEFLOAT_DEMO_OUT=$(OUT) NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict --site-dir $(OUT)/site

clean:
	rm -rf $(VENV) $(LOWEST) $(OUT) .pytest_cache .mypy_cache .ruff_cache
