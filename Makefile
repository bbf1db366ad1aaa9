# Every habit is one target; CI calls `make test`, so a local run and CI cannot drift.
# Installs come from the lock files (requirements/*.lock, `make lock` regenerates them from pyproject.toml):
# a clean clone gets the versions the suite last passed with, not whatever was released since.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
RUNTIME_LOCK := requirements/runtime.lock
DEV_LOCK := requirements/dev.lock
STAMP := $(VENV)/.installed-dev
RUNTIME_STAMP := $(VENV)/.installed-runtime
# --no-emit-*: the locks name packages and versions only, never this machine's index or wheel folder.
LOCK_FLAGS := --quiet --no-emit-index-url --no-emit-find-links --no-emit-trusted-host --strip-extras \
	--annotation-style=line

.PHONY: install install-runtime lock test test-fast lint typecheck pytest coverage bench run clean error-analysis browser \
	fuzz audit soak

# The installer is uv, itself pinned: `make install` on a clean clone takes ~11 s where pip took ~69 s
# (downloads in parallel; measured here, 2026-12-02). The venv's own pip installs only uv.
# --compile-bytecode: the packages' bytecode written once, on every core, at install (8 -> 16 s of wall here);
# without it each process that imports them compiles them again: every pytest-xdist worker of a clean clone's
# `make test` (a worker's collection 37 s of CPU cold against 29 s with the packages compiled, 2026-12-07), the
# serial part, and `make run`'s API and compute processes.
UV_VERSION := 0.13.9
UV := $(BIN)/uv pip install --quiet --compile-bytecode --python $(BIN)/python

$(VENV)/bin/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet uv==$(UV_VERSION)

# The developer's install: runtime + tools, exactly as locked, then the project itself without re-resolving.
$(STAMP): $(DEV_LOCK) pyproject.toml | $(VENV)/bin/python
	$(UV) -r $(DEV_LOCK)
	$(UV) --no-deps -e .
	touch $(STAMP) $(RUNTIME_STAMP)

# A user's install (`make run`): the runtime lock only, none of the dev tools.
$(RUNTIME_STAMP): $(RUNTIME_LOCK) pyproject.toml | $(VENV)/bin/python
	$(UV) -r $(RUNTIME_LOCK)
	$(UV) --no-deps -e .
	touch $(RUNTIME_STAMP)

install: $(STAMP)

install-runtime: $(RUNTIME_STAMP)

# The dev lock is constrained by the runtime lock, so both agree on every shared package.
lock: $(STAMP)
	$(BIN)/pip-compile $(LOCK_FLAGS) --upgrade -o $(RUNTIME_LOCK) pyproject.toml
	$(BIN)/pip-compile $(LOCK_FLAGS) --upgrade --extra dev -c $(RUNTIME_LOCK) -o $(DEV_LOCK) pyproject.toml
	$(BIN)/pip-compile $(LOCK_FLAGS) -o requirements/audit.lock requirements/audit.in

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/lint-imports

# mypy's incremental cache lives with the machine's other caches (uv's wheels, the native libraries), not in the
# clone: every clone and worktree on a machine shares it, a clean clone's CI run too. It is keyed by each module's
# content hash, not its path or mtime, so a clone elsewhere reads what another wrote and rechecks only what differs
# (and what depends on it): ~49 s of CPU cold, under 1 s warm, and an error put in any file is found either way
# (docs/development.md). The first run on a new machine pays the cold figure. MYPY_CACHE_DIR= (empty) writes none.
CACHE_HOME := $(or $(XDG_CACHE_HOME),$(HOME)/.cache)
MYPY_CACHE_DIR ?= $(CACHE_HOME)/iwr-calibration-mypy
MYPY_CACHE := --cache-dir=$(or $(MYPY_CACHE_DIR),/dev/null)
typecheck: $(STAMP)
	$(BIN)/mypy $(MYPY_CACHE)

# The UI tests drive Debian's Chromium through Playwright (no browser download is possible here); install the
# package when missing and we may, else the browser tests skip and say why.
CHROMIUM := /usr/bin/chromium
browser:
	@test -x $(CHROMIUM) || { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null && \
	  DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium >/dev/null; } || \
	  echo "note: $(CHROMIUM) is missing (apt-get install chromium): the browser tests will be skipped"

