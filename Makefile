# Everything the project needs installs from its own files into .venv.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin

.PHONY: setup demo test test-fast lint bench clean

$(BIN)/.installed: pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --upgrade pip
	$(BIN)/python -m pip install -e '.[dev]'
	# bytecode now: a shell with PYTHONDONTWRITEBYTECODE set would compile every module
	# from source at every start (about 0.2 s per command)
	$(BIN)/python -m compileall -q sim fcu gcs flightdata
	touch $@

setup: $(BIN)/.installed

demo: setup
	$(BIN)/ftc-gcs demo

# one worker per CPU (at most 4); a module's tests stay on one worker (its fixtures, its ports)
test: setup
	$(BIN)/python -m pytest -q -n auto --maxprocesses 4 --dist loadscope

# everything but the whole flights (tests marked slow, see tests/conftest.py)
test-fast: setup
	$(BIN)/python -m pytest -q -m "not slow" -n auto

lint: setup
	$(BIN)/ruff check sim fcu gcs flightdata tests
	$(BIN)/mypy sim fcu gcs flightdata

bench: setup
	$(BIN)/ftc-bench

clean:
	rm -rf $(VENV) build *.egg-info
