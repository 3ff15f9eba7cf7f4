# Everything the project needs installs from its own files into .venv.
# The versions come from constraints.txt, the set the tests last passed with: a new release
# upstream changes nothing until `make constraints` takes it in.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
CONSTRAINTS := constraints.txt

.PHONY: setup demo test test-fast lint bench constraints clean

$(BIN)/.installed: pyproject.toml $(CONSTRAINTS)
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --upgrade pip
	$(BIN)/python -m pip install -c $(CONSTRAINTS) -e '.[dev]'
	# bytecode now: a shell with PYTHONDONTWRITEBYTECODE set would compile every module
	# from source at every start (about 0.2 s per command)
	$(BIN)/python -m compileall -q sim fcu gcs flightdata jitsupport
	touch $@

# every kernel compiled (or, when the cache is current, loaded: about 2 s), so that no command
# compiles on its first run; after a git pull that changed kernel code it compiles that again
setup: $(BIN)/.installed
	$(BIN)/ftc-vehicle --precompile

demo: setup
	$(BIN)/ftc-gcs demo

# one worker per CPU (at most 4); a module's tests stay on one worker (its fixtures, its ports)
test: lint
	$(BIN)/python -m pytest -q -n auto --maxprocesses 4 --dist loadscope

# everything but the whole flights (tests marked slow, see tests/conftest.py)
test-fast: setup
	$(BIN)/python -m pytest -q -m "not slow" -n auto

lint: setup
	$(BIN)/ruff check sim fcu gcs flightdata jitsupport tests
	$(BIN)/mypy sim fcu gcs flightdata jitsupport

bench: setup
	$(BIN)/python -m pip install -c $(CONSTRAINTS) -e '.[bench]'
	$(BIN)/ftc-bench

# constraints.txt afresh: the newest releases pyproject.toml admits (with the bench extra), in a
# scratch environment; then run make clean test, and commit the file if the tests pass
constraints:
	rm -rf .venv-constraints
	$(PY) -m venv .venv-constraints
	.venv-constraints/bin/python -m pip install --upgrade pip
	.venv-constraints/bin/python -m pip install -e '.[dev,bench]'
	( echo "# The versions make setup installs: the newest releases pyproject.toml admitted when the"; \
	  echo "# file was written, with which make test passed (make constraints writes it afresh)."; \
	  .venv-constraints/bin/python -m pip freeze --exclude-editable | sort -f ) > $(CONSTRAINTS).new
	mv $(CONSTRAINTS).new $(CONSTRAINTS)
	rm -rf .venv-constraints

clean:
	rm -rf $(VENV) build *.egg-info