# pytest-xdist: three workers per two cores (below), and the tests marked `serial` (wall times, deadlines, load:
# pyproject.toml's markers) in a second pytest at a higher priority (`pytest`, below). Both parts run whatever
# the other's outcome, so one run shows every failure. `make pytest XDIST=0` (or test-fast) is one plain serial pytest, for debugging;
# XDIST=N sets the workers. Each worker builds its own session fixtures (registry, apps); what they share on
# disk (the native-library cache, PostgreSQL databases, broker queues) is named or written so they cannot mix.
# 1.5 workers per core: some tests wait more than they compute (a live server or a fleet starting, a job lease
# expiring, a browser page loading) and a third worker fills those waits, while each worker costs its collection
# and its own builds. Measured on this 2-core machine, the parallel part with coverage: -n 2 226 s, -n 3 214 s,
# -n 4 246 s (docs/development.md, "Test suite time").
NPROC := $(shell nproc 2>/dev/null || echo 2)
XDIST ?= $(shell echo $$(( $(NPROC) * 3 / 2 )))
PYTEST_PARALLEL := $(BIN)/pytest -n $(XDIST) --dist worksteal
# --cov-fail-under=0 on the parallel part: the floor ([tool.coverage.report] fail_under) is checked by
# `coverage report` afterwards. The serial part runs without coverage: its tests drive live servers in other
# processes, which coverage does not follow, and tracing the rest cost it ~30 s of its ~2 min.
COV_PART := --cov --cov-report= --cov-fail-under=0
# The project's own modules compiled once (~1 s on both cores) before the workers start, not once per worker.
# (The test modules are compiled again by pytest's assertion rewriting, which keeps a cache of its own.)
COMPILED := models optimal_design programs service harness iwr_client tests

# Everything, in two parts that both run whatever the other's outcome. On a machine free at the start where this
# user may raise a priority again (root, CAP_SYS_NICE: harness/priority.py checks both), the serial part starts at
# the normal priority and the parallel part beside it at the lowest (`nice -n 19`, inherited by every server,
# worker and browser it starts), raised back to normal once the serial part has ended. The serial tests mostly wait (servers starting,
# deadlines, fixed-length loads: ~46 s of CPU in ~75 s) and Linux gives a nice-19 process ~1.5 % of a core
# beside a nice-0 one, so the parallel part fills their idle time without taking a core from them: one after the
# other the two took 6 min 56 s here, together 6 min 16 s (docs/development.md). Raised back, the parallel part
# does not starve when other work shares the machine. Elsewhere, and on a busy machine (where the overlap only
# slows the serial part), the parts run one after the other, anything niced raised first. The serial
# part's report is printed after the parallel one's. Without coverage: tracing every line of the project's
# Python cost the parallel part 1 min 19 s of its 6 min 32 s (2026-12-07, clean clone), past `make test`'s
# budget; `make coverage` runs the same suite traced and checks the floor.
SERIAL_PART := $(BIN)/pytest -m serial -p no:cov
pytest: $(STAMP) browser
ifeq ($(XDIST),0)
	$(BIN)/pytest
else
	rc=0; \
	$(BIN)/python -m compileall -q -j 0 $(COMPILED) >/dev/null || rc=$$?; \
	if $(BIN)/python -m harness.priority --overlap; then \
	  serial_log=$$(mktemp); \
	  { $(SERIAL_PART) >"$$serial_log" 2>&1; echo $$? >"$$serial_log.rc"; \
	    $(BIN)/python -m harness.priority $(or $(PRIORITY_ROOT),$$$$); } & serial=$$!; \
	  nice -n 19 $(PYTEST_PARALLEL) -m "not serial" -p no:cov || rc=$$?; \
	  wait $$serial; serial_rc=$$(cat "$$serial_log.rc"); [ "$$serial_rc" = 0 ] || rc=$$serial_rc; \
	  echo "--- the serial part (run beside the parallel part, which yielded it the cores) ---"; \
	  cat "$$serial_log"; rm -f "$$serial_log" "$$serial_log.rc"; \
	else \
	  $(BIN)/python -m harness.priority $(or $(PRIORITY_ROOT),$$$$); \
	  $(PYTEST_PARALLEL) -m "not serial" -p no:cov || rc=$$?; \
	  $(SERIAL_PART) || rc=$$?; \
	fi; \
	exit $$rc
endif

# The whole suite with coverage and its floor ([tool.coverage] in pyproject.toml): ~1.5 min longer than `make
# test`; run it before a release and when a change adds modules.
coverage: $(STAMP) browser
	rc=0; \
	$(BIN)/python -m compileall -q -j 0 $(COMPILED) >/dev/null || rc=$$?; \
	$(PYTEST_PARALLEL) -m "not serial" $(COV_PART) || rc=$$?; \
	$(BIN)/pytest -m serial -p no:cov || rc=$$?; \
	$(BIN)/coverage report || rc=$$?; \
	exit $$rc

# Bytecode caches on for the test runs, whatever the shell says (this machine sets PYTHONDONTWRITEBYTECODE=1):
# otherwise each pytest process (a worker per core, then the serial part) recompiles the project and the
# assertion-rewritten plugins, ~11 s of CPU each (measured with the collection alone: 23 s against 12 s).
pytest coverage test-fast: export PYTHONDONTWRITEBYTECODE :=

