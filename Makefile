# Two commands do everything on a fresh machine:
#   make demo   renders the embedded `demo` world and runs the pipeline end to end
#   make test   runs ruff, the tests not marked slow, the example estimator plugin's tests and
#               the documentation site's strict build (what CI runs)
#   make test-all  the same with every test, the slow ones included (long end-to-end runs,
#               more seeds, killed workers)
# Both create .venv and install what is needed first (system libraries too, when root on Debian).
#   make docs   the documentation site (mkdocs.yml) into site/, with `mkdocs build --strict`
#   make suite  every estimator on every dataset (benchmarks/grids/suite.yaml): results in
#               runs/suite (not committed), the report in reports/suite, the results table of
#               the README and of docs/results/index.md

PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
PLUGIN := examples/estimator_plugin
STAMP  := $(VENV)/.installed-$(shell cat pyproject.toml $(PLUGIN)/pyproject.toml | cksum | cut -d' ' -f1)
SYSLIBS := libusb-1.0-0 libgl1 libegl1 libx11-6 libudev1 libgomp1

.PHONY: test test-all demo docs suite venv kernels syslibs lint clean

venv: $(STAMP)

$(STAMP): pyproject.toml $(PLUGIN)/pyproject.toml
	@$(MAKE) --no-print-directory syslibs
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	$(BIN)/python -m pip install --quiet --no-deps -e $(PLUGIN)
	@rm -f $(VENV)/.installed-*
	@touch $@

# the SIFT kernels compiled ahead of time for this machine (omnislam/frontend/kernels_aot.py;
# a no-op when built, numba's just-in-time path when they cannot be)
kernels: venv
	@$(BIN)/python -m omnislam.frontend.kernels_aot

# open3d needs a few shared libraries that a minimal Debian lacks.
syslibs:
	@missing=""; \
	if command -v dpkg-query >/dev/null 2>&1; then \
	  for p in $(SYSLIBS); do \
	    dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	  done; \
	fi; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then \
	    echo "installing system libraries:$$missing"; \
	    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $$missing) >/dev/null \
	      || echo "warning: could not install$$missing; open3d may fail to import"; \
	  else \
	    echo "open3d needs system libraries; run: sudo apt-get install -y$$missing"; \
	  fi; \
	fi

lint: venv
	$(BIN)/ruff check .

# PYTEST_MARKS: which tests `make test` runs (`make test-all` runs them all);
# PYTEST_WORKERS: pytest-xdist processes, one per core by default (a test module stays on one
# worker, so its module fixtures are built once)
PYTEST_MARKS ?= not slow
PYTEST_WORKERS ?= $(shell nproc 2>/dev/null || echo 2)

test: kernels
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -q -n $(PYTEST_WORKERS) --dist loadscope \
	  $(if $(PYTEST_MARKS),-m "$(PYTEST_MARKS)")
	$(BIN)/python -m pytest -q $(PLUGIN)/tests
	@$(MAKE) --no-print-directory docs

test-all:
	@$(MAKE) --no-print-directory test PYTEST_MARKS=

# the site reads the package's docstrings from this checkout (mkdocs.yml: paths [.])
docs: venv
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet

demo: kernels
	$(BIN)/omnislam demo --overwrite

# SUITE_WORKERS=N: N local worker processes (default: one per core);
# SCHEDULER=tcp://HOST:8786: a Dask cluster (docs/tutorials/dask.md), or
# SCHEDULER=local for a LocalCluster. Finished cells, renders and front-end logs are reused.
SUITE_RESULTS ?= runs/suite
SUITE_REPORT  ?= reports/suite
SUITE_WORKERS ?=
SCHEDULER     ?=
# the committed report must stay small
SUITE_MAX_BYTES := 5242880

suite: kernels
	$(BIN)/omnislam compare benchmarks/grids/suite.yaml --out $(SUITE_RESULTS) --resume \
	  $(if $(SCHEDULER),--scheduler $(SCHEDULER)) $(if $(SUITE_WORKERS),--workers $(SUITE_WORKERS)); \
	status=$$?; test $$status -le 1 || exit $$status; \
	$(BIN)/omnislam report $(SUITE_RESULTS) --out $(SUITE_REPORT) --no-exports --no-figures \
	  --overwrite \
	  && $(BIN)/python benchmarks/suite_table.py --report $(SUITE_REPORT) --readme README.md \
	  && $(BIN)/python benchmarks/suite_table.py --report $(SUITE_REPORT) \
	       --readme docs/results/index.md \
	  || exit $$?; \
	size=$$(du -sb $(SUITE_REPORT) | cut -f1); \
	if [ $$size -gt $(SUITE_MAX_BYTES) ]; then \
	  echo "warning: $(SUITE_REPORT) is $$size bytes (> $(SUITE_MAX_BYTES)): too big to commit"; fi; \
	test $$status -eq 0 || echo "some cells failed (named above and in the report)"; \
	exit $$status

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache .hypothesis site
