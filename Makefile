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

## the package's files, listed again at every make and rewritten only when one is added or
## removed: a strict editable install (below) links each file, so a new module needs the
## install again, which this list's change brings about
FILES := $(VENV)/.package-files
$(shell mkdir -p $(VENV) && find aion_cli formats -name __pycache__ -prune -o -type f -print \
	| LC_ALL=C sort > $(FILES).new && (cmp -s $(FILES).new $(FILES) || mv $(FILES).new $(FILES)); \
	rm -f $(FILES).new)

## editable_mode=strict: a tree of links to the files (build/__editable__.*) on sys.path by a
## plain .pth line, which mypy and other type checkers follow; setuptools' default editable
## mode finds aion_cli through an import hook, which they cannot see ("Cannot find
## implementation or library stub for module named aion_cli" in a user's own script)
$(STAMP): pyproject.toml Makefile $(FILES)
	@bash .ci/system-deps.sh
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[test,export,dask]' --config-settings editable_mode=strict
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
	rm -rf $(VENV) $(DEMO) .pytest_cache .mypy_cache .ruff_cache build/__editable__.*
	find aion_cli formats -name __pycache__ -type d -prune -exec rm -rf {} +
