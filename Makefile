# aion — the two commands: `make demo` and `make test`.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp
DEMO := demo-out

.PHONY: install system-deps test lint typecheck pytest demo bench sample clean

## system libraries pip cannot install (libusb-1.0 for open3d), with apt-get/dnf/apk if missing
system-deps:
	@bash .ci/system-deps.sh

$(STAMP): pyproject.toml
	@bash .ci/system-deps.sh
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[test,export,dask]'
	touch $(STAMP)

## the package's bytecode, compiled once: an interpreter run with PYTHONDONTWRITEBYTECODE (as
## some CI machines and containers are) otherwise compiles every module of aion again at every
## command (0.2 s of each `aion predict`); compileall redoes only the files that changed, and a
## tree it may not write to (a read-only checkout) only loses the speed, never the install
install: $(STAMP)
	@$(BIN)/python -m compileall -q -j 0 aion_cli formats > /dev/null 2>&1 || true

lint: $(STAMP)
	$(BIN)/ruff check .

typecheck: $(STAMP)
	$(BIN)/mypy

pytest: install
	$(BIN)/pytest

## make test: create .venv, install, run ruff, mypy and pytest
test: lint typecheck pytest

## make demo: build a map from the bundled sample, predict, plan, export
demo: install system-deps
	bash samples/demo.sh $(BIN) $(DEMO)

## make bench: speed and memory benchmarks (not part of make test)
bench: install
	$(BIN)/python -m benchmarks.run

## make sample: regenerate samples/ from the simulator
sample: $(STAMP)
	bash samples/regenerate.sh $(BIN)

clean:
	rm -rf $(VENV) $(DEMO) .pytest_cache .mypy_cache .ruff_cache
	find aion_cli formats -name __pycache__ -type d -prune -exec rm -rf {} +