# The inner loop: the tests neither slow nor serial, no coverage; one worker per core (its tests compute, none
# waits, and each worker pays the collection). The serial tests assert wall times and budgets, which need the cores
# to themselves and so a second pytest after the first (~8 s of start-up and tests): `make test` runs them.
test-fast: $(STAMP)
ifeq ($(XDIST),0)
	$(BIN)/pytest -m "not slow and not serial"
else
	$(BIN)/pytest -n $(NPROC) --dist worksteal -m "not slow and not serial"
endif

# mypy (one process: ~49 s of CPU on a new machine, under 1 s with its cache warm) runs beside the tests rather
# than before them, at the parallel part's priority (so it never takes a core from the serial tests, and is raised
# back with it: PRIORITY_ROOT, this recipe's shell); its report is printed at the end, and any failure of either
# fails the target.
test: lint
	@log=$$(mktemp); rc=0; \
	if $(BIN)/python -m harness.priority --overlap; then background="nice -n 19"; else background=; fi; \
	$$background $(MAKE) --no-print-directory typecheck >"$$log" 2>&1 & typecheck=$$!; \
	$(MAKE) --no-print-directory pytest PRIORITY_ROOT=$$$$ || rc=$$?; \
	wait $$typecheck || rc=1; \
	cat "$$log"; rm -f "$$log"; exit $$rc

# Schemathesis longer than `make test` does (SQLite and PostgreSQL, stateless and stateful): ~10 min here;
# then hypothesis on the URDF and structure readers, 2 000 random documents per property, not the fixed seed
# of `make test` (~20 s).
fuzz: $(STAMP)
	IWR_FUZZ_EXAMPLES=150 IWR_FUZZ_STEPS=10 IWR_FUZZ_STATEFUL=sqlite,postgres \
		IWR_CONTRACT_EXAMPLES=150 IWR_CONTRACT_BOUNDARIES=1 $(BIN)/pytest -p no:cacheprovider \
		tests/service/test_contract.py tests/service/test_contract_fuzz.py
	IWR_URDF_FUZZ_EXAMPLES=2000 $(BIN)/pytest -p no:cacheprovider tests/models/test_urdf_fuzz.py \
		tests/models/test_importer_fuzz.py
	IWR_READER_FUZZ_EXAMPLES=2000 $(BIN)/pytest -p no:cacheprovider tests/service/test_reader_fuzz.py

# The load and fleet tests at their full length (IWR_SOAK=1, tests/service/helpers.py): 50 clients for 10 s, 12 s
# of mixed load with oversized requests, 200 jobs through two APIs and two workers (~3 min here). `make test`
# runs the same assertions shorter (5 s, 7 s, 60 jobs): what they add by running longer is only waiting.
soak: $(STAMP)
	IWR_SOAK=1 $(BIN)/pytest -p no:cacheprovider tests/service/test_concurrency.py tests/service/test_load_hardening.py \
	  tests/service/test_jobs_distributed.py::test_mixed_jobs_through_two_apis_and_two_workers_with_a_restart_and_a_kill

# The dependency audit: pip-audit, in a venv of its own (requirements/audit.lock: the tool never imports the
# project), looks up every pinned package of both lock files in an advisory database, PyPI's by default
# (`make audit AUDIT_SERVICE=osv` for OSV's). --strict makes a package it could not look up a failure, so an
# unreachable or partial source never reads as "no known vulnerabilities". Not part of `make test`: no advisory
# source is reachable from this machine or its CI (docs/security.md says how to run it where one is).
AUDIT_VENV := .venv-audit
AUDIT_SERVICE ?= pypi
$(AUDIT_VENV)/.installed: requirements/audit.lock | $(VENV)/bin/python
	$(PYTHON) -m venv $(AUDIT_VENV)
	$(BIN)/uv pip install --quiet --python $(AUDIT_VENV)/bin/python -r requirements/audit.lock
	touch $@

audit: $(AUDIT_VENV)/.installed
	$(AUDIT_VENV)/bin/pip-audit --strict --no-deps --disable-pip --progress-spinner off \
	  --vulnerability-service $(AUDIT_SERVICE) -r $(RUNTIME_LOCK) -r $(DEV_LOCK)

bench: $(STAMP)
	$(BIN)/python -m benchmarks

error-analysis: $(STAMP)
	$(BIN)/python -m models.error_analysis --plot docs/error_analysis.png

# `make run PORT=8080 HOST=0.0.0.0` to serve elsewhere.
HOST ?= 127.0.0.1
PORT ?= 8000
run: $(RUNTIME_STAMP)
	$(BIN)/python -m service --host $(HOST) --port $(PORT)

clean:
	rm -rf $(VENV) $(AUDIT_VENV) .mypy_cache .ruff_cache .pytest_cache .coverage .import_linter_cache
